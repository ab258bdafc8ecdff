// The lattice builder: shapes, placement, regions, target counts, and the scene checks it makes.
#include <gtest/gtest.h>

#include <cstdio>

#include <chrono>
#include <cmath>
#include <numbers>

#include <fmt/format.h>

#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "physics/contact_law.hpp"
#include "support.hpp"

namespace mca {
namespace {

TEST(Lattice, BoxHasFaceLinksOnly) {
  const Model m = lattice::build_model(test::block_scene(4, 3, 2));
  EXPECT_EQ(m.size(), 24u);
  EXPECT_EQ(m.link_count(), 3u * 3 * 2 + 4u * 2 * 2 + 4u * 3 * 1);  // x, y and z links
  std::size_t links = 0;
  m.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int axis) {
    ++links;
    EXPECT_EQ(l, axis * m.size() + i);
    EXPECT_LT(i, j);
    EXPECT_EQ(m.neighbour_below[axis * m.size() + j], i);
    const Vec3 d = delta(m.position0[i], m.position0[j]);
    EXPECT_NEAR(length(d), m.spacing, 1e-6);
    EXPECT_NEAR(axis == 0 ? d.x : (axis == 1 ? d.y : d.z), m.spacing, 1e-6);  // along +axis
  });
  EXPECT_EQ(links, m.link_count());
}

TEST(Lattice, SphereAndCylinderFillTheirVolume) {
  SceneDef s = test::block_scene(1, 1, 1, 0.01);
  s.objects[0].shape = Shape::sphere;
  s.objects[0].radius = 0.2;
  const double sphere = 4.0 / 3.0 * std::numbers::pi * std::pow(0.2, 3) / 1e-6;
  EXPECT_NEAR(lattice::count_automata(s, 0.01) / sphere, 1.0, 0.02);
  s.objects[0].shape = Shape::cylinder;
  s.objects[0].height = 0.3;
  const double cyl = std::numbers::pi * 0.04 * 0.3 / 1e-6;
  EXPECT_NEAR(lattice::count_automata(s, 0.01) / cyl, 1.0, 0.02);
}

TEST(Lattice, CountWithoutBuildingMatchesTheBuiltLattice) {
  for (Shape shape : {Shape::sphere, Shape::cylinder}) {
    for (double d : {0.013, 0.01, 0.037, 0.05}) {
      SceneDef s = test::block_scene(1, 1, 1, d);
      s.objects[0].shape = shape;
      s.objects[0].radius = 0.2;
      s.objects[0].height = 0.23;
      EXPECT_EQ(lattice::count_automata(s, d), static_cast<std::int64_t>(lattice::build_model(s).size()))
          << "shape " << static_cast<int>(shape) << ", d " << d;
    }
  }
}

TEST(Lattice, ATinySpacingIsRefusedByTheMemoryCheckNotByExhaustingMemory) {
  SceneDef s = test::block_scene(1, 1, 1, 1e-4);
  s.objects[0].shape = Shape::sphere;
  s.objects[0].radius = 1.0;  // about 4e12 automata
  try {
    lattice::build_model(s);
    FAIL() << "a 4e12-automata sphere was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("GB"), std::string::npos) << e.what();
  }
}

TEST(Lattice, RotationAndPositionPlaceTheObject) {
  SceneDef s = test::block_scene(10, 2, 2, 0.1);
  s.objects[0].rotation = {0, 0, 90};  // the long axis now along y
  s.objects[0].position = {5, -3, 1};
  const Model m = lattice::build_model(s);
  float xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
  for (const DVec3& pd : m.position0) {
    const Vec3 p = to_vec3(pd);
    xmin = std::min(xmin, p.x);
    xmax = std::max(xmax, p.x);
    ymin = std::min(ymin, p.y);
    ymax = std::max(ymax, p.y);
  }
  EXPECT_NEAR(xmax - xmin, 0.1, 1e-4);
  EXPECT_NEAR(ymax - ymin, 0.9, 1e-4);
  EXPECT_NEAR(0.5 * (xmin + xmax), 5.0, 1e-4);
  EXPECT_NEAR(0.5 * (ymin + ymax), -3.0, 1e-4);
}

