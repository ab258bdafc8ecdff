// Rest, energy and stability: a body at rest stays at rest, far from the origin too; the energy
// bookkeeping counts every term the forces derive from and every external work; the time step stays
// below the stability limit; a blow-up is caught by the library.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "mca/simulation.hpp"
#include "physics/link_law.hpp"
#include "support.hpp"

namespace mca {
namespace {

using test::block_scene;
using test::test_material;

// A free concrete block, rotated and 1 km from the origin, with no gravity: every centre carries the
// rounding of a large coordinate, which float32 rest lengths turned into strains that grew until links
// broke (the default wall at 100 m lost 154 links in 834 steps). On the random lattice too, whose
// rest lengths and directions are all different.
TEST(Rest, AFreeBlockFarFromTheOriginStaysAtRestForAMillionSteps) {
  for (const SolverDef::Lattice lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random}) {
    const char* name = lattice == SolverDef::Lattice::cubic ? "cubic" : "random";
    SceneDef s = block_scene(4, 4, 4, 0.05, MaterialDef{});
    s.materials.clear();
    s.objects[0].material = "concrete";
    s.objects[0].position = {1000, -1000, 1000};
    s.objects[0].rotation = {10, 20, 30};
    s.solver.lattice = lattice;
    Engine sim(s);
    const double strain0 = test::max_link_strain(sim.model(), sim.state());
    std::printf("%s block at 1 km: initial strain %.3g\n", name, strain0);
    EXPECT_LT(strain0, 1e-9) << name;
    double worst_energy = 0;
    for (int k = 0; k < 100; ++k) {
      ASSERT_EQ(sim.advance(10000).flags, kHealthy) << name;
      worst_energy = std::max(worst_energy, sim.energies().total());
    }
    const double strain = test::max_link_strain(sim.model(), sim.state());
    std::printf("%s block at 1 km after 1e6 steps: strain %.3g, largest energy %.3g J\n", name, strain, worst_energy);
    EXPECT_EQ(sim.state().broken_by[0] + sim.state().broken_by[1], 0) << name;
    // The double centres at 1 km leave the cubic block a strain of 2.7e-12 (float32 rest lengths: 6e-4 at
    // the start), the random one 1e-16 (its rest lengths are the centres' distances); the same after 1e6
    // steps. (A step's move under half a coordinate's last place is lost: docs/model-notes.md,
    // "Positions' resolution", for a free body where that leaves a residual motion.) The bound leaves
    // room for the rounding of other machines' builds.
    EXPECT_LT(strain, 1e-8) << name;
    // The energy of a strain of 1e-8 in every link of this block is about 1e-7 J.
    EXPECT_LT(worst_energy, 1e-7) << name;
  }
}

// A 0.1 x 0.1 x 1.5 m concrete column standing on the ground under gravity: it settles onto the ground
// (the ground's dashpot takes some energy out) and comes to rest; its energy (kinetic + elastic +
// contact - gravity work) must never grow (it grew until the run stopped at 1.4 s).
TEST(Rest, AStandingColumnKeepsItsEnergyForAMillionSteps) {
  SceneDef s;
  s.name = "column";
  s.source = "<test>";
  s.solver.lattice = SolverDef::Lattice::cubic;
  ObjectDef o;
  o.size = {0.1, 0.1, 1.5};
  o.position = {0, 0, 0.75};
  s.objects.push_back(o);
  s.ground.enabled = true;
  s.output.duration = 1;
  s.output.frame_rate = 1;
  Engine sim(s);
  const double start = sim.energies().total();
  double highest = start, scale = 0;
  std::vector<double> kinetic;
  for (int k = 0; k < 100; ++k) {
    ASSERT_EQ(sim.advance(10000).flags, kHealthy);
    const Energies e = sim.energies();
    highest = std::max(highest, e.total() - e.external_work());
    scale = std::max(scale, std::fabs(e.gravity_work));
    kinetic.push_back(e.kinetic);
  }
  std::printf("column: energy balance at most %.4g J above its start (gravity work %.3g J); kinetic %.3g J "
              "after 0.1 of the run, %.3g J at the end\n",
              highest - start, scale, kinetic[9], kinetic.back());
  EXPECT_LT(highest - start, 1e-3 * scale);
  EXPECT_EQ(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
  EXPECT_LT(kinetic.back(), 1e-3 * scale) << "the column should come to rest";
}

// A free concrete block spinning at 50 rad/s about a skew axis, on each lattice: its links hold the
// centripetal load and nothing more, for 50 ms. The velocities are the last step's, and a pair's relative
// motion split along the step's end direction gave a turning pair a false tangential velocity of order
// dt omega^2 r, which the shear springs summed without end: the random lattice's block stretched its
// links by 7e-7 more every millisecond (3.6e-5 after 50 ms, proportional to the step) and turned its spin
// into deformation, and fragments flying off an impact, which spin, ground themselves down.
struct Spin {
  double strain_early, strain_late, momentum_change;
  std::int64_t broken;
};

Spin spin_block(SolverDef::Lattice lattice, double jitter) {
  SceneDef s = block_scene(6, 6, 6, 0.05, MaterialDef{});
  s.materials.clear();
  s.objects[0].material = "concrete";
  s.solver.lattice = lattice;
  s.solver.lattice_jitter = jitter;
  Engine sim(s);
  const Model& m = sim.model();
  const DVec3 c = test::set_rigid_motion(sim, {}, DVec3{0.3, 0.5, 0.8} * (50.0 / std::sqrt(0.98)));
  // The angular momentum about the centre of mass, which stays where it is (no net momentum).
  const auto momentum = [&] {
    const State& q = sim.state();
    DVec3 L{};
    for (std::size_t a = 0; a < q.x.size(); ++a)
      L += cross(q.x[a] - c, q.v[a]) * static_cast<double>(m.mass[a]) + q.w[a] * static_cast<double>(m.inertia[a]);
    return L;
  };
  const DVec3 L0 = momentum();
  const auto steps = [&](double t) { return static_cast<std::int64_t>(std::ceil(t / static_cast<double>(m.dt))); };
  Spin r;
  EXPECT_EQ(sim.advance(steps(0.01)).flags, kHealthy);
  r.strain_early = test::max_link_strain(m, sim.state());
  EXPECT_EQ(sim.advance(steps(0.04)).flags, kHealthy);
  r.strain_late = test::max_link_strain(m, sim.state());
  const DVec3 dL = momentum() - L0;
  r.momentum_change = std::sqrt(dot(dL, dL) / dot(L0, L0));
  r.broken = sim.state().broken_by[0] + sim.state().broken_by[1];
  return r;
}

TEST(Rest, ASpinningBlockKeepsItsShapeOnEveryLattice) {
  const struct {
    const char* name;
    SolverDef::Lattice lattice;
    double jitter;
  } cases[] = {{"cubic", SolverDef::Lattice::cubic, 0.0},
               {"jittered", SolverDef::Lattice::cubic, 0.25},
               {"random", SolverDef::Lattice::random, 0.0}};
  for (const auto& k : cases) {
    const Spin r = spin_block(k.lattice, k.jitter);
    std::printf("%s block spinning at 50 rad/s: largest strain %.3g at 10 ms, %.3g at 50 ms; angular momentum "
                "changed by %.2g of itself; %lld broken links\n",
                k.name, r.strain_early, r.strain_late, r.momentum_change, static_cast<long long>(r.broken));
    // The centripetal load of this block strains its links by about 2e-6 (cubic) to 4e-6 (random); the
    // false shear had taken the random lattice's to 7.2e-6 at 10 ms and 3.6e-5 at 50 ms. What is left
    // still grows slowly on every lattice, about 7e-7 per 100 ms at first (at 410 ms: cubic 4.6e-6,
    // jittered 7.0e-6, random without its bending springs 1.07e-5; 2026-12-03), not yet explained.
    EXPECT_LT(r.strain_late, 1.3 * r.strain_early) << k.name;
    EXPECT_LT(r.strain_late, 6e-6) << k.name;
    EXPECT_LT(r.momentum_change, 1e-6) << k.name;
    EXPECT_EQ(r.broken, 0) << k.name;
  }
}

// Energy of an 8^3 block released from a uniform expansion, at several Poisson ratios and time steps:
// the many-body (volumetric) energy is part of the elastic energy, so kinetic + elastic is conserved.
struct EnergyCase {
  double nu, safety;
};
void PrintTo(const EnergyCase& c, std::ostream* os) { *os << "nu " << c.nu << ", C " << c.safety; }
std::string case_name(const ::testing::TestParamInfo<EnergyCase>& info) {
  return "nu" + std::to_string(static_cast<int>(info.param.nu * 100)) + "_C" +
         std::to_string(static_cast<int>(info.param.safety * 1000));
}

class EnergyConservation : public ::testing::TestWithParam<EnergyCase> {};
class FullSpectrumEnergy : public ::testing::TestWithParam<EnergyCase> {};

TEST_P(EnergyConservation, BlockReleasedFromAnExpansion) {
  const auto [nu, safety] = GetParam();
  SceneDef s = block_scene(8, 8, 8, 0.01, test_material(30e9, nu));
  s.solver.safety = safety;
  Engine sim(s);
  State st = sim.state();
  for (auto& x : st.x) {
    x.x *= 1 + 1e-4;
    x.y *= 1 + 1e-4;
    x.z *= 1 + 1e-4;
  }
  sim.backend().upload(st);
  const double e0 = sim.energies().total();
  double worst = 0, most_kinetic = 0;
  for (int k = 0; k < 100; ++k) {
    sim.advance(100);
    const Energies e = sim.energies();
    worst = std::max(worst, std::fabs(e.total() - e0) / e0);
    most_kinetic = std::max(most_kinetic, e.kinetic);
  }
  std::printf("expansion, nu %.2f, C %.2f: largest change %.3g %% over 10,000 steps\n", nu, safety, 100 * worst);
  EXPECT_GT(most_kinetic, 0.3 * e0) << "the energy should move between elastic and kinetic";
  EXPECT_LT(worst, 0.01);
}

TEST_P(FullSpectrumEnergy, BlockWithRandomVelocities) {
  // Every mode excited, up to the highest: with the kinetic energy of velocity Verlet's v_n alone the
  // measured energy left the conserved one of the integrator by O((omega dt)^2), 2.4-2.95 % at the
  // default C = 0.5; with the half-step velocities' product (energy.cpp) it is the conserved one.
  const auto [nu, safety] = GetParam();
  SceneDef s = block_scene(8, 8, 8, 0.01, test_material(30e9, nu));
  s.solver.safety = safety;
  Engine sim(s);
  test::randomise_velocities(sim, 0.1, 10.0, 11);
  const double e0 = sim.energies().total();
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    sim.advance(100);
    worst = std::max(worst, std::fabs(sim.energies().total() - e0) / e0);
  }
  std::printf("random velocities, nu %.2f, C %.2f: largest change %.3g %% over 10,000 steps\n", nu, safety,
              100 * worst);
  EXPECT_LT(worst, 0.01);
}

INSTANTIATE_TEST_SUITE_P(PoissonAndStep, EnergyConservation,
                         ::testing::Values(EnergyCase{0.0, 0.125}, EnergyCase{0.0, 0.25}, EnergyCase{0.0, 0.5},
                                           EnergyCase{0.2, 0.125}, EnergyCase{0.2, 0.25}, EnergyCase{0.2, 0.5},
                                           EnergyCase{0.35, 0.125}, EnergyCase{0.35, 0.25}, EnergyCase{0.35, 0.5}),
                         case_name);
INSTANTIATE_TEST_SUITE_P(PoissonAndStep, FullSpectrumEnergy,
                         ::testing::Values(EnergyCase{0.0, 0.125}, EnergyCase{0.0, 0.25}, EnergyCase{0.0, 0.5},
                                           EnergyCase{0.2, 0.125}, EnergyCase{0.2, 0.25}, EnergyCase{0.2, 0.5},
                                           EnergyCase{0.35, 0.125}, EnergyCase{0.35, 0.25}, EnergyCase{0.35, 0.5}),
                         case_name);

// The strengthening law (paper eq. 7) is part of the energy: a block released from an expansion with an
// exponential law conserves kinetic + elastic like the linear one.
TEST(Energy, StrengtheningKeepsTheEnergy) {
  const MaterialDef mat = test::strengthening_material();
  SceneDef s = block_scene(6, 6, 6, 0.01, mat);
  Engine sim(s);
  State st = sim.state();
  for (auto& x : st.x) x.x *= 1 + 1.5e-4;  // f = exp(0.45) = 1.6 at the start
  sim.backend().upload(st);
  const double e0 = sim.energies().total();
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    sim.advance(100);
    worst = std::max(worst, std::fabs(sim.energies().total() - e0) / e0);
  }
  std::printf("strengthening: largest change %.3g %% over 10,000 steps\n", 100 * worst);
  EXPECT_EQ(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
  EXPECT_LT(worst, 0.01);
}

// A cantilever under a [[load]] with no gravity: the load's work is counted, so the run is not taken for
// a blow-up (it stopped at its first frame) and kinetic + elastic - load work is conserved.
TEST(Energy, ALoadsWorkIsCounted) {
  Engine sim(test::loaded_cantilever());
  double worst = 0, most_work = 0;
  for (int k = 0; k < 50; ++k) {
    const StepHealth h = sim.advance(Engine::kEnergyCheckInterval);
    ASSERT_EQ(h.flags, kHealthy) << "step " << h.step << ": energy " << h.energy << " over budget " << h.budget;
    const Energies e = sim.energies();
    most_work = std::max(most_work, e.load_work);
    worst = std::max(worst, std::fabs(e.total() - e.external_work()));
  }
  std::printf("cantilever: load work up to %.4g J, largest |energy - work| %.3g J\n", most_work, worst);
  EXPECT_GT(most_work, 0);
  EXPECT_LT(worst, 0.01 * most_work);
}

// Contacts store energy in their springs: a frictionless, perfectly elastic block bouncing on the ground
// keeps kinetic + elastic + contact energy - gravity work.
TEST(Energy, ContactSpringsAreCounted) {
  SceneDef s = block_scene(3, 3, 3, 0.05, MaterialDef{});
  s.materials.clear();
  MaterialDef m = test_material();
  m.restitution = 1;
  m.friction = 0;
  m.rolling_friction = 0;
  m.twisting_friction = 0;
  s.materials.push_back(m);
  s.objects[0].material = m.name;
  s.objects[0].position = {0, 0, 0.08};
  s.objects[0].velocity = {0, 0, -1};
  s.solver.gravity = {0, 0, -9.81};
  s.ground.enabled = true;
  s.ground.restitution = 1;
  s.ground.friction = 0;
  s.ground.rolling_friction = 0;
  s.ground.twisting_friction = 0;
  Engine sim(s);
  const Energies e0 = sim.energies();
  const double b0 = e0.total() - e0.external_work();
  double worst = 0, most_contact = 0;
  for (int k = 0; k < 400; ++k) {
    sim.advance(25);
    const Energies e = sim.energies();
    most_contact = std::max(most_contact, e.contact);
    worst = std::max(worst, std::fabs(e.total() - e.external_work() - b0) / b0);
  }
  std::printf("bouncing block: contact energy up to %.3g J, largest change of the balance %.3g %%\n", most_contact,
              100 * worst);
  EXPECT_GT(most_contact, 0.1 * b0) << "the block should have hit the ground";
  EXPECT_LT(worst, 0.01);
}

// A break changes the mean strain of an axis at both ends (the mean of two links becomes the one left),
// and with it their many-body energy lambda V theta L / 2: a break can put energy in. Per end the change is
// lambda ff V (L delta + delta^2 / 2) with |L| <= 3 eps_max and |delta| <= eps_max, so one break injects at
// most 7 lambda V eps_max^2 (less the link's own energy, which goes). Measured on a randomly strained block,
// link by link; and in an impact, where thousands break, the energy never rises above the start plus the
// work put in.
TEST(Energy, WhatABreakInjectsIsBounded) {
  Engine sim(block_scene(6, 6, 6, 0.05, test_material()));
  const Model& m = sim.model();
  State st = sim.state();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1, 1);
  for (auto& x : st.x) x += Vec3{static_cast<float>(u(rng)), static_cast<float>(u(rng)), static_cast<float>(u(rng))} * 1e-6f;
  const double w0 = compute_energies_at(m, st).elastic;
  const double eps_max = test::max_link_strain(m, st);
  const GroupParams& g = m.groups[0];
  const double scale = g.lame_lambda * m.volume[0] * eps_max * eps_max;
  double worst = 0;
  m.for_each_link([&](std::size_t l, std::uint32_t, std::uint32_t, int) {
    State t = st;
    t.intact[l] = 0;
    worst = std::max(worst, compute_energies_at(m, t).elastic - w0);
  });
  std::printf("one break in a random strain field (eps_max %.3g): at most %.3g lambda V eps_max^2 put in\n", eps_max,
              worst / scale);
  EXPECT_GT(worst, 0) << "the test should find a break that puts energy in";
  EXPECT_LE(worst, 7 * scale);

