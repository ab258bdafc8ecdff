// Checkpoints as untrusted input: a damaged or edited file is refused with mca::Error (never a crash or
// a run on a state that does not fit the model), and identical runs write identical files.
#include <gtest/gtest.h>

#include <chrono>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <fstream>
#include <random>
#include <sstream>
#include <string>

#include "core/environment.hpp"
#include "core/fnv.hpp"
#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "sim/engine.hpp"
#include "sim/state_check.hpp"
#include "support.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;

// A small wall on the ground, held at its top by a grip and struck hard: after the fixture's steps the
// state has broken links, break records, contacts, projectile and ground contacts and grip forces.
SceneDef struck_wall() {
  SceneDef s = test::cubic_wall_scene();
  s.name = "struck";
  s.source = "<checkpoint test>";
  s.objects[0].size = {0.4, 0.2, 0.3};
  s.objects[0].position = {0, 0, 0.15};  // on the ground
  s.objects[0].velocity = {0.5, 0, 0};      // and sliding on it
  s.projectiles[0].radius = 0.08;
  s.projectiles[0].position = {0, -0.2, 0.15};
  s.projectiles[0].velocity = {0, 80, 0};
  GripDef g;
  g.name = "top";
  g.min = {-1, -1, 0.26};
  g.max = {1, 1, 0.31};
  s.grips.push_back(g);
  s.output.frame_rate = 1000;
  return s;
}


std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

fs::path temp_file(const std::string& name) {
  return fs::temp_directory_path() / ("mca_test_ck_" + std::to_string(::getpid()) + "_" + name);
}

io::Checkpoint checkpoint_of(const Engine& sim) {
  io::Checkpoint cp;
  cp.scene = sim.scene();
  cp.state = sim.state();
  cp.frame = 2;
  cp.total_steps = 4 * sim.steps_per_frame();
  cp.wall_seconds = 1.5;
  return cp;
}

