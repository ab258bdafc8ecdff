// The random lattice (solver.lattice = "random"): a site at a random point of each cell, linked to its
// Voronoi neighbours (lattice/random_lattice.hpp). Its cells fill the object, nothing starts in contact,
// a body at rest stays at rest, every instruction set, thread count and resumed run computes the same
// bits, and its elastic constants as measured (docs/model-notes.md, "The random lattice").
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <tbb/global_control.h>

#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "physics/fracture.hpp"
#include "physics/link_law.hpp"
#include "bitwise.hpp"
#include "support.hpp"

namespace mca {
namespace {

SceneDef random_block(int n, MaterialDef mat = test::test_material()) {
  SceneDef s = test::block_scene(n, n, n, 0.01, mat);
  s.solver.lattice = SolverDef::Lattice::random;
  return s;
}

// Each site lies in its own cell (the cubic lattice's automaton of the same index), those of the surface at
// the cell's centre along the face's normal; the Voronoi cells fill the block (to 2 %); only interior automata are boxed in;
// each link's rest length is its sites' distance; the contact reach of every pair is at most their
// distance (nothing starts pressed together).
TEST(RandomLattice, SitesFillTheirCellsAndNoPairStartsInContact) {
  const int n = 8;
  const double d = 0.01;
  Engine cubic(test::block_scene(n, n, n, d)), random(random_block(n));
  const Model &c = cubic.model(), &m = random.model();
  ASSERT_EQ(c.size(), m.size());
  EXPECT_TRUE(m.random_automaton(0));
  EXPECT_EQ(m.explicit_links.size(), m.links);
  double volume = 0;
  std::size_t boxed = 0;
  for (std::size_t a = 0; a < m.size(); ++a) {
    const DVec3 off = ddelta(c.position0[a], m.position0[a]);
    const double o[3] = {off.x, off.y, off.z}, p[3] = {c.position0[a].x, c.position0[a].y, c.position0[a].z};
    for (int k = 0; k < 3; ++k) {
      EXPECT_LE(std::fabs(o[k]), 0.5 * d * (1 + 1e-9)) << "automaton " << a;
      // On a face of the block: at the cell's centre along the face's normal.
      if (std::fabs(p[k]) > 0.5 * (n - 1) * d - 1e-9) {
        EXPECT_NEAR(o[k], 0.0, 1e-12) << "automaton " << a;
      }
    }
    EXPECT_EQ(m.radius[a], c.radius[a]);
    volume += m.volume[a];
    boxed += m.boxed[a];
    if (m.boxed[a]) {
      for (int k = 0; k < 3; ++k) EXPECT_LT(std::fabs(p[k]), 0.5 * (n - 1) * d - 1e-9) << "automaton " << a << " is on a face";
    }
  }
  const double box = std::pow(n * d, 3);
  std::printf("8^3 random block: Voronoi volume %.4f of the block's, %zu links (%.2f per automaton), %zu boxed in\n",
              volume / box, m.links, 2.0 * m.links / m.size(), boxed);
  EXPECT_NEAR(volume / box, 1.0, 0.02);
  EXPECT_GT(boxed, (n - 2) * (n - 2) * (n - 2) / 2) << "most interior sites";
  const auto& E = m.explicit_links;
  for (std::size_t l = 0; l < E.size(); ++l) {
    const DVec3 dd = ddelta(m.position0[E.i[l]], m.position0[E.j[l]]);
    EXPECT_EQ(E.r0[l], std::sqrt(dot(dd, dd)));
    EXPECT_GT(E.r0[l], 0.3 * d);
    EXPECT_LT(E.r0[l], 3.0 * d);
  }
  for (std::size_t i = 0; i < m.size(); ++i)
    for (std::size_t j = i + 1; j < m.size(); ++j) {
      const DVec3 dd = ddelta(m.position0[i], m.position0[j]);
      EXPECT_LE(m.contact_reach(i, j), std::sqrt(dot(dd, dd))) << i << ", " << j;
    }
  // The same seed, the same sites; another seed, others.
  EXPECT_EQ(Engine(random_block(n)).model().position0[17].x, m.position0[17].x);
  SceneDef other = random_block(n);
  other.solver.seed = 7;
  EXPECT_NE(Engine(other).model().position0[17].x, m.position0[17].x);
}

TEST(RandomLattice, ABodyAtRestStaysAtRest) { test::expect_stays_at_rest(random_block(8), "random block"); }

// The hostile review's findings: the default wall without its ball, standing on the ground, broke links
// under its own weight (its surface sites lay inside their cells, their contact spheres short of the
// faces); an object of one automaton, which has no link, crashed the energy sums; a scene over
// solver.max_memory_gb passed its check, which counted no link.
TEST(RandomLattice, AWallStandingOnTheGroundStaysWhole) {
  SceneDef s = test::cubic_wall_scene();
  s.solver.lattice = SolverDef::Lattice::random;
  s.projectiles.clear();
  Engine sim(s);
  ASSERT_EQ(sim.advance(20000).flags, kHealthy);
  const Energies e = sim.energies();
  std::printf("random wall on the ground after 20,000 steps (%.3g s): kinetic %.3g J\n", sim.state().time, e.kinetic);
  EXPECT_EQ(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
  // (It settles under its own weight: 1.6e-3 J of its 1,300 kg at 14 ms, a sag's ringing.)
  EXPECT_LT(e.kinetic, 1e-2);
}

// (Its critical step: with no link there is nothing for the power iteration, and the automaton's own
// rows, its contacts and the ground's, bound it; the iteration alone gave an infinite step, found when
// the iteration came back.)
TEST(RandomLattice, AnObjectOfOneAutomatonRuns) {
  SceneDef s = test::block_scene(1, 1, 1, 0.01, test::test_material());
  s.solver.lattice = SolverDef::Lattice::random;
  Engine sim(s);
  EXPECT_EQ(sim.model().links, 0u);
  EXPECT_EQ(sim.advance(100).flags, kHealthy);
  EXPECT_EQ(sim.energies().elastic, 0.0);
  s.ground.enabled = true;
  s.ground.height = -0.01;
  const double dt = Engine(s).model().critical_dt, cubic = Engine(test::block_scene(2, 2, 2)).model().critical_dt;
  std::printf("one random automaton on the ground: critical step %.3g s (a cubic 2^3 block's %.3g s)\n", dt, cubic);
  EXPECT_LT(dt, 2 * cubic);
}

TEST(RandomLattice, TheMemoryCheckCountsTheLinks) {
  SceneDef s = test::cubic_wall_scene();
  s.solver.spacing = 0.02;  // 75,000 automata: about 190 MB on the random lattice, 100 MB on the cubic one
  s.solver.max_memory_gb = 0.15;
  EXPECT_EQ(test::error_of([&] { lattice::build_model(s); }), "");
  s.solver.lattice = SolverDef::Lattice::random;
  const std::string e = test::error_of([&] { lattice::build_model(s); });
  EXPECT_NE(e.find("over solver.max_memory_gb = 0.15"), std::string::npos) << e;
}

// The critical step (its power iteration, lattice/time_step.cpp): an undamped random block with random
// velocities kept at safety = 1 for 5,000 steps keeps its energy, at Poisson's ratios where the pairs'
// springs (0) and the many-body term (0.45) dominate. Its step, against the cubic block's: 0.37, 0.43 and
// 0.86 when first built, 0.40, 0.48 and 0.94 with the neighbour pairs' contacts taken as E d, 0.82, 0.92
// and 0.94 with their own (the default wall: 0.51 with its ground and ball, where the automata's
// Gershgorin rows gave 0.32).
TEST(RandomLattice, AnUndampedBlockAtTheLimitIsStable) {
  for (double nu : {0.0, 0.2, 0.45}) {
    const test::AtTheLimit r = test::energy_at_the_limit(random_block(6, test::test_material(30e9, nu)));
    const double cubic = Engine(test::block_scene(6, 6, 6, 0.01, test::test_material(30e9, nu))).model().critical_dt;
    std::printf("random lattice at C = 1, nu %.2f: step %.3g of the cubic lattice's, energy %.4g -> %.4g J\n", nu,
                r.critical_dt / cubic, r.before, r.after);
    EXPECT_LT(r.after, 1.2 * r.before) << "nu " << nu;
    EXPECT_GT(r.critical_dt, 0.3 * cubic) << "nu " << nu;
  }
}

// Once its links have broken, a random block's Voronoi neighbours press on each other as contacts of their
// links' normal stiffness (Model::contact_length), which the critical step takes for each pair (not the
// contact law's E d, several times stiffer for most of the lattice's faces and up to 50 times for a long
// thin one). A block of 8^3 automata of a material too weak to hold any link, its outer layer held by six
// grips of which two close in at 0.1 m/s, at safety = 1: it loses its links within its first steps, its
// automata are then pressed together harder and harder, and what they hold (kinetic and elastic energy)
// must stay below what the grips put in. (The backend's pair contacts made three times as stiff as the
// step takes them blow it up within 300 steps; twice as stiff, it holds.)
TEST(RandomLattice, ABrokenBlockPressedTogetherIsStableAtTheLimit) {
  MaterialDef mat = test::test_material(30e9, 0.2);
  mat.tensile_strength = 3e4;  // a strain of 1e-6, the least the solver takes
  mat.compressive_strength = 3e4;
  mat.fracture_strain = 1e-6;
  SceneDef s = random_block(8, mat);  // centred on the origin, d = 1 cm: the outer layer's sites at +-3.5 cm
  s.solver.safety = 1.0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      GripDef g;
      g.name = fmt::format("wall{}{}", axis, side);
      g.min = {-1, -1, -1};
      g.max = {1, 1, 1};
      (side ? g.min : g.max)[axis] = side ? 0.032 : -0.032;
      if (axis == 0) g.velocity[0] = side ? -0.1 : 0.1;
      s.grips.push_back(g);
    }
  Engine sim(s);
  double held = 0;
  for (int k = 0; k < 50; ++k) {
    ASSERT_EQ(sim.advance(100).flags, kHealthy) << "after " << 100 * (k + 1) << " steps";
    held = std::max(held, sim.energies().total());
  }
  const State st = sim.state();
  const Energies e = sim.energies();
  const std::size_t broken = st.broken_by[0] + st.broken_by[1];
  std::printf("broken random block pressed at C = 1 (critical step %.3g s): %zu of %zu links broken, energy %.4g J "
              "(contacts %.4g J), grips' work %.4g J\n",
              sim.model().critical_dt, broken, sim.model().links, e.total(), e.contact, e.grip_work);
  EXPECT_GT(broken, sim.model().links / 2);  // (those between two held automata hold)
  EXPECT_GT(e.contact, 0.1 * e.grip_work);
  EXPECT_LT(held, e.grip_work);
}

// The power iteration runs over ranges of automata in parallel (lattice/time_step.cpp, pairs_by_range;
// by default ranges of at least 4,096 automata, about four per thread): its step must be the serial
// loop's (one range) for any count, on any thread count. (Its eigenvalue is the largest of the rounds'
// Rayleigh quotients, which the order of a few sums may leave unchanged; a pair left out or counted twice
// changes it: the hostile review's mutations. On the 357,035 automata of wall_357k_random, 8 ranges on
// two threads gave the serial loop's state after a step.)
TEST(RandomLattice, TheTimeStepIsTheSameOnEveryThreadCount) {
  SceneDef s = test::block_scene(16, 16, 16, 0.01, test::test_material());
  s.solver.lattice = SolverDef::Lattice::random;
  const Model m = lattice::build_model(s);
  const double serial = lattice::critical_time_step(m, 1).dt;
  std::printf("random block of 4,096 automata: critical step %.17g s (one range)\n", serial);
  EXPECT_GT(serial, 0);
  EXPECT_EQ(m.critical_dt, serial);  // the automatic count: one range of this block
  for (const std::size_t threads : {1, 2})
    for (const std::size_t ranges : {2, 3, 7, 64}) {
      tbb::global_control gc(tbb::global_control::max_allowed_parallelism, threads);
      EXPECT_EQ(lattice::critical_time_step(m, ranges).dt, serial) << threads << " threads, " << ranges << " ranges";
    }
}

// The default wall on the random lattice, the ball 5 mm from it: every instruction set, thread count and
// sweep gives the same state, and so does a run resumed from a checkpoint.
TEST(RandomLattice, EveryInstructionSetThreadCountAndResumeGivesTheSameState) {
  SceneDef s = test::struck_default_wall();
  s.solver.lattice = SolverDef::Lattice::random;
  EXPECT_GT(test::expect_bitwise_everywhere(s, 1500).broken, 0);
}

// Uniaxial stress on a 20^3 block: the modulus and Poisson's ratios of its middle half against the input,
// with the lattice's stiffness factor (lattice::kRandomStiffness). Measured: E 1.0030, nu 0.1994 / 0.1993
// at nu = 0.2, settled within 10,000 steps (0.9901, 0.2000 / 0.2009 when first measured, on the lattice
// of then). (With equal loads on the end faces' sites, whose moment about the faces' centres turned the
// block without end, it never settled: E and nu_y swung
// between 0.99 and 1.02 and 0.20 and 0.24 over 70 ms, and what the test read at 50,000 steps depended on
// the step. test::uniaxial_block_moduli now loads the faces free of moment.)
TEST(RandomLattice, ABlockReturnsTheInputModulusAndPoissonRatio) {
  const int n = 20;
  const double d = 0.01, E = 30e9, sigma = 1e6;
  for (const double nu : {0.2}) {
    SCOPED_TRACE(nu);
    // (The end layers' sites lie in the inner half of their cells, the next layer's beyond it.)
    const test::BlockModuli b = test::uniaxial_block_moduli(random_block(n, test::test_material(E, nu)), n, d, sigma, 0.2499 * d);
    std::printf("random lattice, nu %.2f: E %.4f E, nu %.4f / %.4f\n", nu, b.E / E, b.nu_y, b.nu_z);
    EXPECT_NEAR(b.E / E, 1.0, 0.02);
    EXPECT_NEAR(b.nu_y / nu, 1.0, 0.02);
    EXPECT_NEAR(b.nu_z / nu, 1.0, 0.02);
  }
}

// Simple shear on a 20^3 block: the law's G (the middle half's averaged stress over its shear strain)
// against E / (2 (1 + nu)), and the applied traction over that strain against the cubic lattice's.
// Measured: the law's G 0.9979 (cubic 0.9963); traction over strain 0.9412 (cubic 0.9380: on either
// lattice the surface layers are softer in shear and the interior carries more than the traction,
// Physics.BlockInSimpleShearReturnsShearModulus).
TEST(RandomLattice, ABlockInSimpleShearReturnsTheShearModulus) {
  const int n = 20;
  const double d = 0.01, E = 30e9, nu = 0.2, tau = 1e6, G = E / (2 * (1 + nu));
  const test::ShearModuli c = test::simple_shear_modulus(test::block_scene(n, n, n, d, test::test_material(E, nu)), n, d, tau, 0);
  const test::ShearModuli r = test::simple_shear_modulus(random_block(n, test::test_material(E, nu)), n, d, tau, 0.2499 * d);
  std::printf("simple shear, 20^3: cubic G %.4f (law) / %.4f (applied traction) of E / (2 (1 + nu)), random %.4f / %.4f\n",
              c.interior / G, c.applied / G, r.interior / G, r.applied / G);
  EXPECT_NEAR(r.interior / G, 1.0, 0.03);
  EXPECT_NEAR(r.applied / c.applied, 1.0, 0.02);
}

// A random-lattice link's own criterion (physics/fracture.hpp, random_link_effort), with a tensile limit 1
// and a compressive limit 10: a tension cut-off, a shear limit of the cohesion plus the friction times its
// compression (not lowered by tension), crushing.
TEST(RandomLattice, ALinkIsHeldToItsOwnStresses) {
  const float f = 1.0f, fc = 10.0f, c = kRandomCohesion, mu = kRandomFriction;
  EXPECT_FLOAT_EQ(random_link_effort(1.0f, 0.0f, f, fc), 1.0f);
  EXPECT_LT(random_link_effort(0.99f, 0.0f, f, fc), 1.0f);
  EXPECT_FLOAT_EQ(random_link_effort(0.0f, c, f, fc), 1.0f);
  EXPECT_LT(random_link_effort(0.0f, 0.99f * c, f, fc), 1.0f);
  EXPECT_FLOAT_EQ(random_link_effort(0.5f, c, f, fc), 1.0f);                 // tension leaves the cohesion
  EXPECT_FLOAT_EQ(random_link_effort(-2.0f, c + 2.0f * mu, f, fc), 1.0f);  // compression adds friction
  EXPECT_LT(random_link_effort(-2.0f, c + 1.9f * mu, f, fc), 1.0f);
  EXPECT_FLOAT_EQ(random_link_effort(-10.0f, 0.0f, f, fc), 1.0f);
  EXPECT_LT(random_link_effort(-9.9f, 0.0f, f, fc), 1.0f);
  // Stretched ten times past the limit while softening: the tension ratio, not a vanishing shear limit.
  EXPECT_FLOAT_EQ(random_link_effort(10.0f, 1.0f, f, fc), 10.0f);
}

// The jittered lattice's tests of strength and wave speed (test_lattice_jitter.cpp) on the random lattice.
// The block's strength, with the lattice's strength factor (lattice::kRandomStrength, 1.10, with the
// links' bending springs at link_bending = 0.1), is the cubic lattice's 0.913 of the tensile strength:
// 0.924 (0.915 with 1.078 and no bending springs, lattice::kRandomStrengthUnbent).
TEST(RandomLattice, TensileStrengthOfABlockAsMeasured) {
  const test::TensileResult r = test::block_tensile_strength(
      [](SceneDef& sc) { sc.solver.lattice = SolverDef::Lattice::random; }, 0.2499 * 0.01);
  std::printf("random lattice: peak mean stress %.3f of the tensile strength, %lld broken links\n", r.strength,
              static_cast<long long>(r.broken));
  EXPECT_GT(r.broken, 0);
  EXPECT_NEAR(r.strength, 0.913, 0.03);
}

// The same block pressed (at 0.02 m/s): brittle materials are 8-12 times stronger in compression than in
// tension (design/physics.md sec. 4). The cubic lattice's block peaks at 0.620 of the compressive strength
// (6.8 times its tensile peak, which is 0.913). The random lattice's gave way at 0.270 (3.0 times) while a
// broken link left its pair a gap of up to 1.2 d (Model::contact_reach), at 0.454 once the pairs touched
// at their initial distance with their links' stiffness (Model::contact_length), its links breaking by
// shear from a tenth of the strength under the lattice's equivalent stress. Held to their own stresses
// (random_link_effort) they first break at a third, and the block holds 0.599 (6.5 times); 0.597 since
// the ghosts are mirrored (lattice::kRandomStrength).
TEST(RandomLattice, ABlockInCompressionHoldsOnceItsLinksHaveBroken) {
  const test::TensileResult c = test::block_strength([](SceneDef&) {}, 0.0, -0.02, 0.5);
  const test::TensileResult r = test::block_strength(
      [](SceneDef& sc) { sc.solver.lattice = SolverDef::Lattice::random; }, 0.2499 * 0.01, -0.02, 0.5);
  std::printf("pressed block: cubic lattice %.3f of the compressive strength (%lld broken links), random lattice "
              "%.3f (%lld)\n",
              c.strength, static_cast<long long>(c.broken), r.strength, static_cast<long long>(r.broken));
  EXPECT_GT(c.strength, 0.55);
  EXPECT_GT(r.strength, 0.55);
}

// The pulse along a bar of 4 x 4 automata, all of them at its surface.
TEST(RandomLattice, APulseTravelsAtTheCubicLatticesSpeed) {
  const double cubic = test::bar_wave_speed([](SceneDef&) {});
  const double random = test::bar_wave_speed([](SceneDef& sc) { sc.solver.lattice = SolverDef::Lattice::random; });
  std::printf("bar wave, 4 x 4 section: cubic %.1f m/s, random %.1f m/s (sqrt(E/rho) = 3535.5)\n", cubic, random);
  EXPECT_NEAR(random / cubic, 1.0, 0.02);  // 1.0015 (0.947 with the ghosts drawn at random)
  EXPECT_NEAR(random / 3535.5, 1.0, 0.03);
}

// The random lattice's surface is as stiff as its interior: a bar of 4 x 4 and one of 8 x 8 carry a pulse
// of long waves only (so that the lattices' dispersion plays no part) at the cubic lattice's speed. With
// the ghosts drawn at random (before 2026-12-03) they were slower by 5.4 % and 2.5 %, a share that halved
// as the section doubled: a soft surface, as if 0.1 d were missing from each face. The faces toward the
// ghosts leaned, and their missing links took 9.5 % and 5.0 % of the bars' sum of A r n_x^2 over all
// faces, the moduli's 10.5 % and 5.0 % deficits (random_sites mirrors the ghosts now; docs/model-notes.md,
// "The random lattice", Wave speed).
TEST(RandomLattice, ABarsSurfaceIsAsStiffAsItsInterior) {
  auto random = [](SceneDef& sc) { sc.solver.lattice = SolverDef::Lattice::random; };
  for (const int section : {4, 8}) {
    const double c = test::bar_wave_speed([](SceneDef&) {}, section, 20), r = test::bar_wave_speed(random, section, 20);
    std::printf("bar of %d x %d, pulse of 20 layers: cubic %.1f m/s, random %.1f m/s (%.4f; sqrt(E/rho) = 3535.5)\n",
                section, section, c, r, r / c);
    EXPECT_NEAR(r / c, 1.0, 0.015) << section;  // 1.0004 and 1.0022 (0.9461 and 0.9747 with random ghosts)
  }
}

// Two automata of the random lattice, one link along x, turning against each other about `axis` at
// `omega` (rad/s) each, nothing else moving: the pair's springs see only the sum of the two rotations, so
// without the bending spring (link_bending = 0) nothing resists and the link stays a free hinge; with it
// the pair swings at omega_0 = sqrt(2 k / J), k the spring's stiffness about that axis
// (volume_bending_constants) and J each automaton's moment of inertia.
struct Hinge {
  Model model;
  std::vector<double> spin;  // the second automaton's angular velocity about the axis, after each step
  double dt = 0, energy0 = 0, energy_spread = 0;
  bool intact = true;
};
Hinge turned_pair(double bending, int axis, double omega, int steps, MaterialDef mat = test::test_material()) {
  mat.damping_time = 0;
  SceneDef s = test::block_scene(2, 1, 1, 0.01, mat);
  s.solver.lattice = SolverDef::Lattice::random;
  s.solver.link_bending = bending;
  Engine sim(s);
  State st = sim.state();
  DVec3 w{};
  (axis == 0 ? w.x : axis == 1 ? w.y : w.z) = omega;
  st.w[0] = w * -1.0;
  st.w[1] = w;
  Engine run(s, st);
  Hinge h{run.model(), {}, run.model().dt};
  h.energy0 = run.energies().total();
  double lo = h.energy0, hi = h.energy0;
  for (int k = 0; k < steps; ++k) {
    EXPECT_EQ(run.advance(1).flags, kHealthy);
    const DVec3 w1 = run.state().w[1];
    h.spin.push_back(axis == 0 ? w1.x : axis == 1 ? w1.y : w1.z);
    const double e = run.energies().total();
    lo = std::min(lo, e);
    hi = std::max(hi, e);
  }
  h.energy_spread = (hi - lo) / h.energy0;
  h.intact = run.state().intact[3 * run.model().size()] != 0;
  return h;
}

TEST(RandomLattice, TwoAutomataTurningAgainstEachOtherAreHeldByTheBendingSpring) {
  const double omega = 1.0;
  // Without the spring: a hinge. Neither automaton's spin changes.
  for (const int axis : {0, 1, 2}) {
    const Hinge free = turned_pair(0.0, axis, omega, 2000);
    ASSERT_EQ(free.model.explicit_links.size(), 1u);
    EXPECT_TRUE(free.intact);
    for (const double w : free.spin) EXPECT_NEAR(w, omega, 1e-6 * omega) << axis;
  }
  // With it: a swing at sqrt(2 k / J), about the link (twist, x) and across it (bending, y and z).
  for (const int axis : {0, 1, 2}) {
    const Hinge h0 = turned_pair(0.1, axis, omega, 20);
    const Model& m = h0.model;
    const auto& E = m.explicit_links;
    const GroupParams& g = m.groups[m.group[0]];
    EXPECT_FLOAT_EQ(static_cast<float>(E.edge[0] * E.edge[0]), E.area[0]);
    const LinkBendingConstants bc = volume_bending_constants(m.lattice_stiffness * g.youngs, m.lattice_stiffness * g.shear_modulus,
                                                             E.r0[0], E.edge[0], 0.1);
    // The beam of the link's section taken round (I = A^2 / (4 pi), J = 2 I), a share 0.1 of it.
    const double A = static_cast<double>(E.edge[0]) * E.edge[0], I = A * A / (4 * std::numbers::pi);
    EXPECT_NEAR(bc.k_in, 0.1 * m.lattice_stiffness * g.youngs * I / E.r0[0], 1e-5 * bc.k_in);
    EXPECT_NEAR(bc.k_twist, 0.1 * m.lattice_stiffness * g.shear_modulus * 2 * I / E.r0[0], 1e-5 * bc.k_twist);
    EXPECT_EQ(bc.s_twist, 0.5f * bc.s_in);
    const double k = axis == 0 ? bc.k_twist : bc.k_in;
    const double w0 = std::sqrt(2.0 * k / m.inertia[0]);
    const int quarter = static_cast<int>(0.5 * std::numbers::pi / w0 / m.dt);
    const Hinge h = turned_pair(0.1, axis, omega, 8 * quarter);
    EXPECT_TRUE(h.intact);
    // The first time the spin turns: a quarter of the swing's period (between two steps, interpolated).
    // The spin after k steps turned the spring through step k + 1 before the next kick changed it: it is
    // the spin at (k + 1/2) dt, as in any leapfrog (spin[i] is the spin after i + 1 steps).
    std::size_t turn = 0;
    while (turn < h.spin.size() && h.spin[turn] > 0) ++turn;
    ASSERT_LT(turn, h.spin.size()) << "the spin never turned about axis " << axis;
    ASSERT_GT(turn, 0u);
    const double before = h.spin[turn - 1], after = h.spin[turn];
    const double t = (static_cast<double>(turn) + 0.5 + before / (before - after)) * m.dt;
    std::printf("pair turned about axis %d: quarter swing %.4g s, sqrt(2 k / J) gives %.4g s (%d steps); energy within %.2g\n",
                axis, t, 0.5 * std::numbers::pi / w0, quarter, h.energy_spread);
    EXPECT_NEAR(t * w0 / (0.5 * std::numbers::pi), 1.0, 0.01) << axis;
    // Undamped: the kinetic energy goes into the spring and back (energies.cpp sums the spring's).
    EXPECT_LT(h.energy_spread, 0.01) << axis;
  }
}

// Turned fast enough, the bent link breaks by its stress criterion: the bending's fibre stress is its
// moment M times c / I (a round section of the face's area A: I = A^2 / (4 pi), c = sqrt(A / pi);
// volume_bending_constants), and a moment of f I / c breaks it, f its tensile limit. The hinge of the same
// pair without the spring turns on, unbroken.
TEST(RandomLattice, ABentLinkBreaksAtItsFibresStrength) {
  MaterialDef mat = test::test_material();
  mat.tensile_strength = 1e6;
  mat.compressive_strength = 1e8;
  // The largest moment of the swing is omega J w0 (the spin's energy, J omega^2 per automaton, in the
  // spring: M^2 / (2 k) = J omega^2, M = omega sqrt(2 J k) = omega J w0): 1.1 and 0.9 times the moment
  // that breaks it.
  const Hinge h0 = turned_pair(0.1, 1, 1.0, 20, mat);
  const Model& m = h0.model;
  const auto& E = m.explicit_links;
  const GroupParams& g = m.groups[m.group[0]];
  const LinkBendingConstants bc =
      volume_bending_constants(m.lattice_stiffness * g.youngs, m.lattice_stiffness * g.shear_modulus, E.r0[0], E.edge[0], 0.1);
  const double A = static_cast<double>(E.edge[0]) * E.edge[0], f = m.lattice_strength * mat.tensile_strength;
  const double I = A * A / (4 * std::numbers::pi), c = std::sqrt(A / std::numbers::pi);
  const double breaking = f * I / c, omega = breaking / std::sqrt(2.0 * m.inertia[0] * bc.k_in);
  const double w0 = std::sqrt(2.0 * bc.k_in / m.inertia[0]);
  const int quarter = static_cast<int>(0.5 * std::numbers::pi / w0 / m.dt);
  EXPECT_FALSE(turned_pair(0.1, 1, 1.1 * omega, 2 * quarter, mat).intact);
  EXPECT_TRUE(turned_pair(0.1, 1, 0.9 * omega, 2 * quarter, mat).intact);
  EXPECT_TRUE(turned_pair(0.0, 1, 1.1 * omega, 2 * quarter, mat).intact);
}

}  // namespace
}  // namespace mca