  SceneDef s = test::cubic_wall_scene();
  s.projectiles[0].position = {0, -0.31, 0.75};  // 1 cm from the wall
  Engine impact(s);
  const double start = impact.energies().total();
  double excess = -INFINITY;
  for (int k = 0; k < 30; ++k) {
    impact.advance(100);
    const Energies e = impact.energies();
    excess = std::max(excess, e.total() - e.external_work() - start);
  }
  std::printf("impact: %lld links broken; energy - work - start at most %.3g J (start %.4g J)\n",
              static_cast<long long>(impact.state().broken_by[0] + impact.state().broken_by[1]), excess, start);
  EXPECT_GT(impact.state().broken_by[0] + impact.state().broken_by[1], 1000);
  EXPECT_LT(excess, 1e-6 * start);
}

// safety = 1 is the stability limit of the linear lattice: an undamped block kept at C = 1 for 5,000
// steps (at which the old d / c_p step grew the energy 1e32-fold at C = 0.8) keeps its energy.
TEST(Stability, AnUndampedBlockAtTheLimitIsStable) {
  for (double nu : {0.0, 0.2, 0.45}) {
    const test::AtTheLimit r = test::energy_at_the_limit(block_scene(6, 6, 6, 0.01, test_material(30e9, nu)));
    std::printf("C = 1, nu %.2f: energy %.4g -> %.4g J\n", nu, r.before, r.after);
    EXPECT_LT(r.after, 1.2 * r.before) << "nu " << nu;
  }
}

