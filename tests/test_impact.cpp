// Impact trend (physics.md sec. 8): a wall hit by a ball breaks more, and into more fragments, the faster
// the ball and the more heterogeneous the wall. Averaged over 3 seeds.
#include <gtest/gtest.h>

#include <fmt/format.h>

#include "analysis/fragments.hpp"
#include "io/scene_io.hpp"
#include "support.hpp"

namespace mca {
namespace {

struct Outcome {
  double broken = 0, fragments = 0;
};

Outcome impact(double speed, const std::string& preset, std::uint64_t seed) {
  SceneDef s = io::load_default_scene();
  s.objects[0].size = {0.8, 0.15, 0.6};
  s.objects[0].position = {0, 0, 0.3};
  s.projectiles[0].radius = 0.08;
  s.projectiles[0].position = {0, -0.075 - 0.08 - 0.01, 0.3};
  s.projectiles[0].velocity = {0, speed, 0};
  s.heterogeneity.preset = preset;
  s.heterogeneity.grain_size = 0;  // independent classes per automaton, as in the paper
  heterogeneity_preset(preset, s.heterogeneity.shares);
  s.solver.seed = seed;
  s.output.frame_rate = 1000;
  Engine sim(s);
  sim.advance(static_cast<int>(0.004 / sim.model().dt));  // 4 ms: the ball has gone through the contact
  const State& st = sim.state();
  const auto fr = analysis::label_fragments(sim.model().size(), sim.model().link_i.data(), sim.model().link_j.data(),
                                            st.intact.data(), sim.model().link_count(), sim.model().mass.data());
  return {static_cast<double>(st.broken_by[0] + st.broken_by[1]), static_cast<double>(fr.count)};
}

Outcome mean_over_seeds(double speed, const std::string& preset) {
  Outcome m;
  for (std::uint64_t seed : {1, 2, 3}) {
    const Outcome o = impact(speed, preset, seed);
    m.broken += o.broken / 3;
    m.fragments += o.fragments / 3;
  }
  return m;
}

TEST(Impact, DamageRisesWithSpeedAndHeterogeneity) {
  const Outcome slow = mean_over_seeds(10, "medium");
  const Outcome mid = mean_over_seeds(25, "medium");
  const Outcome fast = mean_over_seeds(50, "medium");
  EXPECT_LT(slow.broken, mid.broken);
  EXPECT_LT(mid.broken, fast.broken);
  EXPECT_LT(slow.fragments, mid.fragments);
  EXPECT_LT(mid.fragments, fast.fragments);
  const Outcome low = mean_over_seeds(25, "low");
  const Outcome high = mean_over_seeds(25, "high");
  EXPECT_LT(low.broken, mid.broken);
  EXPECT_LT(mid.broken, high.broken);
  EXPECT_LT(low.fragments, mid.fragments);
  EXPECT_LT(mid.fragments, high.fragments);
  RecordProperty("broken_slow_mid_fast", fmt::format("{} {} {}", slow.broken, mid.broken, fast.broken));
  RecordProperty("broken_low_medium_high", fmt::format("{} {} {}", low.broken, mid.broken, high.broken));
  std::printf("broken links (mean of 3 seeds): speed 10/25/50 m/s: %.1f %.1f %.1f; low/medium/high at 25 m/s: "
              "%.1f %.1f %.1f\nfragments: %.1f %.1f %.1f; %.1f %.1f %.1f\n",
              slow.broken, mid.broken, fast.broken, low.broken, mid.broken, high.broken, slow.fragments,
              mid.fragments, fast.fragments, low.fragments, mid.fragments, high.fragments);
}

}  // namespace
}  // namespace mca