struct Fixture {
  SceneDef scene = struck_wall();
  State state;
  std::string bytes;  // the checkpoint file of `state`
  Fixture() {
    Engine sim(scene);
    // Until the ball touches the wall, in steps of 10 (about 200 steps today).
    for (int k = 0; k < 500 && sim.state().projectiles[0].contacts.empty(); ++k) sim.advance(10);
    state = sim.state();
    const fs::path p = temp_file("fixture.mcack");
    io::write_checkpoint(p, checkpoint_of(sim));
    bytes = slurp(p);
    fs::remove(p);
  }
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

TEST(Checkpoint, FixtureExercisesEveryPartOfTheState) {
  const State& s = fixture().state;
  EXPECT_GT(s.broken_by[0] + s.broken_by[1], 0);
  EXPECT_FALSE(s.breaks.empty());
  EXPECT_FALSE(s.contacts.empty());
  ASSERT_EQ(s.projectiles.size(), 1u);
  EXPECT_FALSE(s.projectiles[0].contacts.empty());
  EXPECT_EQ(s.grip_force.size(), 1u);
  bool ground = false;
  for (const BodyContact& c : s.ground_contacts) ground = ground || c.h.ut.x != 0 || c.h.ut.y != 0 || c.h.ut.z != 0;
  EXPECT_TRUE(ground) << "no automaton touches the ground";
}

TEST(Checkpoint, IdenticalRunsWriteIdenticalFiles) {
  Engine a(struck_wall()), b(struck_wall());
  a.advance(static_cast<int>(fixture().state.step));
  b.advance(static_cast<int>(fixture().state.step));
  const fs::path pa = temp_file("a.mcack"), pb = temp_file("b.mcack");
  io::write_checkpoint(pa, checkpoint_of(a));
  io::write_checkpoint(pb, checkpoint_of(b));
  EXPECT_EQ(slurp(pa), slurp(pb));
  fs::remove(pa);
  fs::remove(pb);
}

// Padding bytes inside saved structs (BreakRecord has 3) are whatever the memory held; they must not
// reach the file, or equal states give different checkpoints.
TEST(Checkpoint, PaddingBytesDoNotReachTheFile) {
  const Fixture& f = fixture();
  ASSERT_FALSE(f.state.breaks.empty());
  io::Checkpoint cp;
  cp.scene = f.scene;
  cp.frame = 2;
  cp.total_steps = 4 * Engine(f.scene).steps_per_frame();
  cp.wall_seconds = 1.5;
  cp.state = f.state;
  for (BreakRecord& r : cp.state.breaks) {
    const BreakRecord keep = r;
    std::memset(static_cast<void*>(&r), 0xA5, sizeof r);
    r.step = keep.step;
    r.link = keep.link;
    r.criterion = keep.criterion;
  }
  const fs::path p = temp_file("padding.mcack");
  io::write_checkpoint(p, cp);
  const std::string garbage = slurp(p);
  fs::remove(p);
  EXPECT_TRUE(garbage == f.bytes) << "the checkpoint depends on padding bytes";
}

// The checksum of a checkpoint's bytes, recomputed after they were changed: a forged file that passes the
// checksum, which the state checks still have to stop.
std::string resigned(std::string bytes) {
  constexpr std::size_t tail = 16;  // checksum and end marker
  if (bytes.size() < tail + 8) return bytes;
  Fnv1a sum;
  sum.bytes(bytes.data(), bytes.size() - tail);
  std::memcpy(bytes.data() + bytes.size() - tail, &sum.h, sizeof sum.h);
  std::memcpy(bytes.data() + bytes.size() - 8, bytes.data(), 8);  // the end marker repeats the header's magic
  return bytes;
}

// A few hundred damaged copies of a valid checkpoint. As they are, every one is refused (a flipped byte
// anywhere fails the checksum; before it, most were resumed from). Re-signed, so that only the checks of
// the structure and the state stand between them and a run, each is refused with mca::Error or gives a
// state a backend can step. Run under the asan preset too (ctest --preset asan -R Checkpoint).
TEST(Checkpoint, DamagedFilesAreRefusedOrSafe) {
  const Fixture& f = fixture();
  const std::string& good = f.bytes;
  std::mt19937_64 rng(20240611);
  const fs::path p = temp_file("damaged.mcack");
  const Engine original(f.scene);
  int refused = 0, accepted = 0;
  for (int variant = 0; variant < 400; ++variant) {
    std::string bad = good;
    const int kind = variant % 5;
    auto at = [&](std::size_t limit) { return static_cast<std::size_t>(rng() % limit); };
    if (kind == 0) {
      bad.resize(at(bad.size()));  // cut short
    } else if (kind == 1) {
      for (int k = 0; k < 1 + variant % 4; ++k) bad[at(bad.size())] ^= static_cast<char>(1u << (rng() % 8));
    } else if (kind == 2) {
      // The header, the embedded scene and the first counts: the structure rather than the numbers.
      bad[at(std::min<std::size_t>(bad.size(), 6000))] = static_cast<char>(rng());
    } else if (kind == 3) {
      // An 8-byte field overwritten with a huge, a small or a negative number.
      const std::uint64_t values[] = {~0ull, 1ull << 62, 3, 0, 1ull << 33, static_cast<std::uint64_t>(-1000)};
      const std::uint64_t v = values[rng() % 6];
      std::memcpy(bad.data() + at(bad.size() - 8), &v, 8);
    } else {
      bad.erase(at(bad.size()), 1 + at(64));  // bytes missing in the middle
    }
    if (bad != good) {
      { std::ofstream(p, std::ios::binary) << bad; }
      EXPECT_THROW(io::read_checkpoint(p), Error) << "variant " << variant << " was not refused";
      // A file cut short says so (it was reported as a bad checksum).
      if (kind == 0 && bad.size() >= 24) {
        const std::string m = test::error_of([&] { io::read_checkpoint(p); });
        EXPECT_NE(m.find("bytes do not end with the end marker: cut short"), std::string::npos) << m;
      }
    }
    { std::ofstream(p, std::ios::binary) << resigned(bad); }
    try {
      const io::Checkpoint cp = io::read_checkpoint(p);
      // The embedded scene may have been changed too; a resume would find that out by the model's
      // fingerprint. Here the state goes into the original scene's model, as the worst case.
      check_state(original.model(), cp.state, "damaged");
      Engine sim(f.scene, cp.state);
      sim.advance(3);
      ++accepted;
    } catch (const Error& e) {
      ++refused;
    }
  }
  fs::remove(p);
  // Both outcomes are exercised: re-signed flipped bits in the numbers mostly load, damaged structure does not.
  EXPECT_GT(refused, 100);
  EXPECT_GT(accepted, 20);
  std::printf("damaged and re-signed checkpoints: %d refused, %d accepted\n", refused, accepted);
}

// A file of a checkpoint's name that is far larger than any checkpoint (20 GB behind a checkpoint's header:
// sparse here, so it takes no disk) is refused from its end and its size, without being read: it took 27 s
// and the machine's memory to be refused.
TEST(Checkpoint, AHugeFileIsRefusedWithoutBeingRead) {
  const Fixture& f = fixture();
  const fs::path p = temp_file("huge.mcack");
  const auto sparse = [&](std::uint64_t size, bool end_marker) {
    { std::ofstream(p, std::ios::binary) << f.bytes.substr(0, 16); }
    fs::resize_file(p, size);
    if (end_marker) {
      std::fstream out(p, std::ios::binary | std::ios::in | std::ios::out);
      out.seekp(static_cast<std::streamoff>(size - 8));
      out.write(f.bytes.data() + f.bytes.size() - 8, 8);
    }
  };
  const auto refused_at_once = [&] {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string m = test::error_of([&] { io::read_checkpoint(p); });
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 1.0);
    return m;
  };
  sparse(20'000'000'000ull, false);
  EXPECT_NE(refused_at_once().find("its 20000000000 bytes do not end with the end marker"), std::string::npos);
  if (machine_memory_bytes() < 1e12) {
    sparse(1'000'000'000'000ull, true);  // its end is a checkpoint's: only its size tells
    const std::string m = refused_at_once();
    EXPECT_NE(m.find("holds 1000.0 GB, more than this machine's memory can read back"), std::string::npos) << m;
  }
  fs::remove(p);
}

// Each invariant of a state, broken on its own, is refused with a message naming the source and the
// way out; the valid state passes.
TEST(Checkpoint, StateCheckRefusesEachBrokenInvariant) {
  const Fixture& f = fixture();
  const Engine sim(f.scene);
  const Model& m = sim.model();
  const std::string source = "checkpoint 'x/frame_000007.mcack'";
  EXPECT_NO_THROW(check_state(m, f.state, source));
  State no_list = f.state;
  no_list.x_at_rebuild.clear();  // "rebuild the contact list": allowed
  EXPECT_NO_THROW(check_state(m, no_list, source));

  const std::uint32_t n = static_cast<std::uint32_t>(m.size());
  const auto first_broken = [&](const State& s) {
    for (std::size_t l = 0; l < s.intact.size(); ++l)
      if (!s.intact[l]) return l;
    return s.intact.size();
  };
  const auto first_intact = [&](const State& s) {
    for (std::size_t l = 0; l < s.intact.size(); ++l)
      if (s.intact[l]) return l;
    return s.intact.size();
  };
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<std::pair<std::string, std::function<void(State&)>>> breaks = {
      {"x", [](State& s) { s.x.pop_back(); }},
      {"v", [](State& s) { s.v.push_back({}); }},
      {"w", [](State& s) { s.w.clear(); }},
      {"q", [](State& s) { s.q.pop_back(); }},
      {"s has", [](State& s) { s.s.pop_back(); }},
      {"mean_stress", [](State& s) { s.mean_stress.pop_back(); }},
      {"f has", [](State& s) { s.f.pop_back(); }},
      {"t has", [](State& s) { s.t.pop_back(); }},
      {"ground contacts are not sorted", [](State& s) { s.ground_contacts.push_back(s.ground_contacts.front()); }},
      {"ground contact 0 names automaton", [&](State& s) { s.ground_contacts[0].automaton = n; }},
      {"x_at_rebuild", [](State& s) { s.x_at_rebuild.pop_back(); }},
      {"intact has", [](State& s) { s.intact.pop_back(); }},
      {"link_ut has", [](State& s) { s.link_ut.push_back({}); }},
      {"grip_work", [](State& s) { s.grip_work.clear(); }},
      {"grip_force", [](State& s) { s.grip_force.push_back({}); }},
      {"projectiles are saved", [](State& s) { s.projectiles.push_back(s.projectiles[0]); }},
      {"step counter", [](State& s) { s.step = -1; }},
      {"time", [](State& s) { s.time = std::numeric_limits<double>::infinity(); }},
      // Orientations the integration cannot make (a re-signed zero quaternion was resumed from).
      {"q[0] has length 0, and an orientation's is above 0 and at most 1", [](State& s) { s.q[0] = {0, 0, 0, 0}; }},
      {"q[4] has length 1e+30", [](State& s) { s.q[4] = {1e30f, 0, 0, 0}; }},
      {"q[2] has length 1.01", [](State& s) { s.q[2] = {1.01f, 0, 0, 0}; }},
      {"projectile 0's orientation has length 2", [](State& s) { s.projectiles[0].orientation = {2, 0, 0, 0}; }},
      {"x[3]", [](State& s) { s.x[3].y = std::numeric_limits<double>::quiet_NaN(); }},
      {"v[0]", [&](State& s) { s.v[0].z = nan; }},
      {"q[5]", [&](State& s) { s.q[5].w = std::numeric_limits<float>::infinity(); }},
      {"s[2]", [&](State& s) { s.s[2].zx = nan; }},
      {"link_ut[1]", [&](State& s) { s.link_ut[1].y = nan; }},
      {"starting energy", [](State& s) { s.initial_energy = std::numeric_limits<double>::infinity(); }},
      {"grip_work[0]", [](State& s) { s.grip_work[0] = std::numeric_limits<double>::quiet_NaN(); }},
      {"projectile 0 has a non-finite", [&](State& s) { s.projectiles[0].velocity.x = nan; }},
      {"intact[", [](State& s) { s.intact[0] = 2; }},
      {"links are broken but", [&](State& s) { s.intact[first_intact(s)] = 0; }},
      {"which is intact", [&](State& s) { s.intact[s.breaks[0].link] = 1; }},
      {"names link", [&](State& s) { s.breaks[0].link = static_cast<std::uint32_t>(m.link_slots()); }},
      {"criterion 7", [](State& s) { s.breaks[0].criterion = static_cast<BreakCriterion>(7); }},
      {"break record 0 is at step", [](State& s) { s.breaks[0].step = s.step + 1; }},
      {"two break records", [](State& s) { s.breaks.push_back(s.breaks[0]); }},
      {"break records say so", [](State& s) { ++s.broken_by[0]; }},
      {"break records say so", [](State& s) { s.broken_by[1] = -1; }},
      {"contact 0 is the pair", [&](State& s) { s.contacts[0].j = n; }},
      {"contact 0 is the pair", [](State& s) { s.contacts[0].j = s.contacts[0].i; }},
      {"not in order", [](State& s) { std::swap(s.contacts.front(), s.contacts.back()); }},
      {"not in order", [](State& s) { s.contacts.push_back(s.contacts.back()); }},
      {"contact 0 has a non-finite spring history", [&](State& s) { s.contacts[0].h.ut.x = nan; }},
      {"contact 0 has a non-finite spring history", [&](State& s) { s.contacts[0].h.mr.z = nan; }},
      // A way of touching (ContactPair::face) past the 36 pairs of sides: sides no cell has.
      {"touches in way 200, which their cells' free sides do not have", [](State& s) { s.contacts[0].face = 200; }},
      {"names automaton", [&](State& s) { s.projectiles[0].contacts.back().automaton = n; }},
      {"not sorted by automaton", [](State& s) {
         s.projectiles[0].contacts.push_back(s.projectiles[0].contacts.front());
       }},
  };
  ASSERT_LT(first_broken(f.state), f.state.intact.size());
  ASSERT_GE(f.state.contacts.size(), 2u);
  // Ground contacts where the scene has no ground (the same lattice without it): they would act as a ground
  // at height 0 for the rest of the run (found by a hostile review).
  ASSERT_FALSE(f.state.ground_contacts.empty());
  SceneDef no_ground = f.scene;
  no_ground.ground.enabled = false;
  const Engine bare(no_ground);
  ASSERT_EQ(bare.model().link_slots(), m.link_slots());
  EXPECT_NE(test::error_of([&] { check_state(bare.model(), f.state, source); })
                .find("the state has ground contacts (" + std::to_string(f.state.ground_contacts.size()) +
                      "), and the scene has no ground"),
            std::string::npos);
  State no_lists = f.state;
  no_lists.ground_contacts.clear();
  for (auto& p : no_lists.projectiles) p.ground = {};
  EXPECT_NO_THROW(check_state(bare.model(), no_lists, source));
  no_lists.projectiles[0].ground.ut.x = 0.5f;  // (moves nothing without a ground: only the state's bits)
  EXPECT_NE(test::error_of([&] { check_state(bare.model(), no_lists, source); })
                .find("projectile 0 has a ground contact's history, and the scene has no ground"),
            std::string::npos);
  for (const auto& [expected, edit] : breaks) {
    SCOPED_TRACE(expected);
    State s = f.state;
    edit(s);
    try {
      check_state(m, s, source);
      ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(source, 0), 0u) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << what;
      EXPECT_NE(what.find("start the run again"), std::string::npos) << what;
    }
  }
}

