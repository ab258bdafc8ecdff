#pragma once
// Small scene builders and measurements shared by the physics tests.
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <random>
#include <string>

#include "mca/error.hpp"
#include "mca/scene.hpp"
#include "physics/link_law.hpp"
#include "sim/engine.hpp"

namespace mca::test {

// The largest |strain| of the intact links of state s (lattice links with the spacing, explicit links with
// their own rest lengths, as the kernels form them).
inline double max_link_strain(const Model& m, const State& s) {
  double worst = 0;
  m.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int) {
    if (!s.intact[l]) return;
    const LinkGeometry g = m.is_explicit(l) ? link_geometry(s.x[i], s.x[j], m.link_r0(l), static_cast<float>(1.0 / m.link_r0(l)))
                                            : link_geometry(s.x[i], s.x[j], m.spacing, 1.0f / m.spacing);
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

// Uniaxial stress sigma along x on the n^3 block scene sc (spacing d): loads on the automata of its end
// layers (boxes widened by `margin` to hold moved sites; each must hold n^2 automata), relaxed with local
// damping for 50,000 steps. Returns the modulus and Poisson's ratios of the middle half of the block.
struct BlockModuli {
  double E, nu_y, nu_z;
};
inline BlockModuli uniaxial_block_moduli(SceneDef sc, int n, double d, double sigma, double margin) {
  sc.solver.local_damping = 0.2;
  for (int side = 0; side < 2; ++side) {
    LoadDef ld;
    layer_box(n, side ? n - 1 : 0, 0, d, ld.min, ld.max);
    ld.min[0] -= margin;
    ld.max[0] += margin;
    ld.force = {(side ? 1.0 : -1.0) * sigma * d * d, 0, 0};
    sc.loads.push_back(ld);
  }
  Engine sim(sc);
  const Model& m = sim.model();
  const auto loaded = [&](int sign) {
    return std::count_if(m.load.begin(), m.load.end(), [&](const Vec3& f) { return f.x * sign > 0; });
  };
  EXPECT_EQ(loaded(1), n * n);
  EXPECT_EQ(loaded(-1), n * n);
  for (int k = 0; k < 100; ++k) sim.advance(500);
  const State& s = sim.state();
  // The affine displacement u = A p + t fitted (least squares) to the automata of the middle half of the
  // block (clear of the faces' own layers, docs/model-notes.md "The surface layer"); the strain is the
  // symmetric part of A. (The loads on jittered end faces exert a small torque, and the block turns
  // slowly while it is measured: the fit takes the turn out, where layer means did not.)
  const double lo = -0.5 * (n - 1) * d;
  const long k1 = n / 4, k2 = n - 1 - n / 4;
  double N[4][4] = {}, R[3][4] = {};
  for (std::size_t a = 0; a < m.size(); ++a) {
    const double p[4] = {m.position0[a].x, m.position0[a].y, m.position0[a].z, 1.0};
    bool middle = true;
    for (int ax = 0; ax < 3; ++ax) {
      const long cell = std::lround((p[ax] - lo) / d);
      middle = middle && cell >= k1 && cell <= k2;
    }
    if (!middle) continue;
    const double u[3] = {s.x[a].x - p[0], s.x[a].y - p[1], s.x[a].z - p[2]};
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) N[i][j] += p[i] * p[j];
      for (int c = 0; c < 3; ++c) R[c][i] += u[c] * p[i];
    }
  }
  double A[3][4];
  for (int c = 0; c < 3; ++c) {  // Gauss-Jordan on the 4x4 normal equations, one displacement component each
    double M4[4][5];
    for (int i = 0; i < 4; ++i) {
      for (int j = 0; j < 4; ++j) M4[i][j] = N[i][j];
      M4[i][4] = R[c][i];
    }
    for (int i = 0; i < 4; ++i) {
      int pivot = i;
      for (int r = i + 1; r < 4; ++r)
        if (std::fabs(M4[r][i]) > std::fabs(M4[pivot][i])) pivot = r;
      for (int j = 0; j < 5; ++j) std::swap(M4[i][j], M4[pivot][j]);
      for (int r = 0; r < 4; ++r) {
        if (r == i) continue;
        const double f = M4[r][i] / M4[i][i];
        for (int j = 0; j < 5; ++j) M4[r][j] -= f * M4[i][j];
      }
    }
    for (int i = 0; i < 4; ++i) A[c][i] = M4[i][4] / M4[i][i];
  }
  return {sigma / A[0][0], -A[1][1] / A[0][0], -A[2][2] / A[0][0]};
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

}  // namespace mca::test
