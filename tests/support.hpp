#pragma once
// Small scene builders and measurements shared by the physics tests.
#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include <fmt/format.h>

#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "mca/scene.hpp"
#include "physics/link_law.hpp"
#include "sim/engine.hpp"

namespace mca::test {

// The default scene's wall and ball on the paper's cubic lattice with the instant break, 60 ms at 500 frames
// a second (scenes/wall_ball_cubic.toml: the default scene until the random lattice became the default,
// the same bits: Determinism.TheCubicWallGivesItsStoredHash). The tests of the cubic lattice's sweep, the
// outputs and the renderer were written on it (the command-line tests run the file itself).
inline const std::string kCubicWallPath = MCA_SOURCE_DIR "/scenes/wall_ball_cubic.toml";
inline SceneDef cubic_wall_scene() { return io::load_scene_file(kCubicWallPath); }

// Sets every automaton of sim in the rigid motion of velocity v and spin w about the centre of mass, and
// starts the energy check's budget from that motion's energy; returns the centre of mass.
inline DVec3 set_rigid_motion(Engine& sim, DVec3 v, DVec3 w) {
  State st = sim.state();
  const Model& m = sim.model();
  DVec3 c{};
  double mass = 0;
  for (std::size_t a = 0; a < st.x.size(); ++a) {
    c += st.x[a] * static_cast<double>(m.mass[a]);
    mass += m.mass[a];
  }
  c = c * (1.0 / mass);
  for (std::size_t a = 0; a < st.x.size(); ++a) {
    st.v[a] = v + cross(w, st.x[a] - c);
    st.w[a] = w;
  }
  sim.backend().upload(std::move(st));
  State started = sim.state();
  started.initial_energy = sim.energies().total();
  sim.backend().upload(std::move(started));
  return c;
}

// The largest |strain| of the intact links of state s (lattice links with the spacing, explicit links with
// their own rest lengths, as the kernels form them).
inline double max_link_strain(const Model& m, const State& s) {
  double worst = 0;
  m.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int) {
    if (!s.intact[l]) return;
    // Each link's own rest length: the lattice's d, a jittered link's, an explicit link's.
    const double r0 = m.link_r0(l);
    const LinkGeometry g = link_geometry(s.x[i], s.x[j], r0, static_cast<float>(1.0 / r0));
    worst = std::max(worst, static_cast<double>(std::fabs(g.eps)));
  });
  return worst;
}

// Sets an environment variable for the life of the object, then restores what was there.
class ForceEnv {
 public:
  ForceEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    setenv(name, value, 1);
  }
  ~ForceEnv() {
    if (old_) setenv(name_, old_->c_str(), 1);
    else unsetenv(name_);
  }
  ForceEnv(const ForceEnv&) = delete;
  ForceEnv& operator=(const ForceEnv&) = delete;

 private:
  const char* name_;
  std::optional<std::string> old_;
};

// The message of the mca::Error f throws, or "" when it throws none.
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// A test material: concrete-like elasticity; strengths so high nothing breaks unless a test lowers them.
inline MaterialDef test_material(double E = 30e9, double nu = 0.2, double rho = 2400) {
  MaterialDef m;
  m.name = "testmat";
  m.youngs_modulus = E;
  m.poisson_ratio = nu;
  m.density = rho;
  m.tensile_strength = 1e30;
  m.compressive_strength = 1e30;
  m.fracture_strain = 1e30;
  m.damping_time = 0;  // undamped: the conservation tests measure the elastic law alone
  return m;
}

// The test material with an exponential strengthening law (paper eq. 7), alpha = 3000, capped at a strain
// of 1e-3 (a factor of e^3 = 20): fracture strain 1e-3 and strengths of 30 MPa.
inline MaterialDef strengthening_material() {
  MaterialDef m = test_material();
  m.strengthening = StrengtheningLaw::exponential;
  m.strengthening_alpha = 3000;
  m.fracture_strain = 1e-3;
  m.tensile_strength = 30e6;
  m.compressive_strength = 30e6;
  return m;
}

