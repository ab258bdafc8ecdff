#pragma once
// The OpenGL 4.5 core renderer, shared by the offscreen (EGL) and windowed (GLFW) front ends: draws a
// Snapshot through a Camera into the framebuffer bound at the call, with the ground, the projectiles and
// an overlay (counters, legend). Needs a current GL 4.5 core context (libepoxy loads the functions).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "render/camera.hpp"
#include "render/snapshot.hpp"

namespace mca::render {

struct Overlay {
  bool counters = true;  // time, broken links, fragments (top left)
  bool legend = true;    // the colour scale (bottom left)
  std::vector<std::string> lines;  // extra lines under the counters (the viewer's fps, shot settings)
  double time_resolution = 0;      // the time between the frames shown, which the time's decimals show (s; 0:
                                   // three digits of the time: text::sim_time)
};

// Buffers that a backend writes its draw list into (render::DrawTarget; make_snapshot with a target):
// immutable storage, which CUDA can register and the host can map for writing, replaced by a larger one
// when a list outgrows it. Made, used and destroyed with a GL context current that holds them (the
// renderer's, or one sharing its objects).
class SharedBuffers final : public DrawTarget {
 public:
  SharedBuffers() = default;
  SharedBuffers(const SharedBuffers&) = delete;
  SharedBuffers& operator=(const SharedBuffers&) = delete;
  ~SharedBuffers() override;
  std::size_t reserve(Which w, std::size_t bytes) override;
  unsigned buffer(Which w) const override { return name_[w]; }
  std::unique_ptr<Shared>& shared(Which w) override { return shared_[w]; }
  std::string& refused() override { return refused_; }
  void* map(Which w, std::size_t bytes) override;
  void unmap(Which w) override;

 private:
  unsigned name_[2] = {0, 0};
  std::size_t size_[2] = {0, 0};
  std::unique_ptr<Shared> shared_[2];
  std::string refused_;
};

class Renderer {
 public:
  // Compiles the shaders and makes the buffers. Throws mca::Error when the context is not OpenGL 4.5
  // core or a shader does not compile.
  Renderer();
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Draws into the bound framebuffer's (0, 0, width, height).
  void draw(const Snapshot& snapshot, DrawMode mode, const Camera& camera, int width, int height,
            const Overlay& overlay = {});

  // Buffers of its own that a backend writes its draw list into (zero copy: make_snapshot with a target,
  // then draw).
  DrawTarget& draw_target();

  // "OpenGL 4.5 (Core Profile) Mesa ..., llvmpipe ..." for messages and benchmarks.
  static std::string gl_description();

 private:
  struct Impl;
  Impl* impl_;
};

// The pixels of the bound read framebuffer's (0, 0, width, height) as RGBA, top row first (OpenGL's rows
// run bottom up); waits for the drawing to finish.
void read_pixels(int width, int height, std::vector<std::uint8_t>& out);

// An offscreen colour + depth framebuffer of a fixed size.
class OffscreenTarget {
 public:
  OffscreenTarget(int width, int height);
  ~OffscreenTarget();
  OffscreenTarget(const OffscreenTarget&) = delete;
  OffscreenTarget& operator=(const OffscreenTarget&) = delete;
  void bind() const;
  int width() const { return width_; }
  int height() const { return height_; }
  // The pixels as RGBA, top row first (waits for the drawing to finish).
  void read_rgba(std::vector<std::uint8_t>& out) const;

 private:
  int width_, height_;
  unsigned fbo_ = 0, colour_ = 0, depth_ = 0;
};

}  // namespace mca::render