// A checkpoint's clock and the energy the blow-up check measures against are its run's: its steps make its
// time, and its scene gives the first state's energy again. Edited ones (a time of 5 s; a budget of 1e300
// turned the check off, -1e300 stopped the run as unstable) are refused. A state that is no checkpoint (mca
// view's shots, whose model's step changes under it) keeps its own time.
TEST(Checkpoint, AnEditedClockOrStartingEnergyIsRefused) {
  const Fixture& f = fixture();
  const Engine original(f.scene);
  const Model& m = original.model();
  const std::uint64_t fingerprint = model_fingerprint(m);
  const std::string source = "checkpoint 'x/frame_000002.mcack'";
  ASSERT_NE(f.state.initial_energy, 0.0);
  EXPECT_EQ(f.state.initial_energy, original.state().initial_energy);
  EXPECT_NO_THROW(Engine(f.scene, f.state, source, fingerprint));
  const auto refusal = [&](const std::function<void(State&)>& edit) {
    State s = f.state;
    edit(s);
    const std::string e = test::error_of([&] { Engine(f.scene, s, source, fingerprint); });
    EXPECT_EQ(e.rfind(source + ": the saved state does not fit the model of its scene: ", 0), 0u) << e;
    return e;
  };
  for (const double edited : {1e300, -1e300, 0.0, f.state.initial_energy * 1.001}) {
    SCOPED_TRACE(edited);
    const std::string e = refusal([&](State& s) { s.initial_energy = edited; });
    EXPECT_NE(e.find(fmt::format("its run's starting energy is saved as {} J, and the scene's first state holds {} J",
                                 edited, f.state.initial_energy)),
              std::string::npos)
        << e;
  }
  EXPECT_NE(refusal([](State& s) { s.time = 5.0; }).find("the time is 5 s at step"), std::string::npos);
  EXPECT_NE(refusal([&](State& s) { s.time = static_cast<double>(s.step + 1) * m.dt; }).find("where steps of"),
            std::string::npos);
  State shot = f.state;
  shot.time *= 1.5;
  EXPECT_NO_THROW(check_state(m, shot, source));
  EXPECT_NO_THROW(Engine(f.scene, shot, "the viewer's shot", std::nullopt));
}

