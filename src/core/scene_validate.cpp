// The one place that checks a SceneDef. Parsing (src/io) checks syntax and types; this checks ranges
// and references, so that scenes built in C++ get the same messages as scenes read from TOML.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <string>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include <fmt/format.h>

#include <mca/error.hpp>
#include <mca/scene.hpp>

#include "core/text.hpp"

namespace mca {

namespace {

using text::escaped;
using text::num;
using text::suggestion;

std::string vec(const Vec3d& v) { return fmt::format("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2])); }

// A coefficient the solver keeps in float32 (a friction of 1e39 became infinite there).
constexpr double kFloatMax = std::numeric_limits<float>::max();
constexpr const char* kFrictionRange = ">= 0 and at most 3.4e38 (the largest float32)";

class Checker {
 public:
  explicit Checker(const SceneDef& scene) : scene_(scene) {}

  [[noreturn]] void fail(const std::string& message) const {
    throw Error(fmt::format("{}: {}", scene_.source, message));
  }

  void finite(const std::string& key, double v) const {
    if (!std::isfinite(v)) fail(fmt::format("{} = {} is not a finite number; give a finite value", key, num(v)));
  }
  void finite(const std::string& key, const Vec3d& v) const {
    for (double x : v) {
      if (!std::isfinite(x)) fail(fmt::format("{} = {} has a non-finite component; give finite values", key, vec(v)));
    }
  }
  // Positions within 1e6 m of the origin (a distance, as docs/scene-format.md says): there a double
  // resolves 1e-10 m, a strain of 2e-9 on a 5 cm link; further out the rounding of the centres shows in
  // the strains (at 1e7 m a body at rest starts strained).
  // (hypot: the squares of 1e308 overflowed, and the message said "inf m from the origin".)
  void position(const std::string& key, const Vec3d& v) const {
    finite(key, v);
    const double r = std::hypot(v[0], v[1], v[2]);
    if (r > 1e6)
      fail(fmt::format("{} = {} is {} m from the origin, more than 1e6 m from the origin, where the solver's double "
                       "positions no longer resolve small strains; move the scene's origin near the objects",
                       key, vec(v), num(r)));
  }
  // A height along the up axis (the ground's), as a number.
  void position(const std::string& key, double h) const {
    finite(key, h);
    if (std::fabs(h) > 1e6)
      fail(fmt::format("{} = {} is more than 1e6 m from the origin, where the solver's double positions no longer "
                       "resolve small strains; move the scene's origin near the objects",
                       key, num(h)));
  }

  // Checks lo < v (or lo <= v) and v < hi (or v <= hi); the range text and the fix go in the message.
  void range(const std::string& key, double v, double lo, bool lo_closed, double hi, bool hi_closed,
             const std::string& range_text, const std::string& fix) const {
    const bool ok = std::isfinite(v) && (lo_closed ? v >= lo : v > lo) && (hi_closed ? v <= hi : v < hi);
    if (!ok)
      fail(fmt::format("{} = {} is out of range: must be {}{}; {}", key, num(v), std::isfinite(v) ? "" : "a finite number ",
                       range_text, fix));
  }
  void positive(const std::string& key, double v, const std::string& fix) const {
    range(key, v, 0.0, false, INFINITY, false, "> 0", fix);
  }
  void non_negative(const std::string& key, double v, const std::string& fix) const {
    range(key, v, 0.0, true, INFINITY, false, ">= 0", fix);
  }
  // A file's path without control characters: a NUL ended it early ("x.obj\0.stl" opened x.obj; a scene
  // built in Python), a line break broke the messages naming it (the scene file's reader refuses them too).
  void file_path(const std::string& key, const std::string& path) const {
    if (std::any_of(path.begin(), path.end(), text::is_control))
      fail(fmt::format("{} holds a control character (a line break, tab or NUL); give the mesh file's path", key));
  }

 private:
  const SceneDef& scene_;
};

void check_material(const Checker& c, const MaterialDef& m, std::size_t i) {
  const std::string p = fmt::format("material[{}]", i);
  if (m.name.empty()) c.fail(fmt::format("{}.name is empty; give the material a name objects can refer to", p));
  // Quoting the name after the key path lets a user find the [[material]] block either way.
  const std::string q = fmt::format("(material \"{}\")", m.name);
  // The key path comes first in the message, then the value, then the name.
  auto range = [&](const char* k, double v, double lo, bool lc, double hi, bool hc, const std::string& text,
                   const std::string& fix) {
    const bool ok = std::isfinite(v) && (lc ? v >= lo : v > lo) && (hc ? v <= hi : v < hi);
    if (!ok)
      c.fail(fmt::format("{}.{} = {} {} is out of range: must be {}{}; {}", p, k, num(v), q,
                         std::isfinite(v) ? "" : "a finite number ", text, fix));
  };
  // Physical ranges: from soft rubber to diamond, from aerogel to osmium. Beyond them the numbers are
  // a unit mistake, and their products (masses, stiffnesses, time steps) leave what float32 holds.
  range("youngs_modulus", m.youngs_modulus, 1e3, true, 1e13, true, "in [1e3, 1e13] [Pa]",
        "use e.g. 30e9 for concrete, 200e9 for steel (the unit is Pa, not GPa)");
  range("poisson_ratio", m.poisson_ratio, -1, false, 0.5, false, "in (-1, 0.5) (0.5 is incompressible)",
        "use e.g. 0.2 for concrete");
  range("density", m.density, MaterialDef::kMinDensity, true, MaterialDef::kMaxDensity, true,
        fmt::format("in [{}, {}] [kg/m^3]", num(MaterialDef::kMinDensity), num(MaterialDef::kMaxDensity)),
        "use e.g. 2400 for concrete");
  range("tensile_strength", m.tensile_strength, 0, false, INFINITY, false, "> 0 [Pa]",
        "use e.g. 3e6 for concrete (the unit is Pa, not MPa)");
  if (!std::isfinite(m.compressive_strength) || m.compressive_strength < m.tensile_strength) {
    c.fail(fmt::format("{}.compressive_strength = {} {} is out of range: must be >= tensile_strength = {} [Pa]; "
                       "brittle materials are about 10x stronger in compression (concrete: 30e6); set it equal "
                       "to tensile_strength for a von Mises criterion",
                       p, num(m.compressive_strength), q, num(m.tensile_strength)));
  }
  range("fracture_strain", m.fracture_strain, 0, false, INFINITY, false, "> 0",
        "use about 1.5 x tensile_strength / youngs_modulus so the stress criterion governs in slow tension");
  range("friction", m.friction, 0, true, kFloatMax, true, kFrictionRange, "use e.g. 0.6 for concrete, 0 for frictionless");
  range("restitution", m.restitution, 0.01, true, 1, true, "in [0.01, 1]",
        "use e.g. 0.2 for concrete, 1 for elastic (below 0.01 the contact dashpot would have to be so stiff that "
        "it sets the time step)");
  range("rolling_friction", m.rolling_friction, 0, true, 1, true, "in [0, 1]",
        "use 0.3 (the default) for debris that stops rolling, 0 for none");
  range("twisting_friction", m.twisting_friction, 0, true, 1, true, "in [0, 1]",
        "use 0.3 (the default), 0 for none");
  range("damping_time", m.damping_time, 0, true, 1e-3, true, "in [0, 1e-3] [s]",
        "use 5e-6 (the default: damps the lattice-scale ringing of impacts), 0 for an undamped material");
  range("strengthening_alpha", m.strengthening_alpha, 0, true, INFINITY, false, ">= 0",
        "use 0 for linear elasticity");
  range("fracture_energy", m.fracture_energy, 0, true, 1e6, true, "in [0, 1e6] [J/m^2]",
        "use e.g. 100 for concrete, 0 for the paper's instant break (the unit is J/m^2 = N/m)");
  if (!(m.weibull_modulus == 0 || (m.weibull_modulus >= 1 && m.weibull_modulus <= 100))) {
    c.fail(fmt::format("{}.weibull_modulus = {} {} is out of range: must be 0 (no spread) or in [1, 100]; use e.g. 6 "
                       "for concrete (a spread of about 20 % between links)",
                       p, num(m.weibull_modulus), q));
  }
  switch (m.strengthening) {
    case StrengtheningLaw::none:
    case StrengtheningLaw::exponential:
    case StrengtheningLaw::quadratic:
      break;
    default:
      c.fail(fmt::format("{}.strengthening {} is not a known law; use \"none\", \"exponential\" or \"quadratic\"", p, q));
  }
}

void check_heterogeneity(const Checker& c, const HeterogeneityDef& h, const std::string& p) {
  static const std::vector<std::string> presets = {"none", "low", "medium", "high", "custom"};
  if (std::find(presets.begin(), presets.end(), h.preset) == presets.end()) {
    c.fail(fmt::format("{}.preset = \"{}\" is not a preset{}; use none, low, medium or high, or give shares", p,
                       h.preset, suggestion(h.preset, presets)));
  }
  const std::string shares = fmt::format("[{}, {}, {}, {}]", num(h.shares[0]), num(h.shares[1]), num(h.shares[2]),
                                         num(h.shares[3]));
  double sum = 0.0;
  for (std::size_t i = 0; i < 4; ++i) {
    if (!std::isfinite(h.shares[i]) || h.shares[i] < 0.0) {
      c.fail(fmt::format("{}.shares = {}: share of class {} is {}, must be >= 0; shares are fractions of the "
                         "automata in strength classes 1..4, e.g. [0, 0.15, 0.2, 0.65]",
                         p, shares, i + 1, num(h.shares[i])));
    }
    sum += h.shares[i];
  }
  if (std::fabs(sum - 1.0) > 1e-6) {
    c.fail(fmt::format("{}.shares = {} sum to {}, must sum to 1 (within 1e-6); they are fractions, not "
                       "percentages: e.g. [0, 0.15, 0.2, 0.65]",
                       p, shares, num(sum)));
  }
  if (h.preset != "custom") {
    std::array<double, 4> expected{};
    heterogeneity_preset(h.preset, expected);
    if (expected != h.shares) {
      c.fail(fmt::format("{}.preset = \"{}\" but shares = {} are not that preset's; fill shares with "
                         "mca::heterogeneity_preset(), or set preset = \"custom\"",
                         p, h.preset, shares));
    }
  }
  const std::string factors = fmt::format("[{}, {}, {}, {}]", num(h.class_factors[0]), num(h.class_factors[1]),
                                          num(h.class_factors[2]), num(h.class_factors[3]));
  for (std::size_t i = 0; i < 4; ++i) {
    if (!std::isfinite(h.class_factors[i]) || h.class_factors[i] <= 0.0) {
      c.fail(fmt::format("{}.class_factors = {}: factor of class {} is {}, must be > 0; the default is "
                         "[0.25, 0.5, 0.75, 1]",
                         p, factors, i + 1, num(h.class_factors[i])));
    }
    if (i > 0 && h.class_factors[i] < h.class_factors[i - 1]) {
      c.fail(fmt::format("{}.class_factors = {} must be non-decreasing (class 1 is the weakest); the default is "
                         "[0.25, 0.5, 0.75, 1]",
                         p, factors));
    }
  }
  c.non_negative(p + ".grain_size", h.grain_size,
                 "use 0 for classes drawn per automaton, or a grain size in metres (a few lattice spacings)");
}

}  // namespace

// The lowest Poisson ratio the cubic lattice is stable at (measured: bodies at rest from 1 x 1 x 2 to
// 6 x 6 x 6 automata, plates and lines, jittered or not, on the ground; the default wall struck), and
// the lowest surface mode's shells take (a sphere's shell dropped 1.3 mm onto the ground broke 70 of its
// 480 links at -0.9, all at -0.95, none from -0.85 up).
constexpr double kCubicMinPoisson = -0.2;
constexpr double kSurfaceMinPoisson = -0.8;

const MaterialDef& resolve_material(const SceneDef& scene, const std::string& name, const std::string& key) {
  for (const MaterialDef& m : scene.materials) {
    if (m.name == name) return m;
  }
  if (const MaterialDef* m = find_builtin_material(name)) return *m;
  std::vector<std::string> names;
  for (const MaterialDef& m : scene.materials) names.push_back(m.name);
  for (const MaterialDef& m : builtin_materials()) {
    if (std::find(names.begin(), names.end(), m.name) == names.end()) names.push_back(m.name);
  }
  std::string hint = text::did_you_mean(name, names);
  if (hint.empty()) hint = fmt::format("; known materials: {}", fmt::join(names, ", "));
  throw Error(fmt::format("{}: {} = \"{}\" is not a known material{} (define others in [[material]] blocks)",
                          scene.source, key, name, hint));
}

void validate_scene(const SceneDef& scene) {
  const Checker c(scene);
  // The name titles the run's pictures, windows and summary, and a Blender import's collection (which a
  // NUL cut short).
  if (std::any_of(scene.name.begin(), scene.name.end(), text::is_control))
    c.fail(fmt::format("name = \"{}\" has a control character (a line break, tab or NUL); name the scene with "
                       "printable characters", escaped(scene.name)));

  // Solver.
  // The spacing is stored in float32, and memory and counts go with its cube: 1e-300 became a spacing of
  // 0 and "inf GB" in the messages. Below a nanometre a lattice of continuum cells means nothing.
  c.range("solver.spacing", scene.solver.spacing, SolverDef::kMinSpacing, true, SolverDef::kMaxSpacing, true,
          "in [1e-9, 1e9] [m]",
          "give the lattice spacing in metres, e.g. 0.05");
  // 1.8e8 automata is the most a model holds (links are addressed with 29 bits); a larger target would
  // only make the search for its spacing count lattices of absurd size.
  if (scene.solver.target_automata > SolverDef::kMaxAutomata) {
    c.fail(fmt::format("solver.target_automata = {} is out of range: at most {} (1.8e8) automata fit a model; give a "
                       "smaller target",
                       scene.solver.target_automata, SolverDef::kMaxAutomata));
  }
  if (scene.solver.target_automata > 0 && !scene.objects.empty() &&
      std::all_of(scene.objects.begin(), scene.objects.end(),
                  [](const ObjectDef& o) { return o.shape == Shape::mesh && o.fill == MeshFill::surface; })) {
    c.fail(fmt::format("solver.target_automata = {} sets the lattice spacing, but every object is filled in surface "
                       "mode, one automaton per triangle; remove solver.target_automata (or remesh the model to the "
                       "triangle count you want)",
                       scene.solver.target_automata));
  }
  if (scene.solver.target_automata < 0) {
    c.fail(fmt::format("solver.target_automata = {} is out of range: must be >= 0; use 0 to take solver.spacing "
                       "as given",
                       scene.solver.target_automata));
  }
  c.range("solver.safety", scene.solver.safety, 0, false, 1, true,
          "in (0, 1] (the share of the critical time step; 1 is the stability limit of the linear lattice)",
          "use 0.5 (the default)");
  c.range("solver.mass_scaling", scene.solver.mass_scaling, 0, true, 1, true,
          "in [0, 1] (the share of the object's median critical step below which surface-mode automata get mass; "
          "0: none)",
          "use 0.7 (the default) or 0 to keep the meshes' own masses");
  if (scene.solver.time_step != 0)
    c.range("solver.time_step", scene.solver.time_step, 1e-12, true, 1, true, "0 (automatic) or in [1e-12, 1] [s]",
            "use 0 for the automatic step");
  c.finite("solver.gravity", scene.solver.gravity);
  if (std::sqrt(scene.solver.gravity[0] * scene.solver.gravity[0] + scene.solver.gravity[1] * scene.solver.gravity[1] +
                scene.solver.gravity[2] * scene.solver.gravity[2]) > 1e4) {
    c.fail(fmt::format("solver.gravity = {} is stronger than 1e4 m/s^2 (1000 g); use e.g. [0, 0, -9.81]",
                       vec(scene.solver.gravity)));
  }
  c.range("solver.link_damping", scene.solver.link_damping, 0, true, 1, true, "in [0, 1] (share of critical)",
          "use 0 for none, or a few per cent (0.02)");
  c.range("solver.local_damping", scene.solver.local_damping, 0, true, 0.2, true, "in [0, 0.2]",
          "use 0 for none; Cundall's local damping is usually 0.05 to 0.2 for quasi-static runs");
  // Bounded: at 1e-30, (c sigma_t)^2, in float32 in the softening law, underflowed to 0 and a softening
  // material could not break. c is of order 1 (the paper's K_v).
  c.range("solver.stress_coefficient", scene.solver.stress_coefficient, 1e-3, true, 1e3, true, "in [1e-3, 1e3]",
          "use 1 (the default)");
  c.range("solver.lattice_jitter", scene.solver.lattice_jitter, 0, true, 0.3, true, "in [0, 0.3] (share of the spacing)",
          "use 0 for the paper's cubic lattice (for cracks that do not follow the lattice's planes, lattice = "
          "\"random\", the default, not jitter)");
  if (scene.solver.lattice == SolverDef::Lattice::random && scene.solver.lattice_jitter > 0) {
    c.fail(fmt::format("solver.lattice_jitter = {} moves the sites of the cubic lattice, and solver.lattice is "
                       "\"random\" (the default since 2026-12-03), whose sites are random already; to jitter the "
                       "cubic lattice add lattice = \"cubic\" to [solver], or remove lattice_jitter",
                       num(scene.solver.lattice_jitter)));
  }
  // (Below 0.01 the springs hold next to nothing, and their moments run into float's subnormals: a run at
  // 1e-42 took twice as long as one at 0 for the same result.)
  const double bending = scene.solver.link_bending;
  if (bending != 0) {
    c.range("solver.link_bending", bending, 0.01, true, 1, true,
            "0, or in [0.01, 1] (share of a beam of the link's section)", "use 0.1 (the default, calibrated), or 0 for none");
  }
  if (scene.solver.lattice == SolverDef::Lattice::cubic && bending > 0 && bending != SolverDef{}.link_bending) {
    c.fail(fmt::format("solver.link_bending = {} sets the random lattice's bending springs, and solver.lattice is "
                       "\"cubic\", whose links have none (the paper's model); remove link_bending (or set it to 0, "
                       "or to its default 0.1), or use lattice = \"random\"",
                       num(bending)));
  }
  // Automata with six intact links are left out of the contact search: their nearest unlinked
  // neighbours sit at sqrt(2) d, out of reach only while r_i + r_j + skin = d + skin < sqrt(2) d.
  c.range("solver.skin", scene.solver.skin, 0, false, 0.4, true, "in (0, 0.4] (share of the spacing; above about "
          "0.41 the diagonal neighbours of an intact automaton would enter the contact search, which skips them)",
          "use 0.3 (the default)");
  c.positive("solver.max_memory_gb", scene.solver.max_memory_gb, "give the memory limit in GB, e.g. 16");

  // Output.
  c.positive("output.duration", scene.output.duration, "give the simulated time in seconds, e.g. 0.05");
  // A frame takes at least a step, and a step is at least 1e-12 s (solver.time_step); 1e300 made a step of
  // 0 s in float32.
  c.range("output.frame_rate", scene.output.frame_rate, 0, false, 1e12, true, "in (0, 1e12] [1/s]",
          "give output frames per simulated second, e.g. 500");
  if (scene.output.surface &&
      std::none_of(scene.objects.begin(), scene.objects.end(), [](const ObjectDef& o) { return o.shape == Shape::mesh; })) {
    c.fail("output.surface = true, but no object is a mesh: the surface written is that of the mesh objects; add an "
           "object with shape = \"mesh\" or remove output.surface (the automata are in the VTK frames)");
  }
  if (scene.output.fragment_min_automata < 0) {
    c.fail(fmt::format("output.fragment_min_automata = {} is out of range: must be >= 0 (fragments of more automata "
                       "than this get a mesh; 0: every fragment); use e.g. 8",
                       scene.output.fragment_min_automata));
  }
  if (scene.output.checkpoint_every < 0) {
    c.fail(fmt::format("output.checkpoint_every = {} is out of range: must be >= 0; use 0 for no checkpoints or "
                       "a number of frames",
                       scene.output.checkpoint_every));
  }

  // Materials.
  for (std::size_t i = 0; i < scene.materials.size(); ++i) {
    check_material(c, scene.materials[i], i);
    for (std::size_t j = 0; j < i; ++j) {
      if (scene.materials[j].name == scene.materials[i].name) {
        c.fail(fmt::format("material[{}].name = \"{}\" duplicates material[{}]; give each [[material]] a distinct "
                           "name",
                           i, scene.materials[i].name, j));
      }
    }
  }

  check_heterogeneity(c, scene.heterogeneity, "heterogeneity");

  // Objects.
  if (scene.objects.empty()) {
    c.fail("the scene has no objects; add at least one [[object]] block (e.g. shape = \"box\", size = [2, 0.2, "
           "1.5], material = \"concrete\")");
  }
  std::unordered_map<std::string_view, std::size_t> object_names;
  for (std::size_t i = 0; i < scene.objects.size(); ++i) {
    const ObjectDef& o = scene.objects[i];
    const std::string p = fmt::format("object[{}]", i);
    if (o.name.empty()) c.fail(fmt::format("{}.name is empty; give the object a name", p));
    // A map, not a loop over the earlier objects: a scene of 40,000 objects is checked in milliseconds.
    if (const auto [it, fresh] = object_names.emplace(o.name, i); !fresh) {
      c.fail(fmt::format("{}.name = \"{}\" duplicates object[{}]; give each [[object]] a distinct name", p, o.name,
                         it->second));
    }
    switch (o.shape) {
      case Shape::box:
        for (double s : o.size) {
          if (!std::isfinite(s) || s <= 0.0) {
            c.fail(fmt::format("{}.size = {} is out of range: every extent must be > 0 [m]; give the full box "
                               "extents, e.g. [2, 0.2, 1.5]",
                               p, vec(o.size)));
          }
        }
        break;
      case Shape::sphere:
        c.positive(p + ".radius", o.radius, "give the sphere radius in metres");
        break;
      case Shape::cylinder:
        c.positive(p + ".radius", o.radius, "give the cylinder radius in metres");
        c.positive(p + ".height", o.height, "give the cylinder height in metres (along its local z axis)");
        break;
      case Shape::mesh:
        if (o.mesh.empty()) {
          c.fail(fmt::format("{} has shape = \"mesh\" but no mesh file; add mesh = \"path\" (OBJ, PLY, STL, OFF, glTF; "
                             "relative to the scene file)",
                             p));
        }
        c.file_path(p + ".mesh", o.mesh);
        c.positive(p + ".scale", o.scale, "give the factor from the file's units to metres, e.g. 0.001 for millimetres");
        if (!std::isfinite(o.fit_size) || o.fit_size < 0) {
          c.fail(fmt::format("{}.fit_size = {:g} is out of range: it must be > 0 [m] (the largest extent the mesh is "
                             "scaled to), or 0 for none",
                             p, o.fit_size));
        }
        if (o.fit_size > 0 && o.scale != 1.0) {
          c.fail(fmt::format("{} gives both scale = {:g} and fit_size = {:g}; give one: scale multiplies the file's "
                             "coordinates, fit_size sets the largest extent",
                             p, o.scale, o.fit_size));
        }
        if (!std::isfinite(o.shell_thickness) || o.shell_thickness < 0) {
          c.fail(fmt::format("{}.shell_thickness = {:g} is out of range: it must be > 0 [m], or 0 for the mean "
                             "distance between linked triangles",
                             p, o.shell_thickness));
        }
        if (o.shell_thickness > 0 && o.fill != MeshFill::surface) {
          c.fail(fmt::format("{}.shell_thickness = {:g} is for fill = \"surface\" (a volume fill has no shell); add "
                             "fill = \"surface\" or remove shell_thickness",
                             p, o.shell_thickness));
        }
        break;
      default:
        c.fail(fmt::format("{}.shape is not a known shape; use \"box\", \"sphere\", \"cylinder\" or \"mesh\"", p));
    }
    if (o.shape != Shape::mesh && o.shell_thickness != 0) {
      c.fail(fmt::format("{}.shell_thickness = {:g} is for objects of shape \"mesh\" with fill = \"surface\"; remove "
                         "shell_thickness",
                         p, o.shell_thickness));
    }
    if (o.shape != Shape::mesh && o.fill == MeshFill::surface) {
      c.fail(fmt::format("{}.fill = \"surface\" is for objects of shape \"mesh\" (one automaton per triangle); remove "
                         "fill",
                         p));
    }
    if (o.shape != Shape::mesh && !o.mesh.empty()) {
      c.fail(fmt::format("{}.mesh is given but the shape is not \"mesh\"; add shape = \"mesh\" or remove mesh", p));
    }
    c.position(p + ".position", o.position);
    c.finite(p + ".rotation", o.rotation);
    // (An angle of 1e300 degrees was taken, modulo a turn, as whatever its rounding left.)
    for (double angle : o.rotation)
      if (std::fabs(angle) > 1e6)
        c.fail(fmt::format("{}.rotation = {} has an angle of more than 1e6 degrees (2,778 turns), which no model means "
                           "(a slip of the exponent?); give each angle in degrees, within [-360, 360]",
                           p, vec(o.rotation)));
    c.finite(p + ".velocity", o.velocity);
    // The cubic lattice (jittered or not) with a Poisson ratio below kCubicMinPoisson: its many-body term's
    // negative Lame lambda made bodies at rest fly apart (2 x 2 x 2 automata from -0.26, larger ones from
    // -0.5 to -0.7, every link broken at -0.99). Surface mode's shells from kSurfaceMinPoisson; the random
    // lattice takes the whole range.
    const bool surface = o.shape == Shape::mesh && o.fill == MeshFill::surface;
    const bool cubic_fill = scene.solver.lattice == SolverDef::Lattice::cubic && !surface;
    auto poisson_of_fill = [&](const MaterialDef& m, const std::string& key) {
      if (!(m.poisson_ratio > -1)) return;  // (out of range: said with the material)
      if (cubic_fill && m.poisson_ratio < kCubicMinPoisson) {
        c.fail(fmt::format("{} = \"{}\" has poisson_ratio = {}, and the cubic lattice (solver.lattice = \"cubic\") "
                           "is unstable below {} (a body at rest flies apart); give the material a ratio of {} or "
                           "more, or fill the object with the random lattice (lattice = \"random\" in [solver]{}), "
                           "which takes ratios down to -1",
                           key, m.name, num(m.poisson_ratio), kCubicMinPoisson, kCubicMinPoisson,
                           scene.solver.lattice_jitter > 0 ? ", and remove lattice_jitter" : ""));
      } else if (surface && m.poisson_ratio < kSurfaceMinPoisson) {
        c.fail(fmt::format("{} = \"{}\" has poisson_ratio = {}, and a surface-mode shell (fill = \"surface\") breaks "
                           "up below {} (a sphere's shell dropped 1.3 mm shattered at -0.95); give the material a "
                           "ratio of {} or more, or fill the mesh with the random lattice (remove fill = "
                           "\"surface\"; solver.lattice = \"random\", the default), which takes ratios down to -1",
                           key, m.name, num(m.poisson_ratio), kSurfaceMinPoisson, kSurfaceMinPoisson));
      }
    };
    poisson_of_fill(resolve_material(scene, o.material, p + ".material"), p + ".material");
    if (o.heterogeneity) check_heterogeneity(c, *o.heterogeneity, p + ".heterogeneity");
    for (std::size_t r = 0; r < o.regions.size(); ++r) {
      const RegionDef& g = o.regions[r];
      const std::string rp = fmt::format("{}.region[{}]", p, r);
      if (g.shape == Shape::box) {
        for (double s : g.size) {
          if (!std::isfinite(s) || s <= 0.0) {
            c.fail(fmt::format("{}.size = {} is out of range: every extent must be > 0 [m]", rp, vec(g.size)));
          }
        }
      } else if (g.shape == Shape::sphere) {
        c.positive(rp + ".radius", g.radius, "give the region's radius in metres");
      } else if (g.shape == Shape::mesh) {
        if (o.shape != Shape::mesh) {
          c.fail(fmt::format("{}.shape = \"mesh\" is only for objects of shape \"mesh\" (the region's mesh shares the "
                             "object mesh's units and frame); use a \"box\" or \"sphere\" region here",
                             rp));
        }
        if (g.mesh.empty()) c.fail(fmt::format("{} has shape = \"mesh\" but no mesh file; add mesh = \"path\"", rp));
        c.file_path(rp + ".mesh", g.mesh);
      } else {
        c.fail(fmt::format("{}.shape: a region is a \"box\", a \"sphere\" or a \"mesh\"", rp));
      }
      if (g.shape != Shape::mesh && !g.mesh.empty()) {
        c.fail(fmt::format("{}.mesh is given but the region's shape is not \"mesh\"; add shape = \"mesh\"", rp));
      }
      c.finite(rp + ".center", g.center);
      poisson_of_fill(resolve_material(scene, g.material, rp + ".material"), rp + ".material");
    }
  }

  // Projectiles.
  for (std::size_t i = 0; i < scene.projectiles.size(); ++i) {
    const ProjectileDef& b = scene.projectiles[i];
    const std::string p = fmt::format("projectile[{}]", i);
    c.positive(p + ".radius", b.radius, "give the ball radius in metres, e.g. 0.12");
    resolve_material(scene, b.material, p + ".material");
    if (b.density != 0)
      c.range(p + ".density", b.density, MaterialDef::kMinDensity, true, MaterialDef::kMaxDensity, true,
              fmt::format("0 (the material's) or in [{}, {}] [kg/m^3]", num(MaterialDef::kMinDensity),
                          num(MaterialDef::kMaxDensity)),
              "use 0 to take the material's density, or e.g. 7850 for steel");
    c.position(p + ".position", b.position);
    c.finite(p + ".velocity", b.velocity);
    c.finite(p + ".angular_velocity", b.angular_velocity);
    c.range(p + ".rolling_friction", b.rolling_friction, 0, true, 1, true, "in [0, 1]",
            "use 0.01 (the default) for a hard ball");
    c.range(p + ".twisting_friction", b.twisting_friction, 0, true, 1, true, "in [0, 1]",
            "use 0.01 (the default) for a hard ball");
  }

  // Grips and loads act on the automata whose initial centres lie in [min, max].
  static const char* const axes[] = {"x", "y", "z"};
  auto check_box = [&](const std::string& p, const std::string& name, const Vec3d& lo, const Vec3d& hi) {
    c.finite(p + ".min", lo);
    c.finite(p + ".max", hi);
    for (int a = 0; a < 3; ++a) {
      if (!(lo[a] < hi[a])) {
        c.fail(fmt::format("{} \"{}\": min = {} and max = {} give an empty box: min must be < max on every axis, "
                           "but on {} min = {} >= max = {}; widen the box so it holds the automata centres",
                           p, name, vec(lo), vec(hi), axes[a], num(lo[a]), num(hi[a])));
      }
    }
  };
  std::unordered_map<std::string_view, std::size_t> grip_names;
  for (std::size_t i = 0; i < scene.grips.size(); ++i) {
    const GripDef& g = scene.grips[i];
    const std::string p = fmt::format("grip[{}]", i);
    // The name heads three stats.csv columns ("<name>_force_x", ...), written without quoting: a comma
    // would shift every column after it, a quote or line break would break the file for CSV readers,
    // and two equal names would give columns that cannot be told apart.
    for (const char ch : g.name) {
      if (ch == ',' || ch == '"' || text::is_control(ch)) {
        c.fail(fmt::format("{}.name = \"{}\" has {}, which would break the stats.csv header (its force columns "
                           "are named after the grip); rename the grip with letters, digits, spaces, '_' or '-'",
                           p, escaped(g.name), ch == ',' ? "a comma" : ch == '"' ? "a quote" : "a control character"));
      }
    }
    if (const auto [it, fresh] = grip_names.emplace(g.name, i); !fresh) {
      c.fail(fmt::format("{}.name = \"{}\" is also the name of grip[{}]; the stats.csv force columns are named "
                         "after the grip, so rename one of them (unnamed grips are \"grip\", \"grip1\", ...)",
                         p, escaped(g.name), it->second));
    }
    check_box(p, g.name, g.min, g.max);
    c.finite(p + ".velocity", g.velocity);
  }

  // Loads. The box test is the grips' (initial centres inside [min, max]), so an empty box is the same
  // mistake; a non-finite force would turn every loaded automaton's position into NaN on the first step.
  for (std::size_t i = 0; i < scene.loads.size(); ++i) {
    const LoadDef& l = scene.loads[i];
    const std::string p = fmt::format("load[{}]", i);
    check_box(p, l.name, l.min, l.max);
    c.finite(p + ".force", l.force);
  }

  // Ground.
  c.position("ground.height", scene.ground.height);
  c.range("ground.friction", scene.ground.friction, 0, true, kFloatMax, true, kFrictionRange,
          "use e.g. 0.6, or 0 for a frictionless ground");
  c.range("ground.restitution", scene.ground.restitution, 0.01, true, 1, true, "in [0.01, 1]", "use e.g. 0.3");
  c.range("ground.rolling_friction", scene.ground.rolling_friction, 0, true, 1, true, "in [0, 1]",
          "use 0.3 (the default), 0 for none");
  c.range("ground.twisting_friction", scene.ground.twisting_friction, 0, true, 1, true, "in [0, 1]",
          "use 0.3 (the default), 0 for none");

  // Camera (the renderer's; whether it sees the objects is checked against the built model when a run
  // renders: render/camera.cpp).
  const CameraDef& cam = scene.camera;
  if (cam.position) c.position("camera.position", *cam.position);
  if (cam.target) c.position("camera.target", *cam.target);
  if (cam.position && cam.target && *cam.position == *cam.target)
    c.fail(fmt::format("camera.position = camera.target = {}: the camera needs a direction to look in; move the "
                       "position away from the target",
                       vec(*cam.position)));
  c.range("camera.fov", cam.fov, 5, true, 150, true, "in [5, 150] degrees", "use e.g. 40 (the default)");
}

namespace {
constexpr std::pair<SolverDef::Backend, const char*> kBackendNames[] = {{SolverDef::Backend::automatic, "auto"},
                                                                       {SolverDef::Backend::cpu, "cpu"},
                                                                       {SolverDef::Backend::cuda, "cuda"},
                                                                       {SolverDef::Backend::cuda_emulation, "cuda-emulation"}};
}  // namespace

const char* backend_name(SolverDef::Backend backend) {
  for (const auto& [b, name] : kBackendNames)
    if (b == backend) return name;
  return "auto";
}

std::optional<SolverDef::Backend> parse_backend(const std::string& name) {
  for (const auto& [b, text] : kBackendNames)
    if (name == text) return b;
  return std::nullopt;
}

}  // namespace mca