// A box of nx x ny x nz automata with spacing d centred at the origin, no gravity, no ground.
inline SceneDef block_scene(int nx, int ny, int nz, double d = 0.01, MaterialDef mat = test_material()) {
  SceneDef s;
  s.name = "test";
  s.source = "<test>";
  s.solver.spacing = d;
  s.solver.lattice = SolverDef::Lattice::cubic;  // the paper's; the random lattice's tests set theirs
  s.solver.gravity = {0, 0, 0};
  s.materials.push_back(mat);
  ObjectDef o;
  o.name = "block";
  o.material = mat.name;
  o.size = {nx * d, ny * d, nz * d};
  s.objects.push_back(o);
  s.output.duration = 1.0;
  s.output.frame_rate = 1.0;  // one long frame: the automatic step is used as is
  return s;
}

// Box [lo, hi] around the automata whose index along `axis` is `layer` (0-based) in a block of n cells.
inline void layer_box(int n, int layer, int axis, double d, Vec3d& lo, Vec3d& hi) {
  lo = {-1e9, -1e9, -1e9};
  hi = {1e9, 1e9, 1e9};
  const double c = (layer - 0.5 * (n - 1)) * d;
  lo[axis] = c - 0.25 * d;
  hi[axis] = c + 0.25 * d;
}

// Solves the N x N system in the first N columns of A (the last column its right-hand side) by Gauss-Jordan
// elimination with partial pivoting, in place: the solution's x_i is A[i][N] / A[i][i].
template <std::size_t N>
void gauss_jordan(double (&A)[N][N + 1]) {
  for (std::size_t c = 0; c < N; ++c) {
    std::size_t best = c;
    for (std::size_t r = c + 1; r < N; ++r)
      if (std::fabs(A[r][c]) > std::fabs(A[best][c])) best = r;
    for (std::size_t k = 0; k <= N; ++k) std::swap(A[c][k], A[best][k]);
    for (std::size_t r = 0; r < N; ++r) {
      if (r == c) continue;
      const double s = A[r][c] / A[c][c];
      for (std::size_t k = c; k <= N; ++k) A[r][k] -= s * A[c][k];
    }
  }
}

// Loads on the automata of one end layer of the n^3 block scene sc (spacing d), the layer `side` (0: the
// first, 1: the last) across axis `face`, the cells within `margin` of the layer's plane (for moved
// sites: the layer must hold n^2 automata): `total` newtons along axis `along` in all, through the face's
// centre. Where the sites are moved (jittered and random lattices), equal loads on them have a moment
// about the face's centre, which turns the block without end (the cubic lattice's are equal); so the loads
// are c (1 + a s + b t) on the sites at (s, t) across the face, with a and b making that moment zero.
inline void add_face_loads(SceneDef& sc, const Model& at_rest, int n, double d, double margin, int face, int side,
                           int along, double total) {
  Vec3d lo, hi;
  layer_box(n, side ? n - 1 : 0, face, d, lo, hi);
  std::vector<DVec3> sites;
  for (const DVec3& p : at_rest.position0) {
    const double q[3] = {p.x, p.y, p.z};
    if (q[face] >= lo[face] - margin && q[face] <= hi[face] + margin) sites.push_back(p);
  }
  EXPECT_EQ(sites.size(), static_cast<std::size_t>(n * n));
  const int u = (face + 1) % 3, v = (face + 2) % 3;  // the face's own axes
  const auto coord = [](const DVec3& p, int axis) { return axis == 0 ? p.x : axis == 1 ? p.y : p.z; };
  // Least squares for (c, c a, c b): sum f = total, sum f s = sum f t = 0.
  double A[3][4] = {};
  for (const DVec3& p : sites) {
    const double r[3] = {1.0, coord(p, u), coord(p, v)};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) A[i][j] += r[i] * r[j];
  }
  A[0][3] = total;
  gauss_jordan(A);
  const double c[3] = {A[0][3] / A[0][0], A[1][3] / A[1][1], A[2][3] / A[2][2]};
  for (const DVec3& p : sites) {
    LoadDef ld;
    ld.name = fmt::format("load {}", sc.loads.size());
    ld.min = {p.x - 1e-6 * d, p.y - 1e-6 * d, p.z - 1e-6 * d};
    ld.max = {p.x + 1e-6 * d, p.y + 1e-6 * d, p.z + 1e-6 * d};
    ld.force = {0, 0, 0};
    ld.force[along] = c[0] + c[1] * coord(p, u) + c[2] * coord(p, v);
    sc.loads.push_back(ld);
  }
}