// The critical step includes every stiffness: the shear springs with the rotations, strengthening,
// the contacts. A step above it is refused when given by hand.
TEST(Stability, ATimeStepAboveTheCriticalOneIsRefused) {
  SceneDef s = block_scene(4, 4, 4, 0.01);
  const Model m = lattice::build_model(s);
  EXPECT_GT(m.critical_dt, 0);
  s.solver.time_step = 1.01 * m.critical_dt;
  try {
    lattice::build_model(s);
    FAIL() << "a time step above the critical one was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("critical"), std::string::npos) << e.what();
  }
  // Strengthening shortens the step with the square root of its largest factor (here e^3 = 20; the
  // contact dashpots, which it does not stiffen, keep the ratio below sqrt(20)).
  const MaterialDef mat = test::strengthening_material();
  const Model hard = lattice::build_model(block_scene(4, 4, 4, 0.01, mat));
  EXPECT_LT(hard.critical_dt, m.critical_dt / std::sqrt(10.0));
}

// A blow-up that stays finite is caught by the library (Engine::advance, and so Simulation::advance),
// not only by the command: here a state far above its recorded starting energy. The check falls on the
// run's multiples of 256 steps whatever the calls (mca run and the Python module size theirs by the wall
// clock, so by the machine and the backend), and the run stops there: the same step every time.
TEST(Stability, TheLibraryFlagsEnergyGrowth) {
  for (const int chunk : {100, 7, 256, 1000}) {
    Engine sim(block_scene(4, 4, 4, 0.01));
    State st = sim.state();
    for (auto& v : st.v) v = DVec3{1, 0, 0};  // 1 m/s with a starting energy of zero: nothing put it in
    st.initial_energy = 0;
    sim.backend().upload(st);
    StepHealth h;
    for (int k = 0; k < 400 && h.flags == kHealthy; ++k) h = sim.advance(chunk);
    EXPECT_TRUE(h.flags & kEnergyGrowth) << "calls of " << chunk;
    EXPECT_GT(h.energy, 10 * h.budget);
    EXPECT_EQ(h.step, Engine::kEnergyCheckInterval) << "calls of " << chunk;
    EXPECT_EQ(sim.step(), Engine::kEnergyCheckInterval) << "calls of " << chunk;
  }
  // A state resumed between two checks is checked at the next multiple, as the uninterrupted run was.
  Engine sim(block_scene(4, 4, 4, 0.01));
  State st = sim.state();
  st.step = 300;
  st.time = 300.0 * sim.model().dt;
  for (auto& v : st.v) v = DVec3{1, 0, 0};
  st.initial_energy = 0;
  sim.backend().upload(st);
  const StepHealth h = sim.advance(1000);
  EXPECT_TRUE(h.flags & kEnergyGrowth);
  EXPECT_EQ(h.step, 2 * Engine::kEnergyCheckInterval);
}

}  // namespace
}  // namespace mca