TEST(Lattice, RegionsAssignMaterialGroups) {
  SceneDef s = test::block_scene(10, 10, 10, 0.01);
  RegionDef r;
  r.shape = Shape::sphere;
  r.center = {0, 0, 0};
  r.radius = 0.03;
  r.material = "granite";
  s.objects[0].regions.push_back(r);
  const Model m = lattice::build_model(s);
  ASSERT_EQ(m.groups.size(), 2u);
  std::size_t in_region = 0;
  for (std::size_t a = 0; a < m.size(); ++a) {
    const bool inside = length(to_vec3(m.position0[a])) <= 0.03f;
    EXPECT_EQ(m.group_names[m.group[a]], inside ? "granite" : "testmat");
    in_region += inside;
  }
  EXPECT_GT(in_region, 50u);
  // Granite is denser than the test material: the mass follows the group.
  EXPECT_GT(m.total_mass, 1000 * 2400 * 1e-6);
}

TEST(Lattice, TargetCountLandsWithinTwoPercent) {
  SceneDef s = test::block_scene(1, 1, 1, 0.01);
  s.objects[0].shape = Shape::sphere;
  s.objects[0].radius = 0.5;
  s.solver.target_automata = 50000;
  const Model m = lattice::build_model(s);
  EXPECT_NEAR(static_cast<double>(m.size()) / 50000.0, 1.0, 0.02);
}

TEST(Lattice, SeveralObjectsAndAKinematicProjectile) {
  SceneDef s = test::block_scene(3, 3, 3, 0.1);
  ObjectDef second = s.objects[0];
  second.name = "second";
  second.position = {1, 0, 0};
  s.objects.push_back(second);
  ProjectileDef p;
  p.position = {0, -1, 0};
  p.velocity = {0, 5, 0};
  p.kinematic = true;
  s.projectiles.push_back(p);
  Engine sim(s);
  EXPECT_EQ(sim.model().size(), 54u);
  EXPECT_EQ(sim.model().object_names.size(), 2u);
  sim.advance(2000);
  EXPECT_FLOAT_EQ(sim.state().projectiles[0].velocity.y, 5.0f) << "a kinematic ball keeps its velocity";
}

TEST(Lattice, RefusesATimeStepAboveTheStableOne) {
  SceneDef s = test::block_scene(3, 3, 3, 0.01);
  s.solver.time_step = 1e-3;
  try {
    lattice::build_model(s);
    FAIL() << "an unstable time step was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("solver.time_step"), std::string::npos) << e.what();
  }
}

