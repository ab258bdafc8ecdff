// The jittered lattice (solver.lattice_jitter): sites moved inside their cells, the cubic connectivity
// with each link's own rest length; nothing starts in contact, a body at rest stays at rest, every
// instruction set, thread count and resumed run computes the same bits, and its elastic constants as
// measured (docs/model-notes.md, "The jittered lattice").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <tbb/global_control.h>

#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "sim/state_check.hpp"
#include "bitwise.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

SceneDef jittered_block(int n, double jitter) {
  SceneDef s = test::block_scene(n, n, n, 0.01, test::test_material());
  s.solver.lattice_jitter = jitter;
  return s;
}

TEST(Jitter, SitesStayInTheirCellsAndNoPairStartsInContact) {
  const double d = 0.01, jitter = 0.25;
  Engine cubic(jittered_block(6, 0)), moved(jittered_block(6, jitter));
  const Model &c = cubic.model(), &m = moved.model();
  ASSERT_EQ(c.size(), m.size());
  EXPECT_TRUE(c.link_rest.empty());
  ASSERT_EQ(m.link_rest.size(), m.lattice_slots());
  double largest = 0;
  for (std::size_t a = 0; a < m.size(); ++a) {
    const DVec3 off = ddelta(c.position0[a], m.position0[a]);
    const double most = std::max({std::fabs(off.x), std::fabs(off.y), std::fabs(off.z)});
    EXPECT_LE(most, jitter * d * (1 + 1e-9)) << "automaton " << a;
    EXPECT_NEAR(m.radius[a], 0.5 * d - most, 1e-6 * d) << "automaton " << a;
    largest = std::max(largest, most);
  }
  EXPECT_GT(largest, 0.9 * jitter * d) << "the moves span the range";
  for (std::size_t i = 0; i < m.size(); ++i)
    for (std::size_t j = i + 1; j < m.size(); ++j) {
      const DVec3 dd = ddelta(m.position0[i], m.position0[j]);
      EXPECT_GE(std::sqrt(dot(dd, dd)), m.radius[i] + m.radius[j]) << i << ", " << j << " start in contact";
    }
  for (std::size_t l = 0; l < m.lattice_slots(); ++l) {
    if (m.neighbour[l] == Model::kNoLink) continue;
    const DVec3 dd = ddelta(m.position0[l % m.size()], m.position0[m.neighbour[l]]);
    EXPECT_EQ(m.link_rest[l], std::sqrt(dot(dd, dd)));
  }
  // The same seed, the same sites; another seed, others.
  Engine again(jittered_block(6, jitter));
  EXPECT_EQ(again.model().position0[17].x, m.position0[17].x);
  SceneDef other = jittered_block(6, jitter);
  other.solver.seed = 7;
  EXPECT_NE(Engine(other).model().position0[17].x, m.position0[17].x);
}