// Whether the site p (of an n^3 block of spacing d centred at the origin) lies in the block's middle half:
// cells n / 4 to n - 1 - n / 4 along every axis.
inline bool in_middle_half(const DVec3& p, int n, double d) {
  const double lo = -0.5 * (n - 1) * d;
  const long k1 = n / 4, k2 = n - 1 - n / 4;
  for (const double q : {p.x, p.y, p.z}) {
    const long cell = std::lround((q - lo) / d);
    if (cell < k1 || cell > k2) return false;
  }
  return true;
}

// The strain of the middle half of the n^3 block (spacing d) of sim (clear of the faces' own layers,
// docs/model-notes.md "The surface layer"): the symmetric part of A in the affine displacement u = A p + t
// fitted by least squares to its automata. (A turn of the block is its antisymmetric part, left out.)
struct Strain3 {
  double e[3][3];
};
inline Strain3 middle_strain(const Engine& sim, int n, double d) {
  const Model& m = sim.model();
  const State& s = sim.state();
  double N[4][4] = {}, R[3][4] = {};
  for (std::size_t a = 0; a < m.size(); ++a) {
    if (!in_middle_half(m.position0[a], n, d)) continue;
    const double p[4] = {m.position0[a].x, m.position0[a].y, m.position0[a].z, 1.0};
    const double u[3] = {s.x[a].x - p[0], s.x[a].y - p[1], s.x[a].z - p[2]};
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) N[i][j] += p[i] * p[j];
      for (int c = 0; c < 3; ++c) R[c][i] += u[c] * p[i];
    }
  }
  double A[3][4];
  for (int c = 0; c < 3; ++c) {  // the 4x4 normal equations, one displacement component each
    double M4[4][5];
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) M4[i][j] = N[i][j];
      M4[i][4] = R[c][i];
    }
    gauss_jordan(M4);
    for (int i = 0; i < 4; ++i) A[c][i] = M4[i][4] / M4[i][i];
  }
  Strain3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.e[i][j] = 0.5 * (A[i][j] + A[j][i]);
  return r;
}

// Relaxes sim in rounds of 2,500 steps until what `read` measures (an array of the quantities a test
// reads off a loaded block) changes by less than `tol` of itself over each of two rounds in a row, for at
// least 10,000 and at most 50,000 steps. Returns the steps run and the last reading.
template <class Read>
auto relax_until_settled(Engine& sim, Read read, double tol = 1e-4) {
  auto last = read();
  std::int64_t steps = 0;
  for (int calm = 0; steps < 50000 && (calm < 2 || steps < 10000);) {
    sim.advance(2500);
    steps += 2500;
    const auto now = read();
    bool still = true;
    for (std::size_t i = 0; i < now.size(); ++i) still = still && std::fabs(now[i] - last[i]) <= tol * std::fabs(now[i]);
    calm = still ? calm + 1 : 0;
    last = now;
  }
  return std::pair{steps, last};
}

// Uniaxial stress sigma along x on the n^3 block scene sc (spacing d): loads on the automata of its end
// layers (add_face_loads, free of moment), relaxed with local damping until its moduli settle
// (relax_until_settled). Returns the modulus and Poisson's ratios of the middle half of the block.
struct BlockModuli {
  double E, nu_y, nu_z;
};
inline BlockModuli uniaxial_block_moduli(SceneDef sc, int n, double d, double sigma, double margin) {
  sc.solver.local_damping = 0.2;
  const Model at_rest = lattice::build_model(sc);
  for (int side = 0; side < 2; ++side) add_face_loads(sc, at_rest, n, d, margin, 0, side, 0, (side ? 1 : -1) * sigma * n * n * d * d);
  Engine sim(sc);
  const auto moduli = [&] {
    const Strain3 e = middle_strain(sim, n, d);
    return std::array<double, 3>{sigma / e.e[0][0], -e.e[1][1] / e.e[0][0], -e.e[2][2] / e.e[0][0]};
  };
  const auto [steps, m] = relax_until_settled(sim, moduli);
  std::printf("(the block settled in %lld steps)\n", static_cast<long long>(steps));
  return {m[0], m[1], m[2]};
}

