// The public C++ API (include/mca/simulation.hpp) used as a library user would: no internal headers.
#include <gtest/gtest.h>

#include <algorithm>

#include "mca/error.hpp"
#include "mca/scene.hpp"
#include "mca/simulation.hpp"

namespace {

mca::SceneDef wall() {
  mca::SceneDef s;
  s.name = "api";
  s.solver.spacing = 0.05;
  s.solver.lattice = mca::SolverDef::Lattice::cubic;
  s.heterogeneity.preset = "medium";
  mca::heterogeneity_preset("medium", s.heterogeneity.shares);
  s.ground.enabled = true;
  mca::ObjectDef o;
  o.size = {0.6, 0.15, 0.5};
  o.position = {0, 0, 0.25};
  s.objects.push_back(o);
  mca::ProjectileDef p;
  p.radius = 0.08;
  p.position = {0, -0.17, 0.25};
  p.velocity = {0, 60, 0};
  s.projectiles.push_back(p);
  s.output.frame_rate = 1000;
  return s;
}

TEST(PublicApi, BuildStepAndReadFrames) {
  mca::Simulation sim(wall());
  EXPECT_EQ(sim.automata(), 360u);
  EXPECT_GT(sim.links(), 0u);
  EXPECT_GT(sim.time_step(), 0.0);
  const mca::Frame first = sim.frame();
  EXPECT_EQ(first.fragments, 1);
  EXPECT_EQ(first.position.size(), 360u);
  for (int k = 0; k < 4; ++k) ASSERT_EQ(sim.advance(sim.steps_per_frame()), mca::StepStatus::ok);
  const mca::Frame f = sim.frame();
  EXPECT_NEAR(f.time, 0.004, 1e-6);
  EXPECT_GT(f.broken_links, 0);
  EXPECT_GT(f.fragments, 1);
  EXPECT_EQ(f.fragment.size(), 360u);
  EXPECT_EQ(f.projectile_position.size(), 1u);
  float most = 0;
  for (float d : f.damage) most = std::max(most, d);
  EXPECT_GT(most, 0.0f);
}

TEST(PublicApi, BadSceneThrowsError) {
  mca::SceneDef s = wall();
  s.solver.spacing = -1;
  EXPECT_THROW(mca::Simulation{s}, mca::Error);
}

}  // namespace
