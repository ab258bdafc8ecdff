// Velocities keep small forces (issue: float32 velocities rounded g dt away at speed). A free body under
// gravity gains g t in every mode and at every speed, however small g dt is against its velocity.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "lattice/lattice.hpp"
#include "mesh_fixtures.hpp"
#include "sim/engine.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

constexpr double kG = 9.81;

// The mass-weighted mean z velocity of the automata.
double mean_vz(const Model& m, const State& s) {
  double p = 0, mass = 0;
  for (std::size_t a = 0; a < m.size(); ++a) {
    p += static_cast<double>(m.mass[a]) * s.v[a].z;
    mass += m.mass[a];
  }
  return p / mass;
}

// Advances the engine by the whole steps of 4 ms.
void run_4ms(Engine& sim) {
  const auto steps = static_cast<std::int64_t>(std::llround(4e-3 / sim.model().dt));
  while (sim.state().step < steps) sim.advance(static_cast<int>(std::min<std::int64_t>(steps - sim.state().step, 1000)));
}

// Runs 4 ms of the scene's steps and returns the gain of the mean z velocity against g t (1 is exact).
double gain_over_gt_in_4ms(const SceneDef& s) {
  Engine sim(s);
  const double v0 = mean_vz(sim.model(), sim.state());
  run_4ms(sim);
  return (v0 - mean_vz(sim.model(), sim.state())) / (kG * sim.state().time);
}

// A 0.1 m box (spacing 0.01 m, 1,000 automata), no ground, falling at `speed` for 4 ms.
TEST(VelocityPrecision, AFallingBoxGainsGTAtEverySpeed) {
  for (double speed : {0.0, 10.0, 30.0, 60.0, 100.0, 300.0}) {
    SceneDef s = test::block_scene(10, 10, 10, 0.01);
    s.solver.gravity = {0, 0, -kG};
    s.objects[0].velocity = {0, 0, -speed};
    EXPECT_NEAR(gain_over_gt_in_4ms(s), 1.0, 1e-3) << "at " << speed << " m/s";
  }
}

// The same for a surface-mode shell (one automaton per triangle, explicit links and bending springs).
TEST(VelocityPrecision, AFallingShellGainsGTAtEverySpeed) {
  test::TempDir t;
  test::write_mesh_file(t.path() / "sphere.off", test::sphere_mesh(0.2, 2));
  for (double speed : {0.0, 40.0, 70.0, 150.0}) {
    SceneDef s = test::block_scene(1, 1, 1, 0.05);
    s.objects[0].shape = Shape::mesh;
    s.objects[0].mesh = (t.path() / "sphere.off").string();
    s.objects[0].fill = MeshFill::surface;
    s.objects[0].shell_thickness = 0.01;
    s.solver.gravity = {0, 0, -kG};
    s.objects[0].velocity = {0, 0, -speed};
    EXPECT_NEAR(gain_over_gt_in_4ms(s), 1.0, 1e-3) << "at " << speed << " m/s";
  }
}

// A dynamic projectile far from everything gains g t too, and its spin, with no torque on it, stays put.
TEST(VelocityPrecision, AFallingBallGainsGT) {
  for (double speed : {0.0, 100.0, 500.0}) {
    SceneDef s = test::block_scene(4, 4, 4, 0.01);
    s.solver.gravity = {0, 0, -kG};
    s.objects[0].velocity = {0, 0, -speed};  // the block falls beside it, so nothing touches
    ProjectileDef p;
    p.radius = 0.02;
    p.material = "testmat";
    p.position = {5, 0, 0};
    p.velocity = {0, 0, -speed};
    p.angular_velocity = {0, 0, 1000};
    s.projectiles.push_back(p);
    Engine sim(s);
    run_4ms(sim);
    const ProjectileState& ps = sim.state().projectiles[0];
    EXPECT_NEAR((-speed - ps.velocity.z) / (kG * sim.state().time), 1.0, 1e-3) << "at " << speed << " m/s";
    EXPECT_EQ(ps.angular_velocity.z, 1000.0);
  }
}

// The speed limit (a tenth of the spacing per step) holds for a projectile's spin (its surface speed) and
// a grip's velocity too, as for the initial velocities: a spin of 1e20 rad/s ran to the end with a
// projectile energy of 2e37 J, a grip at 3,000 m/s ran without a word.
TEST(VelocityPrecision, SpinsAndGripsAreHeldToTheSpeedLimit) {
  SceneDef s = test::block_scene(4, 4, 4, 0.01);
  ProjectileDef p;
  p.radius = 0.05;
  p.material = "testmat";
  p.position = {1, 0, 0};
  p.angular_velocity = {1e6, 0, 0};
  s.projectiles.push_back(p);
  std::string e = test::error_of([&] { Engine sim(s); });
  EXPECT_NE(e.find("angular_velocity x radius"), std::string::npos) << e;
  s.projectiles[0].angular_velocity = {1e300, 1e300, 0};
  e = test::error_of([&] { Engine sim(s); });
  EXPECT_NE(e.find("angular_velocity x radius"), std::string::npos) << e;
  s.projectiles.clear();
  GripDef g;
  g.name = "pull";
  g.min = {-1, -1, -1};
  g.max = {1, 1, 0};
  g.velocity = {3000, 0, 0};
  s.grips.push_back(g);
  e = test::error_of([&] { Engine sim(s); });
  EXPECT_NE(e.find("grip 'pull'"), std::string::npos) << e;
  s.grips[0].velocity = {1, 0, 0};
  EXPECT_EQ(test::error_of([&] { Engine sim(s); }), "");
}

}  // namespace
}  // namespace mca
