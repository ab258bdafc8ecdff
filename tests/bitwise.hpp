#pragma once
// The promise of bitwise determinism, checked on one scene: every instruction set the processor runs, 1
// and 2 threads, the lattice's sweep chunk by chunk and one kernel at a time, and a run resumed from a
// checkpoint file halfway give the same state.
#include <gtest/gtest.h>

#include <functional>
#include <tbb/global_control.h>

#include "backend/cpu/lattice_kernels.hpp"
#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "sim/state_check.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca::test {

// The cubic wall (scenes/wall_ball_cubic.toml) for 0.01 s with the ball 5 mm from the wall (it strikes
// within the first steps); the tests of the other lattices set theirs.
inline SceneDef struck_default_wall() {
  SceneDef s = test::cubic_wall_scene();
  s.output.duration = 0.01;
  EXPECT_EQ(s.projectiles.size(), 1u);
  s.projectiles[0].position[1] = -0.1 - s.projectiles[0].radius - 0.005;
  return s;
}

struct Bitwise {
  std::uint64_t hash = 0;  // state_hash after `steps` steps
  std::int64_t broken = 0;  // broken links then
};

// `at_checkpoint` sees the state written to the checkpoint (steps / 2), before it is resumed.
inline Bitwise expect_bitwise_everywhere(const SceneDef& s, int steps,
                                         const std::function<void(const State&)>& at_checkpoint = {}) {
  Bitwise r;
  const cpu::Kernels* sets[4];
  const int count = cpu::available_kernels(sets);
  EXPECT_GE(count, 2);
  for (int k = 0; k < count; ++k)
    for (int threads : {1, 2})
      for (const char* sweep : {"fused", "passes"}) {
        ForceEnv simd("MCA_SIMD", sets[k]->name), how("MCA_SWEEP", sweep);
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
        Engine sim(s);
        EXPECT_EQ(sim.advance(steps).flags, kHealthy);
        const std::uint64_t h = state_hash(sim.state());
        if (r.hash == 0) {
          r.hash = h;
          r.broken = sim.state().broken_by[0] + sim.state().broken_by[1];
          std::printf("%s after %d steps: state_hash %016llx, %lld broken links\n", s.name.c_str(), steps,
                      static_cast<unsigned long long>(h), static_cast<long long>(r.broken));
        }
        EXPECT_EQ(h, r.hash) << sets[k]->name << " on " << threads << " threads, " << sweep;
      }
  TempDir t;
  Engine a(s);
  EXPECT_EQ(a.advance(steps / 2).flags, kHealthy);
  if (at_checkpoint) at_checkpoint(a.state());
  io::Checkpoint cp;
  cp.scene = a.scene();
  cp.state = a.state();
  io::write_checkpoint(t.path() / "cp.mcack", cp);
  const io::Checkpoint back = io::read_checkpoint(t.path() / "cp.mcack");
  Engine b(back.scene, back.state, "<test>", model_fingerprint(a.model()));
  EXPECT_EQ(b.advance(steps - steps / 2).flags, kHealthy);
  EXPECT_EQ(state_hash(b.state()), r.hash) << "resumed from a checkpoint at step " << steps / 2;
  return r;
}

}  // namespace mca::test
