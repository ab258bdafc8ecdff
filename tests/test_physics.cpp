// The physics contract (physics.md sec. 8): conservation, elastic constants, shear modulus, wave speed,
// tensile strength. Each test measures the model against an analytic answer.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "support.hpp"

namespace mca {
namespace {

using test::block_scene;
using test::test_material;

struct Momenta {
  double p[3] = {0, 0, 0}, l[3] = {0, 0, 0};
  double p_scale = 0, l_scale = 0;
};

Momenta momenta(const Model& m, const State& s) {
  Momenta r;
  for (std::size_t a = 0; a < m.size(); ++a) {
    const double mv[3] = {m.mass[a] * static_cast<double>(s.v[a].x), m.mass[a] * static_cast<double>(s.v[a].y),
                          m.mass[a] * static_cast<double>(s.v[a].z)};
    const double x[3] = {s.x[a].x, s.x[a].y, s.x[a].z};
    const double jw[3] = {m.inertia[a] * static_cast<double>(s.w[a].x), m.inertia[a] * static_cast<double>(s.w[a].y),
                          m.inertia[a] * static_cast<double>(s.w[a].z)};
    const double xl[3] = {x[1] * mv[2] - x[2] * mv[1] + jw[0], x[2] * mv[0] - x[0] * mv[2] + jw[1],
                          x[0] * mv[1] - x[1] * mv[0] + jw[2]};
    for (int k = 0; k < 3; ++k) {
      r.p[k] += mv[k];
      r.l[k] += xl[k];
    }
    r.p_scale += std::sqrt(mv[0] * mv[0] + mv[1] * mv[1] + mv[2] * mv[2]);
    r.l_scale += std::sqrt(xl[0] * xl[0] + xl[1] * xl[1] + xl[2] * xl[2]);
  }
  return r;
}

TEST(Physics, MomentumIsConservedWhileTheBlockBreaks) {
  // Real concrete strengths: links break and broken pairs collide, all through pair forces.
  MaterialDef mat = test_material();
  mat.tensile_strength = 3e6;
  mat.compressive_strength = 30e6;
  mat.fracture_strain = 1.5e-4;
  Engine sim(block_scene(6, 6, 6, 0.01, mat));
  test::randomise_velocities(sim, 2.0, 200.0, 7);
  const Momenta before = momenta(sim.model(), sim.state());
  sim.advance(1000);
  const Momenta after = momenta(sim.model(), sim.state());
  EXPECT_GT(sim.state().broken_by[0] + sim.state().broken_by[1], 100) << "the test should exercise fracture";
  EXPECT_GT(sim.state().contacts.size(), 0u) << "the test should exercise contacts";
  for (int k = 0; k < 3; ++k) {
    std::printf("momentum axis %d: linear %.2g, angular %.2g (relative change)\n", k,
                std::fabs(after.p[k] - before.p[k]) / before.p_scale, std::fabs(after.l[k] - before.l[k]) / before.l_scale);
    EXPECT_LT(std::fabs(after.p[k] - before.p[k]) / before.p_scale, 1e-5) << "linear momentum, axis " << k;
    EXPECT_LT(std::fabs(after.l[k] - before.l[k]) / before.l_scale, 1e-5) << "angular momentum, axis " << k;
  }
}

// Mean strain of intact links along `axis` (and the mean lateral shear slopes) in the central region.
struct StrainProbe {
  double axial[3] = {0, 0, 0};
  int count[3] = {0, 0, 0};
  double slope_xy = 0, slope_yx = 0;  // d u_x / d y from y-links, d u_y / d x from x-links
  int n_xy = 0, n_yx = 0;
};

StrainProbe probe(const Model& m, const State& s, double half_width) {
  StrainProbe p;
  m.for_each_link([&](std::size_t, std::uint32_t i, std::uint32_t j, int ax) {
    if (ax < 0) return;  // lattice links only
    const Vec3 a0 = to_vec3(m.position0[i]), b0 = to_vec3(m.position0[j]);
    const Vec3 mid = (a0 + b0) * 0.5f;
    if (std::fabs(mid.x) > half_width || std::fabs(mid.y) > half_width || std::fabs(mid.z) > half_width) return;
    const Vec3 d = delta(s.x[i], s.x[j]);
    const double r0 = m.spacing;
    p.axial[ax] += (length(d) - r0) / r0;
    ++p.count[ax];
    if (ax == 1) { p.slope_xy += d.x / r0; ++p.n_xy; }
    if (ax == 0) { p.slope_yx += d.y / r0; ++p.n_yx; }
  });
  for (int a = 0; a < 3; ++a) p.axial[a] /= std::max(1, p.count[a]);
  p.slope_xy /= std::max(1, p.n_xy);
  p.slope_yx /= std::max(1, p.n_yx);
  return p;
}

// Run with local damping until the block is at rest (kinetic energy no longer matters).
void relax(Engine& sim, int max_steps) {
  double prev = -1;
  for (int k = 0; k < max_steps; k += 200) {
    sim.advance(200);
    const double ke = sim.energies().kinetic;
    const double el = sim.energies().elastic;
    if (ke < 1e-8 * el && prev >= 0 && ke <= prev) break;
    prev = ke;
  }
}

// Tension sigma on the end faces normal to x of a block n automata long (one automaton's share each).
void pull_x_faces(SceneDef& sc, int n, double d, double sigma) {
  for (int side = 0; side < 2; ++side) {
    LoadDef ld;
    test::layer_box(n, side ? n - 1 : 0, 0, d, ld.min, ld.max);
    ld.force = {(side ? 1.0 : -1.0) * sigma * d * d, 0, 0};
    sc.loads.push_back(ld);
  }
}

// An n^3 block of the test material (E, nu), spacing d, under the uniaxial stress sigma along x, with local
// damping to bring it to rest.
SceneDef uniaxial_block(int n, double d, double E, double nu, double sigma) {
  SceneDef sc = block_scene(n, n, n, d, test_material(E, nu));
  sc.solver.local_damping = 0.2;
  pull_x_faces(sc, n, d, sigma);
  return sc;
}

TEST(Physics, BlockInUniaxialStressReturnsYoungsModulusAndPoissonRatio) {
  const int n = 20;
  const double d = 0.01, E = 30e9, nu = 0.2, sigma = 1e6;
  Engine sim(uniaxial_block(n, d, E, nu, sigma));
  relax(sim, 20000);
  const StrainProbe p = probe(sim.model(), sim.state(), 0.25 * n * d);
  // The interior carries the applied stress (the faces parallel to the load are free): its averaged
  // stress agrees, so applied stress over interior strain is the interior modulus.
  double sxx = 0;
  int count = 0;
  for (std::size_t a = 0; a < sim.model().size(); ++a) {
    const DVec3 q = sim.model().position0[a];
    const double half = 0.25 * n * d;
    if (std::fabs(q.x) > half || std::fabs(q.y) > half || std::fabs(q.z) > half) continue;
    sxx += sim.state().s[a].xx;
    ++count;
  }
  sxx /= count;
  EXPECT_NEAR(sxx / sigma, 1.0, 0.02) << "interior stress " << sxx;
  const double E_measured = sigma / p.axial[0];
  const double nu_y = -p.axial[1] / p.axial[0], nu_z = -p.axial[2] / p.axial[0];
  std::printf("uniaxial stress: E %.4g (input %.4g), nu %.4f / %.4f (input %.2f)\n", E_measured, E, nu_y, nu_z, nu);
  EXPECT_NEAR(E_measured / E, 1.0, 0.02) << "E measured " << E_measured;
  EXPECT_NEAR(nu_y / nu, 1.0, 0.02) << "nu measured (y) " << nu_y;
  EXPECT_NEAR(nu_z / nu, 1.0, 0.02) << "nu measured (z) " << nu_z;
}

TEST(Physics, StrengtheningLawStiffensABarAsEquation7Says) {
  // A bar under end loads, relaxed: the secant modulus at strain e is E0 exp(alpha e) (paper eq. 7).
  const int n = 10;
  const double d = 0.01, E = 30e9, alpha = 3000, sigma = 4e6;
  const MaterialDef mat = test::strengthening_material();  // E 30e9, alpha 3000, capped at a strain of 1e-3
  SceneDef sc = block_scene(n, 1, 1, d, mat);
  sc.solver.local_damping = 0.2;
  pull_x_faces(sc, n, d, sigma);
  Engine sim(sc);
  sim.advance(40000);  // about 60 round trips of the bar's wave: at rest with local damping
  // Interior links (the end automata have one link, which weights their many-body term fully).
  const StrainProbe p = probe(sim.model(), sim.state(), 0.3 * n * d);
  const double e = p.axial[0];
  std::printf("strengthening: strain %.4g, secant modulus %.4g, E0 exp(alpha e) = %.4g\n", e, sigma / e,
              E * std::exp(alpha * e));
  EXPECT_GT(E * std::exp(alpha * e) / E, 1.2) << "the test should be in the nonlinear range";
  EXPECT_NEAR((sigma / e) / (E * std::exp(alpha * e)), 1.0, 0.02);
}

// Simple shear: tractions on the four faces normal to x and y, balanced in force and moment. G is
// measured twice: in the interior, from the averaged (Love) stress and the link slopes of the central
// region, which tests the law itself; and as a lab does, from the traction and the displacement of the
// loaded faces. The surface layers of a lattice are softer in shear (a surface automaton misses a link, so
// it turns by gamma / 6 and shears its in-surface links by gamma / 3 instead of gamma / 2): the interior
// carries 4 % more than the applied traction, and the faces' G approaches the bulk value as 1 / n
// (-2.7 % at 20^3, -1.8 % at 30^3). Dividing the applied traction by the interior strain mixes the two
// and gives a G 4-6 % low that is neither.
TEST(Physics, BlockInSimpleShearReturnsShearModulus) {
  const int n = 30;
  const double d = 0.01, E = 30e9, nu = 0.2, tau = 1e6;
  SceneDef sc = block_scene(n, n, n, d, test_material(E, nu));
  sc.solver.local_damping = 0.2;
  for (int side = 0; side < 2; ++side) {
    const double sgn = side ? 1.0 : -1.0;
    LoadDef top;
    test::layer_box(n, side ? n - 1 : 0, 1, d, top.min, top.max);
    top.force = {sgn * tau * d * d, 0, 0};
    sc.loads.push_back(top);
    LoadDef right;
    test::layer_box(n, side ? n - 1 : 0, 0, d, right.min, right.max);
    right.force = {0, sgn * tau * d * d, 0};
    sc.loads.push_back(right);
  }
  Engine sim(sc);
  relax(sim, 40000);
  const Model& m = sim.model();
  const State& s = sim.state();
  const double G = E / (2 * (1 + nu));
  // Interior: Love stress and link slopes of the central region (half the block's width).
  const double half = 0.25 * n * d;
  const StrainProbe p = probe(m, s, half);
  double sxy = 0;
  int count = 0;
  for (std::size_t a = 0; a < m.size(); ++a) {
    const DVec3 q = m.position0[a];
    if (std::fabs(q.x) > half || std::fabs(q.y) > half || std::fabs(q.z) > half) continue;
    sxy += s.s[a].xy;
    ++count;
  }
  sxy /= count;
  const double gamma_inside = p.slope_xy + p.slope_yx;
  // Faces: the mean displacement of the loaded layers over the distance between them.
  double ux[2] = {0, 0}, uy[2] = {0, 0};
  int cx[2] = {0, 0}, cy[2] = {0, 0};
  const float lo = static_cast<float>(-0.5 * (n - 1) * d + 0.25 * d), hi = -lo;
  for (std::size_t a = 0; a < m.size(); ++a) {
    const Vec3 p0 = to_vec3(m.position0[a]);
    const Vec3 u = delta(m.position0[a], s.x[a]);
    if (p0.y < lo) { ux[0] += u.x; ++cx[0]; }
    if (p0.y > hi) { ux[1] += u.x; ++cx[1]; }
    if (p0.x < lo) { uy[0] += u.y; ++cy[0]; }
    if (p0.x > hi) { uy[1] += u.y; ++cy[1]; }
  }
  const double span = (n - 1) * d;
  const double gamma_faces = (ux[1] / cx[1] - ux[0] / cx[0]) / span + (uy[1] / cy[1] - uy[0] / cy[0]) / span;
  std::printf("simple shear, %d^3: interior G %.4g (stress %.4g over strain %.4g), faces G %.4g (expected %.4g)\n", n,
              sxy / gamma_inside, sxy, gamma_inside, tau / gamma_faces, G);
  EXPECT_NEAR((sxy / gamma_inside) / G, 1.0, 0.02) << "interior G " << sxy / gamma_inside << ", expected " << G;
  EXPECT_NEAR((tau / gamma_faces) / G, 1.0, 0.02) << "faces G " << tau / gamma_faces << ", expected " << G;
}

TEST(Physics, WaveInABarTravelsAtTheBarSpeed) {
  const int n = 400;
  const double d = 0.01, E = 30e9, rho = 2400;
  Engine sim(block_scene(n, 1, 1, d, test_material(E, 0.2, rho)));
  State s = sim.state();
  s.v[0] = DVec3{1.0, 0, 0};  // a kick at the left end (strains of 1e-4: well above float32 noise)
  sim.backend().upload(s);
  const int st1 = 100, st2 = 300;  // stations (automaton index = cell along x)
  double t1 = -1, t2 = -1, peak1 = 0, peak2 = 0;
  // First pass: the first peak velocity at each station; the arrival is when it first reaches half of it.
  std::vector<std::pair<double, double>> v1, v2;
  const double c = std::sqrt(E / rho);
  const int steps = static_cast<int>(1.3 * (st2 * d / c) / sim.model().dt);
  for (int k = 0; k < steps; ++k) {
    sim.advance(1);
    v1.emplace_back(sim.state().time, sim.state().v[st1].x);
    v2.emplace_back(sim.state().time, sim.state().v[st2].x);
  }
  // Arrival: the first time the station's velocity reaches half of its peak (the first, largest one;
  // the run ends before the reflection from the far end comes back).
  auto arrival = [](const std::vector<std::pair<double, double>>& v, double& peak) {
    peak = 0;
    for (const auto& e : v) peak = std::max(peak, e.second);
    for (const auto& e : v)
      if (e.second >= 0.5 * peak) return e.first;
    return -1.0;
  };
  t1 = arrival(v1, peak1);
  t2 = arrival(v2, peak2);
  ASSERT_GT(t1, 0);
  ASSERT_GT(t2, t1);
  const double speed = (st2 - st1) * d / (t2 - t1);
  std::printf("bar wave: %.1f m/s (sqrt(E/rho) = %.1f m/s)\n", speed, c);
  EXPECT_NEAR(speed / c, 1.0, 0.03) << "wave speed " << speed << " m/s, bar speed " << c;
}

// Pull a bar slowly from one end (the other held) and read the grip force at the first break.
double breaking_stress(double tensile, double fracture_strain, int& criterion) {
  const int n = 20;
  const double d = 0.01;
  MaterialDef mat = test_material();
  mat.tensile_strength = tensile;
  mat.compressive_strength = tensile;
  mat.fracture_strain = fracture_strain;
  Engine sim(test::pulled_bar(n, d, mat));
  double peak = 0;
  for (int k = 0; k < 2000000 && sim.state().broken_by[0] + sim.state().broken_by[1] == 0; ++k) {
    peak = std::max(peak, static_cast<double>(sim.state().grip_force[1].x));
    sim.advance(1);
  }
  criterion = sim.state().breaks.empty() ? -1 : static_cast<int>(sim.state().breaks.front().criterion);
  std::printf("tension bar: breaks at %.4g Pa by criterion %d (tensile %.3g Pa, E eps_b %.3g Pa)\n", peak / (d * d),
              criterion, tensile, 30e9 * fracture_strain);
  return peak / (d * d);
}

TEST(Physics, BarBreaksAtItsTensileStrength) {
  int criterion = -1;
  const double s = breaking_stress(3e6, 1.5e-4, criterion);  // sigma_t / E = 1e-4 < eps_b: stress governs
  EXPECT_EQ(criterion, static_cast<int>(BreakCriterion::stress));
  EXPECT_NEAR(s / 3e6, 1.0, 0.05) << "breaking stress " << s;
}

TEST(Physics, BarBreaksAtItsFractureStrainWhenThatComesFirst) {
  int criterion = -1;
  const double s = breaking_stress(3e6, 0.5e-4, criterion);  // E eps_b = 1.5 MPa < sigma_t
  EXPECT_EQ(criterion, static_cast<int>(BreakCriterion::displacement));
  EXPECT_NEAR(s / (30e9 * 0.5e-4), 1.0, 0.05) << "breaking stress " << s;
}


// The many-body term at a free face (docs/model-notes.md, "The surface layer"): an automaton on a face has
// one link along the face's normal and gives it its whole many-body term, so that link contracts more in
// a block under uniaxial stress than the links inside. Measured: the face's links 1.34-1.39 times the
// interior's lateral strain at n = 6-20, the next layer within 3 %, the axial strain uniform within 2 %
// and the modulus from the end faces' displacement within 1.5 % of E.
TEST(Physics, TheSurfaceLayerOfABlockInUniaxialStress) {
  for (const int n : {6, 10}) {
    SCOPED_TRACE(n);
    const double d = 0.01, E = 30e9, nu = 0.2, sigma = 1e6;
    Engine sim(uniaxial_block(n, d, E, nu, sigma));
    relax(sim, 40000);
    const Model& m = sim.model();
    const State& s = sim.state();
    // Per layer along y, in the middle half of x and z: the y links' strain (link k joins layers k and
    // k + 1) and the x links' strain.
    std::vector<double> ey(n - 1, 0.0), ex(n, 0.0);
    std::vector<int> cy(n - 1, 0), cx(n, 0);
    const double lo = -0.5 * (n - 1) * d;
    m.for_each_link([&](std::size_t, std::uint32_t i, std::uint32_t j, int ax) {
      const DVec3 a0 = m.position0[i], b0 = m.position0[j];
      if (std::fabs(0.5 * (a0.x + b0.x)) > 0.25 * n * d || std::fabs(0.5 * (a0.z + b0.z)) > 0.25 * n * d) return;
      const double e = (length(delta(s.x[i], s.x[j])) - d) / d;
      const int k = static_cast<int>(std::lround((a0.y - lo) / d));
      if (ax == 1) { ey[k] += e; ++cy[k]; }
      if (ax == 0) { ex[k] += e; ++cx[k]; }
    });
    double first = 0, last = 0;
    int nf = 0, nl = 0;
    for (std::size_t a = 0; a < m.size(); ++a) {
      if (m.position0[a].x < lo + 0.5 * d) { first += s.x[a].x - m.position0[a].x; ++nf; }
      if (m.position0[a].x > -lo - 0.5 * d) { last += s.x[a].x - m.position0[a].x; ++nl; }
    }
    const double E_ends = sigma / ((last / nl - first / nf) / ((n - 1) * d));
    const double lateral = -nu * sigma / E;
    const double face = ey[0] / cy[0] / lateral, next = ey[1] / cy[1] / lateral, middle = ey[n / 2 - 1] / cy[n / 2 - 1] / lateral;
    std::printf("n %d: E from the end faces %.4f E; lateral strain / (-nu sigma / E): face %.3f, next %.3f, middle %.3f; "
                "axial strain / (sigma / E): face layer %.3f, middle %.3f\n",
                n, E_ends / E, face, next, middle, ex[0] / cx[0] / (sigma / E), ex[n / 2] / cx[n / 2] / (sigma / E));
    EXPECT_NEAR(E_ends / E, 1.0, 0.02);
    EXPECT_GT(face, 1.25) << "the face's links contract more (their automata's whole many-body term)";
    EXPECT_LT(face, 1.5) << "at most the 1.5 of equal volumetric strains";
    EXPECT_NEAR(next / middle, 1.0, 0.06) << "the next layer is the interior's";
    EXPECT_NEAR(ey[0] / cy[0], ey[n - 2] / cy[n - 2], 1e-3 * std::fabs(lateral)) << "both faces alike";
    EXPECT_NEAR(ex[0] / cx[0] / (sigma / E), ex[n / 2] / cx[n / 2] / (sigma / E), 0.02) << "the axial strain is uniform";
  }
}

}  // namespace
}  // namespace mca