// The message of the error building the scene throws (empty when it builds).
std::string build_error(const SceneDef& s) {
  try {
    lattice::build_model(s);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// Objects may touch (automata d apart) but not overlap: two boxes overlapping by 0.1 m exploded with
// 3e7 J, and two boxes at one place reported 2.85e8 J while nothing moved.
TEST(Lattice, OverlappingObjectsAreRefusedTouchingOnesAccepted) {
  SceneDef s = test::block_scene(8, 8, 8, 0.05);
  ObjectDef second = s.objects[0];
  second.name = "second";
  second.position = {0.3, 0, 0};  // 0.1 m into the first
  s.objects.push_back(second);
  std::string msg = build_error(s);
  EXPECT_NE(msg.find("'second' overlaps object 'block': 128 pairs of their automata overlap"), std::string::npos) << msg;
  // (two layers of 8 x 8 at one place: the deepest overlap is a whole automaton's reach)
  EXPECT_NE(msg.find("move them apart (by at least 0.05 m; 0.1001 m along x parts their boxes)"), std::string::npos)
      << msg;
  s.objects[1].position = {0, 0, 0};  // the same place
  EXPECT_NE(build_error(s).find("overlaps"), std::string::npos);
  s.objects[1].position = {0.4, 0, 0};  // face to face: touching
  EXPECT_EQ(build_error(s), "");
  s.objects[1].position = {0.4, 0.4, 0.4};  // corner to corner
  EXPECT_EQ(build_error(s), "");
  s.objects[1].rotation = {0, 0, 45};  // rotated into the first
  s.objects[1].position = {0.35, 0, 0};
  EXPECT_NE(build_error(s).find("overlaps"), std::string::npos);
}

// A body placed on the ground starts touching it, not pressed into it by the rounding of its centres and
// radii to float: the plane goes down by the objects' rounding (1.1e-8 m for the default wall before its
// contact radius was rounded down), and a ball goes up by its own. Pressed in, a cube started with 5.3e-8 J
// in its ground contacts whatever its density, and at density 0.1 that threw it off the ground at 8 mm/s
// within 600 steps. A ball's rounding is its own: a ball of 15.954 m (4.7e-7 m larger in float) lowered the
// plane under a box beside it, which dropped and bounced off at 2.4 mm/s; and the viewer's balls in flight,
// one pressed into the ground by its landing, lowered it by that (5.6e-5 m) with the next shot.
TEST(Lattice, ABodyPlacedOnTheGroundStartsTouchingItNotPressedIn) {
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random})
    for (const double density : {0.1, 2400.0}) {
      const std::string what = fmt::format("{} lattice, density {}", lattice == SolverDef::Lattice::cubic ? "cubic" : "random", density);
      SceneDef s = test::block_scene(4, 4, 4, 0.05, test::test_material(30e9, 0.2, density));
      s.solver.lattice = lattice;
      s.objects[0].position = {0, 0, 0.1};  // the bottom face on the ground
      s.ground.enabled = true;
      s.solver.gravity = {0, 0, -9.81};
      const double lowered = lattice::build_model(s).ground_lowered;
      ProjectileDef ball;
      ball.radius = 0.2;
      ball.position = {1, 0, 0.2};  // resting on the ground (0.2 is 0.200000003 in float)
      ProjectileDef big;
      big.radius = 15.954;  // (15.9540005 in float)
      big.position = {30, 0, 15.954};
      s.projectiles = {ball, big};
      Engine sim(s);
      const Model& m = sim.model();
      EXPECT_EQ(m.ground_lowered, lowered) << what << ": the balls' rounding is not the objects'";
      EXPECT_LE(m.ground_lowered, 1e-6 * 0.05) << what;
      EXPECT_EQ(m.ground_height + m.ground_lowered, 0.0) << what;
      double deepest = -INFINITY;
      for (std::size_t a = 0; a < m.size(); ++a)
        deepest = std::max<double>(deepest, ground_overlap(m.position0[a], m.up, m.ground_height, m.radius[a]));
      EXPECT_LE(deepest, 0.0) << what;
      EXPECT_GT(deepest, -1e-7) << what << ": it touches the ground";
      for (const ProjectileParams& P : m.projectiles) {
        const float overlap = ground_overlap(P.position, m.up, m.ground_height, P.radius);
        EXPECT_LE(overlap, 0.0f) << what << ", " << P.radius;
        EXPECT_GT(overlap, -1e-6f * P.radius) << what << ", " << P.radius << ": it touches the ground";
      }
      EXPECT_EQ(sim.energies().contact, 0.0) << what;
      double rising = 0;
      for (int k = 0; k < 20; ++k) {
        ASSERT_EQ(sim.advance(30).flags, kHealthy) << what;
        double mv = 0, mass = 0;
        for (std::size_t a = 0; a < m.size(); ++a) {
          mv += m.mass[a] * sim.state().v[a].z;
          mass += m.mass[a];
        }
        rising = std::max({rising, mv / mass, sim.state().projectiles[0].velocity.z, sim.state().projectiles[1].velocity.z});
      }
      // Falling onto it from rest, neither moves up faster than gravity would move it in the time.
      EXPECT_LT(rising, 9.81 * sim.state().time) << what;
      // A ball in flight (before `placed`) is where the state has it, pressed into the ground perhaps: it
      // is neither refused nor lifted, and the plane stays.
      s.projectiles[0].position = {1, 0, 0.2 - 1e-4};
      EXPECT_EQ(lattice::build_model(s, 1).ground_height, m.ground_height) << what;
      EXPECT_EQ(lattice::build_model(s, 1).projectiles[0].position.z, 0.2 - 1e-4) << what;
    }
}

