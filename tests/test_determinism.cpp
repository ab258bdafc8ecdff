// Determinism (architecture.md examples 4 and 10): the same scene gives bitwise the same state for any
// thread count, and a run restored from a checkpoint steps in lockstep with the original.
#include <gtest/gtest.h>

#include <filesystem>
#include <tbb/global_control.h>

#include "io/checkpoint.hpp"
#include "mca/error.hpp"
#include "io/scene_io.hpp"
#include "support.hpp"

namespace mca {
namespace {

// A small wall struck hard: links break and contacts form during the compared steps.
SceneDef small_impact() {
  SceneDef s = io::load_default_scene();
  s.objects[0].size = {0.8, 0.2, 0.6};
  s.objects[0].position = {0, 0, 0.3};
  s.projectiles[0].radius = 0.1;
  s.projectiles[0].position = {0, -0.25, 0.3};
  s.projectiles[0].velocity = {0, 80, 0};
  s.output.frame_rate = 1000;
  return s;
}

std::uint64_t run_with_threads(int threads, int steps) {
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  Engine sim(small_impact());
  sim.advance(steps);
  EXPECT_GT(sim.state().broken_by[0] + sim.state().broken_by[1], 0) << "the ball should break links";
  return state_hash(sim.state());
}

TEST(Determinism, SameStateForAnyThreadCount) {
  const int steps = 3000;
  const std::uint64_t one = run_with_threads(1, steps);
  EXPECT_EQ(one, run_with_threads(2, steps));
  EXPECT_EQ(one, run_with_threads(3, steps));
  EXPECT_EQ(one, run_with_threads(8, steps));
}

TEST(Determinism, SameStateHoweverTheStepsAreGroupedIntoCalls) {
  Engine a(small_impact()), b(small_impact());
  a.advance(1200);
  for (int k = 0; k < 12; ++k) b.advance(100);
  EXPECT_GT(a.state().broken_by[0] + a.state().broken_by[1], 0);
  EXPECT_EQ(state_hash(a.state()), state_hash(b.state()));
}

TEST(Determinism, CheckpointRestoresALockstepTwin) {
  Engine a(small_impact());
  a.advance(2000);
  const auto path = std::filesystem::temp_directory_path() / "mca_test_lockstep.mcack";
  io::Checkpoint cp;
  cp.scene = a.scene();
  cp.state = a.state();
  cp.frame = 3;
  cp.total_steps = 5000;
  io::write_checkpoint(path, cp);
  const io::Checkpoint back = io::read_checkpoint(path);
  std::filesystem::remove(path);
  EXPECT_EQ(back.frame, 3);
  EXPECT_EQ(back.total_steps, 5000);
  Engine b(back.scene, back.state);
  ASSERT_EQ(state_hash(a.state()), state_hash(b.state()));
  for (int k = 0; k < 300; ++k) {
    a.advance(5);
    b.advance(5);
    ASSERT_EQ(state_hash(a.state()), state_hash(b.state())) << "diverged after " << 5 * (k + 1) << " steps";
  }
  EXPECT_GT(a.state().broken_by[0] + a.state().broken_by[1], 0);
  EXPECT_EQ(a.state().breaks.size(), b.state().breaks.size());
}

TEST(Determinism, DamagedCheckpointIsRefusedWithAClearError) {
  const auto path = std::filesystem::temp_directory_path() / "mca_test_cut.mcack";
  Engine a(small_impact());
  io::Checkpoint cp;
  cp.scene = a.scene();
  cp.state = a.state();
  io::write_checkpoint(path, cp);
  std::filesystem::resize_file(path, std::filesystem::file_size(path) / 2);
  try {
    io::read_checkpoint(path);
    FAIL() << "a truncated checkpoint was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(path.string()), std::string::npos) << e.what();
  }
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace mca