// A small ball spinning about as fast as one part of its turn (0.49 rad a step) settles at an orientation's
// length of 0.9987, short of 1 (the integration's renormalisation): its run's checkpoints resume (a check of unit
// length within 1e-3 refused them all).
TEST(Checkpoint, AFastSpinningBallsCheckpointResumes) {
  SceneDef s = struck_wall();
  const double r = 0.0104;  // (0.208 of the spacing: a smaller ball would pass between the automata)
  s.projectiles[0].radius = r;
  s.projectiles[0].position = {0, -0.4, 0.15};
  s.projectiles[0].velocity = {0, 1, 0};
  Engine probe(s);
  const double dt = probe.model().dt;  // (0.5 rad a step is one part, and its surface at a tenth of the spacing)
  const double spin = std::min(0.49 / dt, 0.0999 * probe.model().spacing / dt / r);
  s.projectiles[0].angular_velocity = {0, 0, spin};
  Engine sim(s);
  sim.advance(200);
  const Quat q = sim.state().projectiles[0].orientation;
  const double length = std::sqrt(double(q.w) * q.w + double(q.x) * q.x + double(q.y) * q.y + double(q.z) * q.z);
  std::printf("a ball of %.4g m at %.3g rad/s, %.2f rad a step: orientation's length %.6f\n", r, spin,
              spin * sim.model().dt, length);
  EXPECT_LT(length, 0.9995) << "the spin no longer moves the length off 1: the test measures nothing";
  EXPECT_NO_THROW(Engine(s, sim.state(), "checkpoint 'spin'", model_fingerprint(sim.model())));
}