// A box standing on another starts touching it, not pressed into it: the centres are laid out with the
// spacing rounded to float (0.05 is 0.0500000007), and contact spheres of half that reached 3e-9 m past a
// 0.2 m box's faces, a preload that threw a light box off the one below at 8 mm/s within 600 steps. On
// every lattice, at a light and at concrete's density.
TEST(Lattice, ABoxStandingOnAnotherStartsTouchingItNotPressedIn) {
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random})
    for (const double jitter : {0.0, 0.3})
      for (const double density : {0.1, 2400.0}) {
        if (lattice == SolverDef::Lattice::random && jitter > 0) continue;
        const std::string what = fmt::format("{} lattice, jitter {}, density {}",
                                             lattice == SolverDef::Lattice::cubic ? "cubic" : "random", jitter, density);
        SceneDef s = test::block_scene(4, 4, 4, 0.05, test::test_material(30e9, 0.2, density));
        s.solver.lattice = lattice;
        s.solver.lattice_jitter = jitter;
        s.objects[0].position = {0, 0, 0.1};
        s.objects.push_back(s.objects[0]);
        s.objects[1].name = "upper";
        s.objects[1].position = {0, 0, 0.3};  // on the first
        s.ground.enabled = true;
        s.solver.gravity = {0, 0, -9.81};
        Engine sim(s);
        const Model& m = sim.model();
        double deepest = -INFINITY;
        for (std::size_t a = 0; a < m.size(); ++a)
          for (std::size_t b = 0; b < m.size(); ++b)
            if (m.object[a] == 0 && m.object[b] == 1) {
              const DVec3 dd = ddelta(m.position0[a], m.position0[b]);
              deepest = std::max(deepest, static_cast<double>(m.radius[a]) + m.radius[b] - std::sqrt(dot(dd, dd)));
            }
        EXPECT_LE(deepest, 0.0) << what;
        EXPECT_EQ(sim.energies().contact, 0.0) << what;
        double rising = 0;
        for (int k = 0; k < 20; ++k) {
          ASSERT_EQ(sim.advance(30).flags, kHealthy) << what;
          double mv = 0, mass = 0;
          for (std::size_t a = 0; a < m.size(); ++a)
            if (m.object[a] == 1) {
              mv += m.mass[a] * sim.state().v[a].z;
              mass += m.mass[a];
            }
          rising = std::max(rising, mv / mass);
        }
        EXPECT_LT(rising, 9.81 * sim.state().time) << what;
        if (lattice == SolverDef::Lattice::cubic && jitter == 0) {
          EXPECT_LE(m.radius[0], 0.025f) << what;  // (a sphere of d / 2 reached past the faces)
          EXPECT_GT(m.radius[0], 0.025f * (1 - 1e-6f)) << what;
        }
      }
}

// A ball placed touching another ball, a box or the ground starts touching it, not pressed into it: its
// radius is rounded down to float (0.136 is 0.136000007: a light ball placed on another on the ground left
// it at 0.07 m/s, a box on a ball at 1.1 mm/s, a ball on a box at 7 mm/s). Nothing moves up faster than
// gravity's settling explains.
TEST(Lattice, ABallPlacedOnABallOrABoxStartsTouchingIt) {
  const double r = 0.136;
  const auto ball = [&](const char* name, double x, double z) {
    return fmt::format("[[projectile]]\nname = \"{}\"\nradius = {}\ndensity = 0.1\nposition = [{}, 0.025, {:.17g}]\n",
                       name, r, x, z);
  };
  const std::string head =
      "[solver]\nspacing = 0.05\nlattice = \"cubic\"\n[output]\nduration = 1\n[ground]\nenabled = true\n"
      "[[material]]\nname = \"light\"\nbase = \"concrete\"\ndensity = 100\n";
  const std::string far = "[[object]]\nname = \"far\"\nsize = [0.2, 0.2, 0.2]\nposition = [5, 5, 0.1]\n";
  const std::pair<const char*, std::string> cases[] = {
      {"a ball on a ball on the ground", far + ball("low", 0, r) + ball("high", 0, 3 * r)},
      {"two balls side by side", far + ball("a", 0, r) + ball("b", 2 * r, r)},
      {"a box on a ball", ball("low", 0.025, r) + fmt::format("[[object]]\nname = \"lid\"\nmaterial = \"light\"\n"
                                                             "size = [0.2, 0.2, 0.2]\nposition = [0, 0, {:.17g}]\n",
                                                             2 * r + 0.1)},
      {"a ball on a box", "[[object]]\nname = \"base\"\nsize = [0.2, 0.2, 0.2]\nposition = [0, 0, 0.1]\n" +
                              ball("high", 0.025, 0.2 + r)},
  };
  for (const auto& [what, body] : cases) {
    Engine sim(io::parse_scene(head + body, "balls.toml"));
    for (const ProjectileParams& P : sim.model().projectiles) EXPECT_LE(static_cast<double>(P.radius), r) << what;
    double rising = 0;
    for (int k = 0; k < 40; ++k) {
      ASSERT_EQ(sim.advance(5).flags, kHealthy) << what;
      for (const ProjectileState& p : sim.state().projectiles) rising = std::max(rising, p.velocity.z);
      for (const DVec3& v : sim.state().v) rising = std::max(rising, v.z);
    }
    EXPECT_LT(rising, 9.81 * sim.state().time) << what;
  }
}

