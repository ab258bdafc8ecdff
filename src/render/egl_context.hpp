#pragma once
// An offscreen OpenGL 4.5 core context through EGL, with no window and no display server: the first EGL
// device that gives one (a GPU, or Mesa's software device), else Mesa's surfaceless platform. Drawing goes
// into a framebuffer object (OffscreenTarget).
#include <string>

namespace mca::render {

class EglContext {
 public:
  // Creates the context and makes it current on this thread. Throws mca::Error saying what failed and
  // what to install when no EGL display or context can be had.
  EglContext();
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;
  // Which display gave the context ("EGL device 0", "Mesa surfaceless").
  const std::string& source() const { return source_; }

 private:
  void* display_ = nullptr;
  void* context_ = nullptr;
  std::string source_;
};

}  // namespace mca::render
