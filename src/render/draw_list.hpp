#pragma once
// What the renderer draws of the automata, as plain records and per-thread functions that a CPU loop and a
// CUDA thread run alike (MCA_HD, the same operations in the same order: the same bytes). The host builds
// its draw list from a State (snapshot.cpp); a backend that steps its own copy of the state on a device
// builds the same list there (Backend::draw_list), so that a frame needs no download of the state.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/math.hpp"
#include "core/model.hpp"

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

using Rgba = std::array<std::uint8_t, 4>;

struct Instance {
  float x, y, z;       // centre, relative to Snapshot::origin
  float qx, qy, qz, qw;  // orientation
  Rgba colour;
};

struct SurfaceVertex {
  float x, y, z;
  Rgba colour;
};

// The renderer's buffers that a backend writes its draw list into, where it can: zero copy (the paper's
// sec. 5.4). The CUDA backend registers them with CUDA (CUDA-OpenGL interop) and its kernels write them
// on the GPU; its host emulation maps them into host memory. Needs a GL context current that holds them.
class DrawTarget {
 public:
  enum Which { automata, surface };  // Instance records (drawn as cubes); SurfaceVertex, 3 per triangle
  // What a device keeps of a buffer it shares (the CUDA backend's registration with CUDA): held here, so
  // that it is released before the buffer is replaced or deleted.
  struct Shared {
    virtual ~Shared() = default;
  };
  virtual ~DrawTarget() = default;
  // Buffer `which` holding at least `bytes`: where it holds less, a new buffer (another GL name, its
  // contents undefined, its Shared released first) takes its place. Returns its size in bytes.
  virtual std::size_t reserve(Which which, std::size_t bytes) = 0;
  virtual unsigned buffer(Which which) const = 0;  // its GL name
  virtual std::unique_ptr<Shared>& shared(Which which) = 0;
  // Why a device could not share these buffers (empty: it has not refused): kept with them, so that a
  // backend does not try again each frame, and tries a new target afresh.
  virtual std::string& refused() = 0;
  // Its first `bytes` mapped into host memory for writing, until unmap.
  virtual void* map(Which which, std::size_t bytes) = 0;
  virtual void unmap(Which which) = 0;
};

// A backend's draw list of its current state (Backend::draw_list): the automata and surface of a
// Snapshot (snapshot.hpp) and what its legend and counters need.
struct DrawList {
  std::vector<Instance> automata;
  std::vector<float> radius;
  std::vector<SurfaceVertex> surface;
  // Written into a DrawTarget's buffers instead of `automata` and `surface` (their radius not kept: the
  // cubes and surface modes).
  std::size_t shared_automata = 0, shared_corners = 0;
  std::string shared_why;  // why a target given was not written (empty: it was, or none was given)
  std::vector<DVec3> projectiles;  // world positions
  std::int32_t fragments = 0;
  float largest = 0;       // stress and speed: the largest finite value (the scale when none is fixed)
  bool softening = false;  // the links soften (the damage legend says so)
};

// --- Colours ---

// 255 v rounded, v clamped to [0, 1] (the CPU's lround and CUDA's lroundf: the same exact rounding).
MCA_HD std::uint8_t colour_byte(float v) {
  v = v < 0.0f ? 0.0f : v > 1.0f ? 1.0f : v;
#if defined(__CUDA_ARCH__)
  return static_cast<std::uint8_t>(lroundf(255.0f * v));
#else
  return static_cast<std::uint8_t>(std::lround(255.0f * v));
#endif
}
MCA_HD Rgba rgb(float r, float g, float b) { return {colour_byte(r), colour_byte(g), colour_byte(b), 255}; }

// Piecewise-linear interpolation between N equally spaced stops (t outside [0, 1] clamped, not finite: 0).
template <std::size_t N>
MCA_HD Rgba ramp(const float (&stops)[N][3], float t) {
  t = t == t && t <= kFloatMax && t >= -kFloatMax ? (t < 0.0f ? 0.0f : t > 1.0f ? 1.0f : t) : 0.0f;
  const float x = t * (N - 1);
  std::size_t k = static_cast<std::size_t>(x);
  if (k > N - 2) k = N - 2;
  const float f = x - static_cast<float>(k);
  const float* a = stops[k];
  const float* b = stops[k + 1];
  return rgb(a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]), a[2] + f * (b[2] - a[2]));
}

// Concrete grey for intact, through orange to deep red where every link has broken.
MCA_HD Rgba ramp_damage(float t) {
  const float stops[4][3] = {{0.72f, 0.71f, 0.68f}, {0.98f, 0.80f, 0.25f}, {0.95f, 0.40f, 0.10f}, {0.65f, 0.05f, 0.05f}};
  return ramp(stops, t);
}

// Matplotlib's viridis at nine stops.
MCA_HD Rgba ramp_viridis(float t) {
  const float stops[9][3] = {{0.267f, 0.005f, 0.329f}, {0.283f, 0.141f, 0.458f}, {0.254f, 0.265f, 0.530f},
                             {0.207f, 0.372f, 0.553f}, {0.164f, 0.471f, 0.558f}, {0.128f, 0.567f, 0.551f},
                             {0.135f, 0.659f, 0.518f}, {0.267f, 0.749f, 0.441f}, {0.993f, 0.906f, 0.144f}};
  return ramp(stops, t);
}

// The paper colours automata by strength class (its Figs. 5-8): the weaker class blue against red
// (Venus, sec. 6), three classes yellow, green and red in the medium-heterogeneity bunny.
MCA_HD Rgba class_colour(int c) {
  switch (c) {
    case 1: return rgb(0.20f, 0.40f, 0.95f);
    case 2: return rgb(0.95f, 0.85f, 0.15f);
    case 3: return rgb(0.25f, 0.75f, 0.25f);
    default: return rgb(0.85f, 0.15f, 0.15f);
  }
}