// Nothing starts inside the ground or inside another projectile (a box whose lattice is a row taller than
// its size started 5 mm inside the ground and burst at t = 0, exit code 0).
TEST(Lattice, BodiesInsideTheGroundOrEachOtherAreRefused) {
  SceneDef s = test::block_scene(6, 6, 1, 0.05);
  s.objects[0].size = {0.3, 0.3, 0.24};  // 5 cells, 0.25 m
  s.objects[0].position = {0, 0, 0.12};
  s.ground.enabled = true;
  s.solver.gravity = {0, 0, -9.81};
  std::string msg = build_error(s);
  EXPECT_NE(msg.find("starts 0.005 m inside the ground"), std::string::npos) << msg;
  EXPECT_NE(msg.find("0.25 m"), std::string::npos) << msg;
  s.objects[0].position = {0, 0, 0.125};
  EXPECT_EQ(build_error(s), "");
  ProjectileDef a, b;
  a.position = {1, 0, 0.5};
  b.position = {1.15, 0, 0.5};  // radii 0.1: 0.05 m into each other
  s.projectiles = {a, b};
  msg = build_error(s);
  EXPECT_NE(msg.find("overlaps projectile[0]"), std::string::npos) << msg;
  s.projectiles = {a};
  s.projectiles[0].position = {1, 0, 0.05};
  EXPECT_NE(build_error(s).find("inside the ground"), std::string::npos);
  // A ball inside the block: how far back along its path it clears every automaton it overlaps, and that
  // distance is enough (one refusal, not several).
  s.projectiles[0].position = {0, -0.1, 0.125};  // the block's faces at y = -0.15, its automata 0.025 m in
  s.projectiles[0].velocity = {0, 30, 0};
  msg = build_error(s);
  const auto at = msg.find("m further back along its path clears it");
  ASSERT_NE(at, std::string::npos) << msg;
  const double back = std::stod(msg.substr(msg.rfind('(', at) + 1));
  EXPECT_GT(back, 0.1) << msg;  // its centre 0.05 m inside the faces, its radius 0.1 m
  s.projectiles[0].position = {0, -0.1 - back, 0.125};
  EXPECT_EQ(build_error(s), "");
  // Flying away from the block it is inside: the message says so; at rest: the way straight out, which
  // clears it.
  s.projectiles[0].position = {0, -0.1, 0.125};
  s.projectiles[0].velocity = {0, -30, 0};
  EXPECT_NE(build_error(s).find("its velocity leads out of the object: check its direction"), std::string::npos)
      << build_error(s);
  s.projectiles[0].velocity = {0, 0, 0};
  msg = build_error(s);
  const auto rest = msg.find("it is at rest: a move by ");
  ASSERT_NE(rest, std::string::npos) << msg;
  double w[3] = {0, 0, 0};
  ASSERT_EQ(std::sscanf(msg.c_str() + rest, "it is at rest: a move by [%lf, %lf, %lf]", &w[0], &w[1], &w[2]), 3) << msg;
  s.projectiles[0].position = {w[0], -0.1 + w[1], 0.125 + w[2]};
  EXPECT_EQ(build_error(s), "");
}