TEST(Checkpoint, ModelFingerprintTellsModelsApart) {
  const SceneDef base = struck_wall();
  const std::uint64_t a = model_fingerprint(Engine(base).model());
  EXPECT_EQ(a, model_fingerprint(Engine(base).model()));
  SceneDef other = base;
  other.objects[0].position[0] += 0.01;  // same counts, moved
  EXPECT_NE(a, model_fingerprint(Engine(other).model()));
  other = base;
  other.projectiles[0].radius = 0.07;
  EXPECT_NE(a, model_fingerprint(Engine(other).model()));
  other = base;
  other.solver.seed = 2;  // other strength classes
  EXPECT_NE(a, model_fingerprint(Engine(other).model()));
  other = base;
  other.grips[0].velocity = {0, 0, 0.1};
  EXPECT_NE(a, model_fingerprint(Engine(other).model()));
  other = base;
  other.name = "renamed";  // names do not shape the state
  EXPECT_EQ(a, model_fingerprint(Engine(other).model()));

  // The random lattice's bending springs: -0 (from any front end, not only a scene file) is 0.
  SceneDef block = test::block_scene(6, 6, 6);
  block.solver.lattice = SolverDef::Lattice::random;
  block.solver.link_bending = 0.0;
  const std::uint64_t unbent = model_fingerprint(Engine(block).model());
  block.solver.link_bending = -0.0;
  EXPECT_EQ(unbent, model_fingerprint(Engine(block).model()));
  block.solver.link_bending = 0.1;
  EXPECT_NE(unbent, model_fingerprint(Engine(block).model()));

  // Through the Engine, as resume uses it.
  EXPECT_NO_THROW(Engine(base, fixture().state, "here", a));
  try {
    Engine e(base, fixture().state, "checkpoint 'c.mcack'", a ^ 1);
    ADD_FAILURE() << "a fingerprint mismatch was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("checkpoint 'c.mcack'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("does not give the model"), std::string::npos) << e.what();
  }
}

