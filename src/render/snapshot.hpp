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
#include "core/model.hpp"
#include "core/state.hpp"

namespace mca::render {

// How the automata are coloured.
enum class ColourMode { fragment, damage, strength_class, group, stress, speed };
// What is drawn for the objects.
enum class DrawMode {
  cubes,     // each automaton a cube of side d, turned by its quaternion
  spheres,   // each automaton a sphere of its radius (impostors: one quad each)
  surface,   // the bound surface of the mesh objects (analysis::posed_surface); automata elsewhere
  links,     // the intact links as lines
};

const char* name(ColourMode m);
const char* name(DrawMode m);
std::optional<ColourMode> parse_colour_mode(const std::string& text);
std::optional<DrawMode> parse_draw_mode(const std::string& text);
// "fragment, damage, ..." for messages.
std::string colour_mode_names();
std::string draw_mode_names();

using Rgba = std::array<std::uint8_t, 4>;

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

struct Instance {
  float x, y, z;       // centre, relative to Snapshot::origin
  float qx, qy, qz, qw;  // orientation
  Rgba colour;
};

struct SurfaceVertex {
  float x, y, z;
  Rgba colour;
};

struct Snapshot {
  std::array<double, 3> origin{};  // world position of the drawing frame's origin (precision: see make_snapshot)
  float cube_size = 0;             // d: the side of an automaton's cube
  std::vector<Instance> automata;  // those to draw (the exposed ones unless all were asked for)
  std::vector<float> radius;       // per drawn automaton (spheres)
  std::vector<SurfaceVertex> surface;  // 3 per triangle
  std::vector<SurfaceVertex> links;    // 2 per intact link (links mode)
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

struct SnapshotOptions {
  DrawMode draw = DrawMode::cubes;
  ColourMode colour = ColourMode::fragment;
  // Draw every automaton, not only the exposed ones (an automaton with all six lattice links intact is
  // enclosed by its neighbours' cubes and cannot be seen).
  bool all_automata = false;
  // Scale of the continuous colour modes: fixed over a run so colours compare between frames. 0: from
  // this state (the largest value, at least a small floor).
  double scale_max = 0;
};

// `origin`: subtracted from every position before rounding to float (positions are double: a scene far
// from the world origin keeps its detail); the camera uses the same origin.
Snapshot make_snapshot(const Model& model, const State& state, const analysis::Fragments& fragments,
                       const SnapshotOptions& options, const std::array<double, 3>& origin);

// The automata that can be seen: those without all six lattice links intact (at most six links; any
// broken or missing one opens a face). Per automaton, 1 = exposed.
std::vector<std::uint8_t> exposed_automata(const Model& model, const State& state);

// Colour ramps of the continuous modes, t in [0, 1].
Rgba ramp_damage(float t);
Rgba ramp_viridis(float t);
// The paper's colours of the strength classes 1..4 (weakest to strongest): blue, yellow, green, red.
Rgba class_colour(int strength_class);
// Fragment colours that stay with a piece from frame to frame (the fragment ids are renumbered by mass
// every frame): concrete grey for the main body of an object (a fragment holding more than half of its
// object's automata), else a hue from a hash of the piece's smallest automaton index.
Rgba main_body_colour();
Rgba piece_colour(std::uint32_t first_automaton);
// Per automaton, the colour of its fragment as above.
std::vector<Rgba> fragment_colours(const Model& model, const analysis::Fragments& fragments);

}  // namespace mca::render