// Values a scene can give but the solver cannot honour are refused with the reason: an extent under half a
// cell, positions beyond 1e6 m, gravity beyond 1,000 g; and speeds that cross a tenth of a cell per step.
TEST(Lattice, ExtremeGeometryAndSpeedsAreRefused) {
  SceneDef s = test::block_scene(4, 4, 4, 0.05);
  s.objects[0].size = {0.2, 0.01, 0.2};
  EXPECT_NE(build_error(s).find("less than half the spacing"), std::string::npos);
  s.objects[0].size = {0.2, 0.2, 0.2};
  s.objects[0].position = {2e6, 0, 0};
  EXPECT_NE(build_error(s).find("more than 1e6 m from the origin"), std::string::npos);
  s.objects[0].position = {0, 0, 0};
  s.solver.gravity = {0, 0, -1e5};
  EXPECT_NE(build_error(s).find("stronger than 1e4"), std::string::npos);
  s.solver.gravity = {0, 0, 0};
  s.objects[0].velocity = {1e5, 0, 0};
  try {
    const Engine sim(s);
    ADD_FAILURE() << "an object at 1e5 m/s was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("contacts would be skipped"), std::string::npos) << e.what();
  }
}

// Automata with six intact links are left out of the contact search, safe only while r_i + r_j + skin
// < sqrt(2) d: a larger skin is refused, and the hint names the real default.
TEST(Lattice, ASkinThatTheContactSearchCannotHonourIsRefused) {
  SceneDef s = test::block_scene(3, 3, 3, 0.05);
  s.solver.skin = 0.45;
  const std::string msg = build_error(s);
  EXPECT_NE(msg.find("solver.skin = 0.45"), std::string::npos) << msg;
  EXPECT_NE(msg.find("0.3 (the default)"), std::string::npos) << msg;
  s.solver.skin = 0.4;
  EXPECT_EQ(build_error(s), "");
}

// A stress coefficient outside [1e-3, 1e3] is refused: at 1e-30 the softening law's (c sigma_t)^2
// underflowed in float32 and a material with a fracture energy could not break (the hostile review).
TEST(Lattice, AStressCoefficientOutOfRangeIsRefused) {
  SceneDef s = test::block_scene(3, 3, 3, 0.05);
  for (double c : {1e-30, 9e-4, 1.1e3}) {
    s.solver.stress_coefficient = c;
    const std::string msg = build_error(s);
    EXPECT_NE(msg.find("solver.stress_coefficient"), std::string::npos) << msg;
    EXPECT_NE(msg.find("use 1 (the default)"), std::string::npos) << msg;
  }
  for (double c : {1e-3, 1.0, 1e3}) {
    s.solver.stress_coefficient = c;
    EXPECT_EQ(build_error(s), "") << c;
  }
}