// Simple shear tau on the n^3 block scene sc: tractions along x on the faces across y and along y on those
// across x (add_face_loads), relaxed as above. Returns the middle half's mean averaged (Love) stress xy
// over its engineering shear strain (the law's G), and the applied tau over that strain (which mixes in
// the softer surface layers: Physics.BlockInSimpleShearReturnsShearModulus).
struct ShearModuli {
  double interior, applied;
};
inline ShearModuli simple_shear_modulus(SceneDef sc, int n, double d, double tau, double margin) {
  sc.solver.local_damping = 0.2;
  const Model at_rest = lattice::build_model(sc);
  for (int side = 0; side < 2; ++side) {
    const double f = (side ? 1 : -1) * tau * n * n * d * d;
    add_face_loads(sc, at_rest, n, d, margin, 1, side, 0, f);
    add_face_loads(sc, at_rest, n, d, margin, 0, side, 1, f);
  }
  Engine sim(sc);
  const auto moduli = [&] {
    const double gamma = 2 * middle_strain(sim, n, d).e[0][1];
    const State& st = sim.state();
    double sxy = 0, volume = 0;
    for (std::size_t a = 0; a < sim.model().size(); ++a) {
      if (!in_middle_half(sim.model().position0[a], n, d)) continue;
      sxy += st.s[a].xy * sim.model().volume[a];  // (volume-weighted: the random lattice's cells differ)
      volume += sim.model().volume[a];
    }
    return std::array<double, 2>{sxy / volume / gamma, tau / gamma};
  };
  const auto [steps, m] = relax_until_settled(sim, moduli);
  std::printf("(the block settled in %lld steps)\n", static_cast<long long>(steps));
  return {m[0], m[1]};
}

// A bar of n automata along x (one thick, spacing d) of material mat, held at its first automaton by the
// grip "hold" and pulled at its last by the grip "pull" at `speed` m/s along x (grip_force[1], grip_work[1]
// are the pull's), with link_damping 0.3 so that it is pulled quasi-statically.
inline SceneDef pulled_bar(int n, double d, const MaterialDef& mat, double speed = 0.002) {
  SceneDef sc = block_scene(n, 1, 1, d, mat);
  sc.solver.link_damping = 0.3;
  GripDef hold, pull;
  hold.name = "hold";  // grip names must differ (they name the stats.csv columns)
  pull.name = "pull";
  layer_box(n, 0, 0, d, hold.min, hold.max);
  layer_box(n, n - 1, 0, d, pull.min, pull.max);
  pull.velocity = {speed, 0, 0};
  sc.grips = {hold, pull};
  return sc;
}

// A cantilever of 20 x 2 x 2 automata 1 cm apart, held at one end by a grip and under a [[load]] of 200 N
// down at the other, no gravity.
inline SceneDef loaded_cantilever() {
  SceneDef s = block_scene(20, 2, 2, 0.01);
  s.name = "loaded_cantilever";
  GripDef hold;
  layer_box(20, 0, 0, 0.01, hold.min, hold.max);
  s.grips.push_back(hold);
  LoadDef load;
  layer_box(20, 19, 0, 0.01, load.min, load.max);
  load.force = {0, 0, -200};
  s.loads.push_back(load);
  return s;
}

// Uniformly random velocities in [-v_scale, v_scale] and angular velocities in [-w_scale, w_scale] on
// every automaton (a fixed seed: the same numbers every run).
inline void randomise_velocities(Engine& sim, double v_scale, double w_scale, unsigned seed) {
  State s = sim.state();
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (std::size_t a = 0; a < s.v.size(); ++a) {
    s.v[a] = to_dvec3(Vec3{u(rng), u(rng), u(rng)} * static_cast<float>(v_scale));
    s.w[a] = to_dvec3(Vec3{u(rng), u(rng), u(rng)} * static_cast<float>(w_scale));
  }
  sim.backend().upload(std::move(s));
}