// A colour from its hue h in [0, 6) (red, yellow, green, cyan, blue, magenta), saturation and value.
MCA_HD Rgba hsv(float h, float s, float v) {
  const int k = static_cast<int>(h);
  const float f = h - static_cast<float>(k), p = v * (1 - s), q = v * (1 - s * f), u = v * (1 - s * (1 - f));
  switch (k % 6) {
    case 0: return rgb(v, u, p);
    case 1: return rgb(q, v, p);
    case 2: return rgb(p, v, u);
    case 3: return rgb(p, q, v);
    case 4: return rgb(u, p, v);
    default: return rgb(v, p, q);
  }
}

// Fragment colours that stay with a piece from frame to frame (the fragment ids are renumbered by mass
// every frame): concrete grey for the main body of an object (a fragment holding more than half of its
// object's automata), else a hue from a hash of the piece's smallest automaton index.
MCA_HD Rgba main_body_colour() { return rgb(0.72f, 0.71f, 0.68f); }
MCA_HD Rgba piece_colour(std::uint32_t first_automaton) {
  // A well-mixed hash of the index (murmur3's finaliser): pieces that split from neighbouring automata get
  // far-apart hues; saturation and value vary a little so that close hues still differ.
  std::uint32_t x = first_automaton + 0x9e3779b9u;
  x ^= x >> 16;
  x *= 0x85ebca6bu;
  x ^= x >> 13;
  x *= 0xc2b2ae35u;
  x ^= x >> 16;
  return hsv(static_cast<float>(x & 0xffffu) / 65536.0f * 6.0f, 0.55f + 0.25f * static_cast<float>((x >> 16) & 0xffu) / 255.0f,
             0.80f + 0.15f * static_cast<float>(x >> 24) / 255.0f);
}

// Material k's colour: a categorical palette (well separated hues, readable on the dark background).
MCA_HD Rgba group_colour(std::size_t k) {
  const float palette[10][3] = {{0.30f, 0.55f, 0.85f}, {0.95f, 0.55f, 0.15f}, {0.35f, 0.75f, 0.35f},
                                {0.85f, 0.25f, 0.25f}, {0.65f, 0.45f, 0.80f}, {0.60f, 0.40f, 0.30f},
                                {0.90f, 0.50f, 0.75f}, {0.75f, 0.75f, 0.20f}, {0.20f, 0.75f, 0.80f},
                                {0.55f, 0.55f, 0.55f}};
  // Past ten: hues a golden angle apart, lighter and darker by turns (the palette repeated: the eleventh was the
  // first's colour).
  if (k >= 10) {
    const float turn = static_cast<float>(k) * 0.6180340f;
    return hsv(6.0f * (turn - static_cast<float>(static_cast<std::uint64_t>(turn))), 0.65f, k % 2 ? 0.70f : 0.92f);
  }
  const float* c = palette[k];
  return rgb(c[0], c[1], c[2]);
}

// The colour of an automaton's fragment: `first` its smallest automaton, `size` its automata, `whole` its
// object's.
MCA_HD Rgba fragment_colour(std::uint32_t first, std::size_t size, std::size_t whole) {
  return 2 * size > whole ? main_body_colour() : piece_colour(first);
}

// The continuous modes (stress, speed): the value's colour on a scale of 0 to top.
MCA_HD float finite_or_zero(float v) { return v == v && v <= kFloatMax && v >= -kFloatMax ? v : 0.0f; }
MCA_HD float speed_of(double vx, double vy, double vz) { return static_cast<float>(length(DVec3{vx, vy, vz})); }
MCA_HD Rgba scaled_colour(float v, double top) { return ramp_viridis(static_cast<float>(v / top)); }
// The top of the scale: the one fixed by the options, else the largest finite value, at least 1 kPa of
// stress or 1 mm/s of speed.
inline double colour_scale(const SnapshotOptions& o, float largest) {
  return o.scale_max > 0 ? o.scale_max : std::max<double>(largest, o.colour == ColourMode::stress ? 1e3 : 1e-3);
}

// --- Per automaton ---

// Per automaton, 1 where it carries triangles of the bound surface (drawn as those where the surface is).
inline std::vector<std::uint8_t> carrying_automata(const Model& model) {
  std::vector<std::uint8_t> carries(model.size(), 0);
  for (const std::uint32_t a : model.surface.automaton) carries[a] = 1;
  return carries;
}

// Per object index (Model::object), its automata (what fragment_colour's `whole` is).
inline std::vector<std::uint32_t> object_sizes(const Model& model) {
  std::vector<std::uint32_t> size(model.object_names.size() + 1, 0);
  for (const std::int32_t o : model.object) ++size[static_cast<std::size_t>(o)];
  return size;
}

// Whether automaton a can be seen: not enclosed by its neighbours' cubes (a cubic automaton with its six
// links, one of the random lattice boxed in (`boxed`, null for none) with all of its).
MCA_HD bool automaton_exposed(const AutomatonLinks& links, std::size_t a, const std::uint8_t* intact,
                              const std::uint8_t* boxed) {
  int sound = 0, all = 0;
  links.for_each(a, [&](std::size_t l) {
    sound += intact[l] != 0;
    ++all;
  });
  return boxed ? !boxed[a] || sound < all : sound < 6;
}

// The drawing frame's float coordinate of a world coordinate (origin subtracted in double).
MCA_HD float local(double x, double origin) { return static_cast<float>(x - origin); }

}  // namespace mca::render