TEST(Jitter, ABodyAtRestStaysAtRest) {
  Engine sim(jittered_block(8, 0.3));
  ASSERT_EQ(sim.advance(20000).flags, kHealthy);
  const Energies e = sim.energies();
  std::printf("jittered block at rest after 20,000 steps: kinetic %.3g J, elastic %.3g J\n", e.kinetic, e.elastic);
  EXPECT_LT(e.kinetic + e.elastic, 1e-15);
  EXPECT_EQ(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
}

// The default wall on a jittered lattice, the ball 5 mm from it: every instruction set, thread count
// and sweep gives the same state, and so does a run resumed from a checkpoint.
TEST(Jitter, EveryInstructionSetThreadCountAndResumeGivesTheSameState) {
  SceneDef s = io::load_default_scene();
  s.solver.lattice_jitter = 0.25;
  s.output.duration = 0.01;
  ASSERT_EQ(s.projectiles.size(), 1u);
  s.projectiles[0].position[1] = -0.1 - s.projectiles[0].radius - 0.005;
  EXPECT_GT(test::expect_bitwise_everywhere(s, 3000).broken, 0);
}

// Uniaxial stress on a 20^3 block: the modulus and Poisson's ratios of the middle half (an affine fit of its
// displacements), against the input E and nu, with the jittered lattice's stiffness factor
// (lattice::jitter_stiffness, fitted at nu = 0.2) at two Poisson ratios.
TEST(Jitter, ABlockReturnsTheInputModulusAndPoissonRatio) {
  const int n = 20;
  const double d = 0.01, E = 30e9, sigma = 1e6;
  const std::pair<double, double> cases[] = {{0.0, 0.2}, {0.25, 0.2}, {0.25, 0.3}};
  for (const auto& [jitter, nu] : cases) {
    SCOPED_TRACE(jitter);
    SCOPED_TRACE(nu);
    SceneDef sc = test::block_scene(n, n, n, d, test::test_material(E, nu));
    sc.solver.lattice_jitter = jitter;
    const test::BlockModuli b = test::uniaxial_block_moduli(sc, n, d, sigma, 0.3 * d);  // the jittered end layers
    const double E_m = b.E, nu_y = b.nu_y, nu_z = b.nu_z;
    std::printf("jitter %.2f, nu %.2f: E %.4f E, nu %.4f / %.4f\n", jitter, nu, E_m / E, nu_y, nu_z);
    EXPECT_NEAR(E_m / E, 1.0, 0.02);
    // (The jittered lattice's Poisson ratio scatters by a few per cent between directions and seeds:
    // 0.192-0.207 at 0.25 over seeds 1 and 2; the issue asks for 2 %, not yet met.)
    EXPECT_NEAR(nu_y / nu, 1.0, 0.05);
    EXPECT_NEAR(nu_z / nu, 1.0, 0.05);
  }
}


// A block of 6 x 6 x 16 automata pulled along its length by grips on its end layers at 1 cm/s: the largest
// mean stress over its section before it parts, against the tensile strength. Measured: 0.913 on the
// cubic lattice, 0.721 on the jittered one (its leaning links carry shear, which the equivalent stress
// counts): the jittered lattice is 21 % weaker in tension, not yet calibrated (the issue asks for 5 %);
// the bounds make a change of either seen (docs/model-notes.md, "The jittered lattice").
TEST(Jitter, TensileStrengthOfABlockAsMeasured) {
  const double d = 0.01, st = 3e6;
  for (const double jitter : {0.0, 0.25}) {
    MaterialDef mat = test::test_material();
    mat.tensile_strength = st;
    mat.compressive_strength = 10 * st;
    mat.fracture_strain = 1.5 * st / mat.youngs_modulus;
    SceneDef sc = test::block_scene(16, 6, 6, d, mat);
    sc.solver.lattice_jitter = jitter;
    sc.solver.link_damping = 0.3;
    GripDef hold, pull;
    hold.name = "hold";
    pull.name = "pull";
    test::layer_box(16, 0, 0, d, hold.min, hold.max);
    test::layer_box(16, 15, 0, d, pull.min, pull.max);
    for (GripDef* g : {&hold, &pull}) {
      g->min[0] -= 0.3 * d;
      g->max[0] += 0.3 * d;
    }
    pull.velocity = {0.01, 0, 0};
    sc.grips = {hold, pull};
    Engine sim(sc);
    double peak = 0;
    for (int k = 0; k < 4000; ++k) {
      ASSERT_EQ(sim.advance(50).flags, kHealthy);
      peak = std::max(peak, static_cast<double>(sim.state().grip_force[1].x));
      if (sim.state().grip_force[1].x < 0.2 * peak && peak > 0) break;
    }
    const double strength = peak / (36 * d * d) / st;
    std::printf("jitter %.2f: peak mean stress %.3f of the tensile strength, %lld broken links\n", jitter, strength,
                static_cast<long long>(sim.state().broken_by[0] + sim.state().broken_by[1]));
    EXPECT_GT(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
    EXPECT_NEAR(strength, jitter == 0 ? 0.913 : 0.721, 0.03);
  }
}


// A pulse along a bar of 300 x 4 x 4 automata (d = 1 cm): the speed between two stations (the first time
// the mean velocity of the automata of a cell layer reaches half its first peak) on the jittered lattice,
// against the cubic lattice's (which Physics.WaveInABarTravelsAtTheBarSpeed holds to sqrt(E / rho)).
double bar_wave_speed(double jitter) {
  const int n = 300, st1 = 80, st2 = 220;
  const double d = 0.01;
  SceneDef sc = test::block_scene(n, 4, 4, d, test::test_material());
  sc.solver.lattice_jitter = jitter;
  Engine sim(sc);
  const Model& m = sim.model();
  const double lo = -0.5 * (n - 1) * d;
  std::vector<int> cell(m.size());
  for (std::size_t a = 0; a < m.size(); ++a) cell[a] = static_cast<int>(std::lround((m.position0[a].x - lo) / d));
  State s = sim.state();
  for (std::size_t a = 0; a < m.size(); ++a)
    if (cell[a] == 0) s.v[a] = DVec3{1.0, 0, 0};  // a kick at the left end
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

TEST(Jitter, APulseTravelsAtTheCubicLatticesSpeed) {
  const double cubic = bar_wave_speed(0), jittered = bar_wave_speed(0.25);
  std::printf("bar wave, 4 x 4 section: cubic %.1f m/s, jittered %.1f m/s (sqrt(E/rho) = 3535.5)\n", cubic, jittered);
  EXPECT_NEAR(jittered / cubic, 1.0, 0.03);
}

}  // namespace
}  // namespace mca