// A body of scene s left alone for 20,000 steps: it stays healthy, breaks no link and keeps kinetic plus
// elastic energy below 1e-15 J (what rounding leaves: a few 1e-21 J).
inline void expect_stays_at_rest(const SceneDef& s, const char* what) {
  Engine sim(s);
  ASSERT_EQ(sim.advance(20000).flags, kHealthy);
  const Energies e = sim.energies();
  std::printf("%s at rest after 20,000 steps: kinetic %.3g J, elastic %.3g J\n", what, e.kinetic, e.elastic);
  EXPECT_LT(e.kinetic + e.elastic, 1e-15);
  EXPECT_EQ(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
}

// The total energy of scene s with random velocities (0.1 m/s, 10 rad/s) at safety = 1 (the critical
// step), before and after 5,000 steps; and its critical step.
struct AtTheLimit {
  double before, after, critical_dt;
};
inline AtTheLimit energy_at_the_limit(SceneDef s) {
  s.solver.safety = 1.0;
  Engine sim(s);
  randomise_velocities(sim, 0.1, 10.0, 5);
  const double e0 = sim.energies().total();
  sim.advance(5000);
  return {e0, sim.energies().total(), sim.model().critical_dt};
}

// A block of 6 x 6 x 16 automata (d = 1 cm) of the lattice `lattice` sets, of a material of tensile
// strength 3 MPa and fracture energy gf, pulled along its length by grips on its end layers (boxes widened
// by `margin` for moved sites) at 1 cm/s.
inline constexpr double kPulledBlockStrength = 3e6;             // [Pa]
inline constexpr double kPulledBlockSection = 6 * 6 * 0.01 * 0.01;  // [m^2]
inline SceneDef pulled_block(const std::function<void(SceneDef&)>& lattice, double margin, double gf = 0) {
  const double d = 0.01, st = kPulledBlockStrength;
  MaterialDef mat = test_material();
  mat.tensile_strength = st;
  mat.compressive_strength = 10 * st;
  mat.fracture_strain = 1.5 * st / mat.youngs_modulus;
  mat.fracture_energy = gf;
  SceneDef sc = block_scene(16, 6, 6, d, mat);
  lattice(sc);
  sc.solver.link_damping = 0.3;
  GripDef hold, pull;
  hold.name = "hold";
  pull.name = "pull";
  layer_box(16, 0, 0, d, hold.min, hold.max);
  layer_box(16, 15, 0, d, pull.min, pull.max);
  for (GripDef* g : {&hold, &pull}) {
    g->min[0] -= margin;
    g->max[0] += margin;
  }
  pull.velocity = {0.01, 0, 0};
  sc.grips = {hold, pull};
  return sc;
}

// pulled_block: the largest mean stress over its section before it parts, as a share of the tensile
// strength, and the links broken by then.
struct TensileResult {
  double strength;
  std::int64_t broken;
};
// pulled_block's grip moved at `speed` (> 0 pulls, < 0 presses) until its force falls below `drop` of its
// peak: the peak mean stress over the section as a share of the tensile strength (pulled) or of the
// compressive strength, 10 times it (pressed), and the links broken by the end.
inline TensileResult block_strength(const std::function<void(SceneDef&)>& lattice, double margin, double speed,
                                    double drop) {
  SceneDef sc = pulled_block(lattice, margin);
  sc.grips[1].velocity = {speed, 0, 0};
  const double sign = speed > 0 ? 1.0 : -1.0;
  Engine sim(sc);
  double peak = 0;
  for (int k = 0; k < 4000; ++k) {
    if (sim.advance(50).flags != kHealthy) {
      ADD_FAILURE() << "the block is no longer healthy";
      break;
    }
    const double f = sign * sim.state().grip_force[1].x;
    peak = std::max(peak, f);
    if (f < drop * peak && peak > 0) break;
  }
  const double strength = speed > 0 ? kPulledBlockStrength : 10 * kPulledBlockStrength;  // pulled_block's
  return {peak / kPulledBlockSection / strength, sim.state().broken_by[0] + sim.state().broken_by[1]};
}
inline TensileResult block_tensile_strength(const std::function<void(SceneDef&)>& lattice, double margin) {
  return block_strength(lattice, margin, 0.01, 0.2);
}

// pulled_block of fracture energy gf, pulled until it has come apart (the pull's force below 1 % of its
// peak for 2,000 steps): the pull's work per unit of the block's section [J/m^2] and the links broken.
struct FractureWork {
  double per_area;
  std::int64_t broken;
};
inline FractureWork block_fracture_work(const std::function<void(SceneDef&)>& lattice, double margin, double gf) {
  Engine sim(pulled_block(lattice, margin, gf));
  double peak = 0;
  std::int64_t low_since = -1;
  for (int k = 0; k < 20000; ++k) {
    if (sim.advance(100).flags != kHealthy) {
      ADD_FAILURE() << "the pulled block is no longer healthy";
      break;
    }
    const double f = sim.state().grip_force[1].x;
    peak = std::max(peak, f);
    if (peak > 0 && std::abs(f) < 0.01 * peak) {
      if (low_since < 0) low_since = sim.state().step;
      if (sim.state().step - low_since >= 2000) break;
    } else {
      low_since = -1;
    }
  }
  EXPECT_GE(low_since, 0) << "the pulled block did not come apart";
  return {sim.state().grip_work[1] / kPulledBlockSection, sim.state().broken_by[0] + sim.state().broken_by[1]};
}

// A pulse along a bar of 300 x section x section automata (d = 1 cm) of the lattice `lattice` sets: the
// speed between two stations (the first time the mean velocity of the automata of a cell layer reaches
// half its first peak). The pulse: the first layer kicked at 1 m/s, or with `smooth` layers, the first
// `smooth` layers at 0.5 (1 + cos(pi k / smooth)) m/s (a pulse of long waves only, which the lattice's
// dispersion does not slow). (Physics.WaveInABarTravelsAtTheBarSpeed holds the cubic lattice's to
// sqrt(E / rho).)
inline double bar_wave_speed(const std::function<void(SceneDef&)>& lattice, int section = 4, int smooth = 0) {
  const int n = 300, st1 = 80, st2 = 220;
  const double d = 0.01;
  SceneDef sc = block_scene(n, section, section, d, test_material());
  lattice(sc);
  Engine sim(sc);
  const Model& m = sim.model();
  const double lo = -0.5 * (n - 1) * d;
  std::vector<int> cell(m.size());
  for (std::size_t a = 0; a < m.size(); ++a) cell[a] = static_cast<int>(std::lround((m.position0[a].x - lo) / d));
  State s = sim.state();
  for (std::size_t a = 0; a < m.size(); ++a)
    if (smooth > 0 ? cell[a] < smooth : cell[a] == 0)  // a kick at the left end
      s.v[a] = DVec3{smooth > 0 ? 0.5 * (1.0 + std::cos(std::numbers::pi * cell[a] / smooth)) : 1.0, 0, 0};
  sim.backend().upload(s);
  std::vector<double> t, v1, v2;
  const int steps = static_cast<int>(1.3 * (st2 * d / 3536.0) / m.dt);
  for (int k = 0; k < steps; ++k) {
    sim.advance(1);
    double a1 = 0, a2 = 0;
    int c1 = 0, c2 = 0;
    for (std::size_t a = 0; a < m.size(); ++a) {
      if (cell[a] == st1) { a1 += sim.state().v[a].x; ++c1; }
      if (cell[a] == st2) { a2 += sim.state().v[a].x; ++c2; }
    }
    t.push_back(sim.state().time);
    v1.push_back(a1 / c1);
    v2.push_back(a2 / c2);
  }
  auto arrival = [&](const std::vector<double>& v) {
    const double peak = *std::max_element(v.begin(), v.end());
    for (std::size_t k = 0; k < v.size(); ++k)
      if (v[k] >= 0.5 * peak) return t[k];
    return -1.0;
  };
  return (st2 - st1) * d / (arrival(v2) - arrival(v1));
}

}  // namespace mca::test