// Values whose float32 form is 0, infinite, or too coarse for the breaking strain are refused with the
// reason, instead of a NaN run or a message about frame_rate.
TEST(Lattice, ValuesOutsideFloat32AreRefusedWithTheReason) {
  auto with = [](auto edit) {
    SceneDef s = test::block_scene(3, 3, 3, 0.05, MaterialDef{});
    s.materials[0].name = "m";
    s.objects[0].material = "m";
    edit(s);
    return build_error(s);
  };
  std::string msg = with([](SceneDef& s) { s.materials[0].youngs_modulus = 1e39; });
  EXPECT_NE(msg.find("youngs_modulus = 1e39"), std::string::npos) << msg;
  EXPECT_NE(msg.find("[1e3, 1e13]"), std::string::npos) << msg;
  msg = with([](SceneDef& s) { s.materials[0].density = 1e-50; });
  EXPECT_NE(msg.find("density = 1e-50"), std::string::npos) << msg;
  EXPECT_NE(msg.find("[0.1, 1e5]"), std::string::npos) << msg;
  msg = with([](SceneDef& s) { s.materials[0].youngs_modulus = 1e13; });  // 3 MPa breaks at 3e-7
  EXPECT_NE(msg.find("breaks at a strain of 3e-07"), std::string::npos) << msg;
  msg = with([](SceneDef& s) {
    ProjectileDef p;
    p.position = {0, -1, 0};
    p.density = 1e-50;
    s.projectiles.push_back(p);
  });
  EXPECT_NE(msg.find("projectile[0].density = 1e-50"), std::string::npos) << msg;
  // A rigid projectile never breaks: a material too stiff to break is fine for it.
  EXPECT_EQ(with([](SceneDef& s) {
              MaterialDef hard = s.materials[0];
              hard.name = "hard";
              hard.youngs_modulus = 1e13;
              s.materials.push_back(hard);
              ProjectileDef p;
              p.position = {0, -1, 0};
              p.material = "hard";
              s.projectiles.push_back(p);
            }),
            "");
  msg = with([](SceneDef& s) {
    ProjectileDef p;
    p.position = {0, -1, 0};
    p.radius = 1e-30;
    s.projectiles.push_back(p);
  });
  EXPECT_NE(msg.find("does not fit the float32"), std::string::npos) << msg;
  // A strengthening law that would stiffen the material 1e4-fold before it breaks.
  msg = with([](SceneDef& s) {
    s.materials[0].strengthening = StrengtheningLaw::exponential;
    s.materials[0].strengthening_alpha = 1e6;
  });
  EXPECT_NE(msg.find("strengthening_alpha = 1e+06"), std::string::npos) << msg;
}

// More objects than a 16-bit index holds (it wrapped to negative ids, then ran out of memory).
TEST(Lattice, FortyThousandObjectsKeepTheirIds) {
  SceneDef s = test::block_scene(1, 1, 1, 0.05);
  s.objects.clear();
  for (int k = 0; k < 40000; ++k) {
    ObjectDef o;
    o.name = fmt::format("o{}", k);
    o.material = "testmat";
    o.size = {0.05, 0.05, 0.05};
    o.position = {(k % 200) * 0.1, (k / 200) * 0.1, 0};
    s.objects.push_back(o);
  }
  const Model m = lattice::build_model(s);
  ASSERT_EQ(m.size(), 40000u);
  for (std::size_t a = 0; a < m.size(); ++a) ASSERT_EQ(m.object[a], static_cast<std::int32_t>(a));
}

// A model larger than the machine is refused at once from the shapes' volume, before counting and
// allocating (mca info swapped for minutes on a 1.8e8-automata sphere).
TEST(Lattice, AModelLargerThanTheMachineIsRefusedAtOnce) {
  SceneDef s = test::block_scene(1, 1, 1, 0.0005);
  s.objects[0].shape = Shape::sphere;
  s.objects[0].radius = 1.0;
  s.solver.max_memory_gb = 1e9;  // the user's limit lifted: the machine's still holds
  const auto start = std::chrono::steady_clock::now();
  const std::string msg = build_error(s);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  EXPECT_NE(msg.find("automata"), std::string::npos) << msg;
  EXPECT_LT(seconds, 1.0);
}

// The run covers the asked duration to within half a step, with a shorter last frame (1e-4 s at 500
// frames per second simulated 2 ms); a frame shorter than a time step given by hand is refused.
TEST(Lattice, TheRunCoversItsDuration) {
  SceneDef s = test::block_scene(3, 3, 3, 0.05);
  s.output.duration = 1e-4;
  s.output.frame_rate = 500;
  {
    const Engine sim(s);
    EXPECT_NEAR(sim.total_steps() * static_cast<double>(sim.model().dt), 1e-4, 0.5 * sim.model().dt);
    EXPECT_EQ(sim.frame_count(), 1);
  }
  s.output.duration = 0.0105;  // 5 frames and a quarter of one
  {
    const Engine sim(s);
    EXPECT_NEAR(sim.total_steps() * static_cast<double>(sim.model().dt), 0.0105, 0.5 * sim.model().dt);
    EXPECT_EQ(sim.frame_count(), 6);
  }
  s.solver.time_step = 1e-6;
  s.output.frame_rate = 1e7;
  s.output.duration = 1e-4;
  try {
    const Engine sim(s);
    FAIL() << "frames shorter than the time step were accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("output.frame_rate = 1e7"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace mca