TEST(Checkpoint, RoundTripKeepsEveryField) {
  const Fixture& f = fixture();
  const fs::path p = temp_file("round.mcack");
  { std::ofstream(p, std::ios::binary) << f.bytes; }
  const io::Checkpoint cp = io::read_checkpoint(p);
  fs::remove(p);
  EXPECT_EQ(cp.frame, 2);
  EXPECT_EQ(cp.wall_seconds, 1.5);
  EXPECT_EQ(state_hash(cp.state), state_hash(f.state));
  // What state_hash leaves out.
  const State& a = f.state;
  const State& b = cp.state;
  EXPECT_EQ(std::memcmp(a.s.data(), b.s.data(), a.s.size() * sizeof(Sym3)), 0);
  EXPECT_EQ(std::memcmp(a.f.data(), b.f.data(), a.f.size() * sizeof(Vec3)), 0);
  EXPECT_EQ(std::memcmp(a.t.data(), b.t.data(), a.t.size() * sizeof(Vec3)), 0);
  ASSERT_EQ(a.breaks.size(), b.breaks.size());
  for (std::size_t k = 0; k < a.breaks.size(); ++k) {
    EXPECT_EQ(a.breaks[k].step, b.breaks[k].step);
    EXPECT_EQ(a.breaks[k].link, b.breaks[k].link);
    EXPECT_EQ(a.breaks[k].criterion, b.breaks[k].criterion);
  }
  ASSERT_EQ(a.projectiles[0].contacts.size(), b.projectiles[0].contacts.size());
  EXPECT_EQ(a.projectiles[0].contacts[0].automaton, b.projectiles[0].contacts[0].automaton);
  EXPECT_EQ(a.broken_by[0], b.broken_by[0]);
  EXPECT_EQ(a.broken_by[1], b.broken_by[1]);
  EXPECT_EQ(a.grip_work, b.grip_work);
}

