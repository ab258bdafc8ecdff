// The lattice builder: shapes, placement, regions, target counts, and the scene checks it makes.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "support.hpp"

namespace mca {
namespace {

TEST(Lattice, BoxHasFaceLinksOnly) {
  const Model m = lattice::build_model(test::block_scene(4, 3, 2));
  EXPECT_EQ(m.size(), 24u);
  EXPECT_EQ(m.link_count(), 3u * 3 * 2 + 4u * 2 * 2 + 4u * 3 * 1);  // x, y and z links
  for (std::size_t l = 0; l < m.link_count(); ++l) {
    EXPECT_LT(m.link_i[l], m.link_j[l]);
    EXPECT_NEAR(length(delta(m.position0[m.link_i[l]], m.position0[m.link_j[l]])), m.link_r0[l], 1e-6);
  }
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

}  // namespace
}  // namespace mca
