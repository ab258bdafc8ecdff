#pragma once
// What the renderer draws, taken from a Model and a State (read only) without any OpenGL: the automata
// to draw (position, orientation, colour), the projectiles, the bound surface, the links, the legend and
// the counters of the overlay. The live viewer's simulation thread builds one per shown frame and hands it
// to the window's thread, so drawing never touches the simulation's state.
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "analysis/fragments.hpp"
#include "backend/backend.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "render/draw_list.hpp"

namespace mca::render {

const char* name(ColourMode m);
const char* name(DrawMode m);
std::optional<ColourMode> parse_colour_mode(const std::string& text);
std::optional<DrawMode> parse_draw_mode(const std::string& text);
// "fragment, damage, ..." for messages.
std::string colour_mode_names();
std::string draw_mode_names();

// The colour scale of the legend: a continuous bar from min to max (damage, stress, speed) or named
// swatches (classes, groups); fragments list their count.
struct Legend {
  std::string title;
  bool continuous = false;
  double min = 0, max = 1;
  std::string unit;
  std::vector<std::pair<std::string, Rgba>> swatches;
  // Colour of a value t in [0, 1] along the bar.
  Rgba (*ramp)(float t) = nullptr;
};

struct Snapshot {
  std::array<double, 3> origin{};  // world position of the drawing frame's origin (precision: see make_snapshot)
  float cube_size = 0;             // d: the side of an automaton's cube
  std::vector<Instance> automata;  // those to draw (the exposed ones unless all were asked for)
  std::vector<float> radius;       // per drawn automaton (spheres)
  std::vector<SurfaceVertex> surface;  // 3 per triangle
  std::vector<SurfaceVertex> links;    // 2 per intact link (links mode)
  // Zero copy: the automata (as cubes) and the surface's corners a backend wrote into a DrawTarget's GL
  // buffers (these names) in place of `automata` and `surface`; the renderer draws them from there (valid
  // until the next draw list is written into them).
  std::size_t shared_automata = 0, shared_corners = 0;
  unsigned shared_automata_buffer = 0, shared_surface_buffer = 0;
  // What is drawn, from the lists or the shared buffers.
  std::size_t drawn_automata() const { return shared_automata + automata.size(); }
  std::size_t triangles() const { return (shared_corners + surface.size()) / 3; }
  bool drawn_from_shared_buffers() const { return shared_automata + shared_corners > 0; }
  struct Ball {
    float x, y, z, radius;
  };
  std::vector<Ball> projectiles;
  bool ground = false;
  std::array<float, 3> up{0, 0, 1};
  float ground_height = 0;  // along up, relative to the origin
  Legend legend;
  // Overlay counters.
  double time = 0;
  std::int64_t step = 0, broken_links = 0;
  std::int32_t fragments = 0;
  std::size_t automata_total = 0;
};

// `origin`: subtracted from every position before rounding to float (positions are double: a scene far
// from the world origin keeps its detail); the camera uses the same origin.
Snapshot make_snapshot(const Model& model, const State& state, const analysis::Fragments& fragments,
                       const SnapshotOptions& options, const std::array<double, 3>& origin);

// The same of a backend's current state: from its draw list where it builds one (the CUDA backend, on
// the device: no download of the state), else from its state (fragments labelled here). With a target
// (Renderer::draw_target, its GL context current), the backend writes the cubes and the surface straight
// into the renderer's buffers where it can (Snapshot::shared_automata, shared_corners; *why_not, where
// given, says why it did not).
Snapshot make_snapshot(const Model& model, const Backend& backend, const SnapshotOptions& options,
                       const std::array<double, 3>& origin, DrawTarget* target = nullptr, std::string* why_not = nullptr);

// The legend of a colour mode: `softening`, the links soften (damage); `largest`, the largest value drawn
// (stress, speed: the scale when the options fix none).
Legend make_legend(const Model& model, const SnapshotOptions& options, bool softening, double largest);

// The automata that can be seen: those without all six lattice links intact (at most six links; any
// broken or missing one opens a face). Per automaton, 1 = exposed.
std::vector<std::uint8_t> exposed_automata(const Model& model, const State& state);

// Per automaton, the colour of its fragment (fragment_colour).
std::vector<Rgba> fragment_colours(const Model& model, const analysis::Fragments& fragments);

}  // namespace mca::render