TEST(Checkpoint, OlderFormatIsRefusedWithAClearMessage) {
  std::string bytes = fixture().bytes;
  bytes[7] = '1';
  const fs::path p = temp_file("v1.mcack");
  { std::ofstream(p, std::ios::binary) << bytes; }
  try {
    io::read_checkpoint(p);
    ADD_FAILURE() << "a format 1 file was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(p.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("format 1"), std::string::npos) << e.what();
  }
  bytes = fixture().bytes + "x";
  { std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes; }
  EXPECT_THROW(io::read_checkpoint(p), Error);  // bytes after the end marker
  fs::remove(p);
}

// A run folder's checkpoint is its own whatever backend wrote it (a run resumed on another backend writes
// that one into its checkpoints, and must resume again), and another scene's is refused.
TEST(Checkpoint, AFoldersCheckpointIsItsOwnWhateverBackendWroteIt) {
  const fs::path dir = temp_file("run_folder");
  fs::create_directories(dir);
  SceneDef scene = struck_wall();
  scene.solver.backend = SolverDef::Backend::cpu;
  {
    std::ofstream out(dir / "scene.toml");
    out << io::scene_to_toml(scene);
  }
  const fs::path file = dir / "checkpoints" / io::checkpoint_name(2);
  io::Checkpoint cp;
  cp.scene = scene;
  for (const auto b : {SolverDef::Backend::cpu, SolverDef::Backend::cuda_emulation, SolverDef::Backend::cuda,
                       SolverDef::Backend::automatic}) {
    cp.scene.solver.backend = b;
    EXPECT_NO_THROW(io::check_checkpoint_scene(cp, file, dir));
  }
  cp.scene.solver.seed += 1;
  try {
    io::check_checkpoint_scene(cp, file, dir);
    ADD_FAILURE() << "another scene's checkpoint was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("seed"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
}

TEST(Checkpoint, NamesSortByFrameNumberPastAMillion) {
  EXPECT_EQ(io::checkpoint_name(7), "frame_000007.mcack");
  EXPECT_EQ(io::checkpoint_name(999999), "frame_999999.mcack");
  EXPECT_EQ(io::checkpoint_name(1000000), "frame_1000000.mcack");
  const fs::path dir = temp_file("names");
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const char* name : {"frame_1000000.mcack", "frame_999999.mcack", "frame_000002.mcack", "frame_12.mcack",
                           "frame_abc.mcack", "frame_.mcack", "notes.mcack", "frame_000003.mcack.1.2.tmp",
                           "frame_-5.mcack", "frame_99999999999999999999999.mcack"})
    std::ofstream(dir / name) << "x";
  fs::create_directories(dir / "frame_000001.mcack");  // a folder, not a checkpoint
  std::vector<std::string> names;
  for (const auto& p : io::list_checkpoints(dir)) names.push_back(p.filename().string());
  EXPECT_EQ(names, (std::vector<std::string>{"frame_000002.mcack", "frame_12.mcack", "frame_999999.mcack",
                                             "frame_1000000.mcack"}));
  EXPECT_TRUE(io::list_checkpoints(dir / "missing").empty());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mca
