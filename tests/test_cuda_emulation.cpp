// The CUDA backend's algorithm (src/backend/cuda/), run on the host thread by thread (its host emulation),
// against the CPU backend, bit for bit: the state of both after every chunk of steps, on scenes with
// breaking, contacts and the ground active. This is how every line of the CUDA backend's step logic is
// tested on machines without a GPU.
#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <optional>
#include <string>
#include <thread>
#include <tuple>
#include <type_traits>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "backend/cuda/device_backend.hpp"
#include "backend/cuda/host_device.hpp"
#include "analysis/fragments.hpp"
#include "core/environment.hpp"
#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "render/camera.hpp"
#include "render/egl_context.hpp"
#include "render/renderer.hpp"
#include "render/snapshot.hpp"
#include "sim/engine.hpp"
#include "shell.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {
using test::ForceEnv;
using test::error_of;

// The first field and index where two states differ (bitwise), or "" when they are equal.
template <class T>
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}
template <class T, class F>
std::string first_diff(const char* name, const std::vector<T>& a, const std::vector<T>& b, F&& same) {
  if (a.size() != b.size()) return fmt::format("{}: {} against {} entries", name, a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k)
    if (!same(a[k], b[k])) return fmt::format("{}[{}]", name, k);
  return "";
}
template <class T>
std::string first_diff(const char* name, const std::vector<T>& a, const std::vector<T>& b) {
  return first_diff(name, a, b, [](const T& x, const T& y) { return same_bits(x, y); });
}
std::string first_difference(const State& a, const State& b) {
  auto pair = [](const ContactPair& x, const ContactPair& y) {
    return x.i == y.i && x.j == y.j && same_bits(x.h.ut, y.h.ut) && same_bits(x.h.mr, y.h.mr);
  };
  auto body = [](const BodyContact& x, const BodyContact& y) {
    return x.automaton == y.automaton && same_bits(x.h.ut, y.h.ut) && same_bits(x.h.mr, y.h.mr);
  };
  auto brk = [](const BreakRecord& x, const BreakRecord& y) {
    return x.step == y.step && x.link == y.link && x.criterion == y.criterion;
  };
  for (const std::string& d :
       {first_diff("x", a.x, b.x), first_diff("v", a.v, b.v), first_diff("w", a.w, b.w), first_diff("q", a.q, b.q),
        first_diff("intact", a.intact, b.intact), first_diff("link_ut", a.link_ut, b.link_ut),
        first_diff("link_moment", a.link_moment, b.link_moment), first_diff("link_damage", a.link_damage, b.link_damage),
        first_diff("mean_stress", a.mean_stress, b.mean_stress), first_diff("s", a.s, b.s), first_diff("f", a.f, b.f),
        first_diff("t", a.t, b.t), first_diff("contacts", a.contacts, b.contacts, pair),
        first_diff("ground_contacts", a.ground_contacts, b.ground_contacts, body),
        first_diff("x_at_rebuild", a.x_at_rebuild, b.x_at_rebuild), first_diff("breaks", a.breaks, b.breaks, brk),
        first_diff("grip_work", a.grip_work, b.grip_work), first_diff("grip_force", a.grip_force, b.grip_force)})
    if (!d.empty()) return d;
  if (a.projectiles.size() != b.projectiles.size()) return "projectiles";
  for (std::size_t p = 0; p < a.projectiles.size(); ++p) {
    const ProjectileState &x = a.projectiles[p], &y = b.projectiles[p];
    if (!same_bits(x.position, y.position) || !same_bits(x.velocity, y.velocity) ||
        !same_bits(x.angular_velocity, y.angular_velocity) || !same_bits(x.orientation, y.orientation) ||
        !same_bits(x.force, y.force) || !same_bits(x.ground.ut, y.ground.ut) || !same_bits(x.ground.mr, y.ground.mr) ||
        !same_bits(x.work, y.work))
      return fmt::format("projectiles[{}]", p);
    const std::string c = first_diff("projectile contacts", x.contacts, y.contacts, body);
    if (!c.empty()) return fmt::format("projectiles[{}] {}", p, c);
  }
  if (a.projectile_contacts.size() != b.projectile_contacts.size()) return "projectile_contacts";
  for (std::size_t k = 0; k < a.projectile_contacts.size(); ++k) {
    const ProjectilePair &x = a.projectile_contacts[k], &y = b.projectile_contacts[k];
    if (x.p != y.p || x.q != y.q || !same_bits(x.h.ut, y.h.ut) || !same_bits(x.h.mr, y.h.mr))
      return fmt::format("projectile_contacts[{}]", k);
  }
  if (a.step != b.step || !same_bits(a.time, b.time)) return "step or time";
  if (a.broken_by[0] != b.broken_by[0] || a.broken_by[1] != b.broken_by[1]) return "broken_by";
  if (!same_bits(a.initial_energy, b.initial_energy)) return "initial_energy";
  return "";
}

struct Compared {
  std::int64_t breaks = 0;
  std::size_t contacts = 0, ground = 0, projectile_contacts = 0;
  std::size_t shared = 0;  // automata in contact with two projectiles or more at once
  std::size_t pairs = 0;   // projectile pairs in contact
};

// The automata in two projectiles' contact lists or more.
std::size_t shared_automata(const State& s) {
  std::map<std::uint32_t, int> lists;
  for (const auto& p : s.projectiles)
    for (const auto& c : p.contacts) ++lists[c.automaton];
  return static_cast<std::size_t>(std::count_if(lists.begin(), lists.end(), [](const auto& e) { return e.second > 1; }));
}

// Each field of two Energies, named.
std::vector<std::pair<const char*, std::pair<double, double>>> energy_fields(const Energies& a, const Energies& b) {
  return {{"kinetic", {a.kinetic, b.kinetic}},
          {"elastic", {a.elastic, b.elastic}},
          {"contact", {a.contact, b.contact}},
          {"projectile_kinetic", {a.projectile_kinetic, b.projectile_kinetic}},
          {"gravity_work", {a.gravity_work, b.gravity_work}},
          {"grip_work", {a.grip_work, b.grip_work}},
          {"load_work", {a.load_work, b.load_work}},
          {"projectile_work", {a.projectile_work, b.projectile_work}}};
}
// The energies Engine's check takes from each backend (Backend::energies): the same bits, so that a run stops
// or goes on at the same step on each (a checkpoint whose starting energy put the check on the edge stopped
// the CPU's run and not the emulation's, found by a hostile review).
void expect_same_energies(const Energies& second, const Energies& first, std::int64_t step) {
  for (const auto& [name, v] : energy_fields(second, first))
    EXPECT_TRUE(same_bits(v.first, v.second)) << name << " of the energy check after step " << step << ": "
                                              << fmt::format("{:a} against {:a}", v.first, v.second);
}
// Those energies against compute_energies' serial sums of the same terms: equal to rounding (relative to the
// energies in play).
void expect_energies_close(const Energies& device, const Energies& host, std::int64_t step) {
  const double scale = std::fabs(host.kinetic) + std::fabs(host.elastic) + std::fabs(host.projectile_kinetic) +
                       std::fabs(host.gravity_work) + std::fabs(host.grip_work) + std::fabs(host.load_work) +
                       std::fabs(host.projectile_work) + 1e-300;
  for (const auto& [name, v] : energy_fields(device, host))
    EXPECT_LE(std::fabs(v.first - v.second), 1e-12 * scale)
        << name << " after step " << step << ": " << v.first << " on the device, " << v.second << " from the state";
}

// What a caller of run_both watches: `each` sees the first backend's state after every call, `after` the
// second backend's engine at the end.
struct Watch {
  std::function<void(const State&)> each;
  std::function<void(const Engine&)> after;
};

// Every launch of the emulation runs its threads backwards while one lives (a CUDA grid runs its threads in
// no set order, so no launch may depend on one).
struct Backwards {
  Backwards() { gpu::HostDevice::reverse = true; }
  ~Backwards() { gpu::HostDevice::reverse = false; }
  Backwards(const Backwards&) = delete;
  Backwards& operator=(const Backwards&) = delete;
};

// Runs the scene on backend `first` (the CPU's by default) and on `second` (the CUDA backend's emulation by
// default), `steps` steps in calls of `chunk`, and checks that the states are equal after every call.
Compared run_both(SceneDef scene, std::int64_t steps, int chunk, SolverDef::Backend second = SolverDef::Backend::cuda_emulation,
                  SolverDef::Backend first = SolverDef::Backend::cpu, const Watch& watch = {}) {
  scene.solver.backend = first;
  Engine cpu(scene);
  scene.solver.backend = second;
  Engine emu(scene);
  Compared c;
  bool equal = true;
  for (std::int64_t done = 0; done < steps; done += chunk) {
    const int k = static_cast<int>(std::min<std::int64_t>(chunk, steps - done));
    EXPECT_EQ(cpu.advance(k).flags, kHealthy);
    EXPECT_EQ(emu.advance(k).flags, kHealthy);
    const State &a = cpu.state(), &b = emu.state();
    c.contacts = std::max(c.contacts, a.contacts.size());
    c.ground = std::max(c.ground, a.ground_contacts.size());
    for (const auto& p : a.projectiles) c.projectile_contacts = std::max(c.projectile_contacts, p.contacts.size());
    c.shared = std::max(c.shared, shared_automata(a));
    c.pairs = std::max(c.pairs, a.projectile_contacts.size());
    if (watch.each) watch.each(a);
    const std::string d = first_difference(a, b);
    if (!d.empty()) {
      ADD_FAILURE() << scene.name << ": the state of " << emu.backend().name() << " differs from that of "
                    << cpu.backend().name() << " after step " << a.step << ", first in " << d;
      equal = false;
      break;
    }
    EXPECT_EQ(state_hash(a), state_hash(b));
    const Energies checked = emu.backend().energies();
    expect_same_energies(checked, cpu.backend().energies(), a.step);
    expect_energies_close(checked, compute_energies(emu.model(), b), a.step);
  }
  c.breaks = cpu.state().broken_by[0] + cpu.state().broken_by[1];
  if (watch.after) watch.after(emu);
  if (equal)
    std::printf("%s, %s against %s: %lld steps equal bit for bit; %lld links broken, up to %zu pair contacts, %zu on the ground, %zu "
              "under a projectile\n",
              scene.name.c_str(), emu.backend().name().c_str(), cpu.backend().name().c_str(), static_cast<long long>(steps),
              static_cast<long long>(c.breaks), c.contacts, c.ground,
              c.projectile_contacts);
  return c;
}

TEST(CudaEmulation, TheDefaultWallIsTheCpusBitForBit) {
  const Compared c = run_both(io::load_default_scene(), 6000, 1000);
  EXPECT_GT(c.breaks, 0);
  EXPECT_GT(c.contacts, 0u);
  EXPECT_GT(c.ground, 0u);
  EXPECT_GT(c.projectile_contacts, 0u);
}

// The paper's four walls (cubic lattice, clustered classes), their balls moved to 1 cm from the walls.
// The scenes folder: MCA_SCENES where the tests run away from the source tree (scripts/gpu_check.sh on a GPU
// machine), else the source tree's.
std::string scene_file(const std::string& name) {
  const char* dir = std::getenv("MCA_SCENES");
  return (dir && *dir ? std::string(dir) : std::string(MCA_SOURCE_DIR "/scenes")) + "/" + name;
}

SceneDef four_walls() {
  SceneDef s = io::load_scene_file(scene_file("four_walls.toml"));
  for (auto& p : s.projectiles) p.position[1] = -0.31;
  return s;
}
TEST(CudaEmulation, FourWallsAreTheCpusBitForBit) {
  const SceneDef s = four_walls();
  const Compared c = run_both(s, 3000, 750);
  EXPECT_GT(c.breaks, 0);
  EXPECT_GT(c.ground, 0u);
  EXPECT_GT(c.projectile_contacts, 0u);
}

// A volume-filled mesh on the random lattice: the bunny at a coarse spacing, its ball 1 cm away.
// The scene file with `edit` applied, or none (and why) when the paper's models are not installed.
std::optional<SceneDef> paper_scene(const char* file, const std::function<void(SceneDef&)>& edit, std::string& why) {
  try {
    SceneDef s = io::load_scene_file(scene_file(file));
    edit(s);
    Engine probe(s);  // resolves the mesh
    return s;
  } catch (const Error& e) {
    if (std::string(e.what()).find("get_models.sh") == std::string::npos) throw;
    why = std::string("the paper's models are not installed (scripts/get_models.sh): ") + e.what();
    return std::nullopt;
  }
}
std::optional<SceneDef> bunny(std::string& why) {
  return paper_scene("bunny.toml", [](SceneDef& s) {
    s.solver.target_automata = 3000;
    s.projectiles[0].position[0] = -0.295;
  }, why);
}
std::optional<SceneDef> cow(std::string& why) {
  return paper_scene("cow.toml", [](SceneDef& s) { s.projectiles[0].position[1] = -0.205; }, why);
}

TEST(CudaEmulation, AVolumeFilledMeshIsTheCpusBitForBit) {
  std::string why;
  const auto s = bunny(why);
  if (!s) GTEST_SKIP() << why;
  const Compared c = run_both(*s, 6000, 1500);
  EXPECT_GT(c.breaks, 0);
  EXPECT_GT(c.projectile_contacts, 0u);
}

// The paper's cow in surface mode (one automaton per triangle, explicit links with bending springs).
TEST(CudaEmulation, TheCowShellIsTheCpusBitForBit) {
  std::string why;
  const auto s = cow(why);
  if (!s) GTEST_SKIP() << why;
  const Compared c = run_both(*s, 10000, 500);
  EXPECT_GT(c.breaks, 0);
  EXPECT_GT(c.projectile_contacts, 0u);
}

// A bar pulled apart by its grips (the grips' sums and work).
SceneDef pulled_bar() {
  SceneDef bar = io::load_scene_file(scene_file("tension_bar.toml"));
  bar.grips[1].velocity = {0.5, 0, 0};
  return bar;
}
// Two balls that meet over a random-lattice block: one free, one kinematic (the projectile pairs, a
// kinematic projectile's work).
SceneDef colliding_balls() {
  SceneDef s = test::block_scene(12, 12, 4, 0.02);
  s.solver.lattice = SolverDef::Lattice::random;
  s.solver.gravity = {0, 0, -9.81};
  s.ground.enabled = true;
  s.ground.height = -0.04;
  s.materials[0] = *find_builtin_material("concrete");
  s.objects[0].material = "concrete";
  ProjectileDef a, b;  // (names from std::string: g++ 12 warned a false -Wrestrict on "a")
  a.name = std::string(1, 'a');
  a.radius = 0.04;
  a.position = {-0.085, 0, 0.085};
  a.velocity = {20, 0, 0};
  b.name = std::string(1, 'b');
  b.radius = 0.04;
  b.position = {0.0, 0, 0.085};
  b.velocity = {0, 0, -5};
  b.kinematic = true;
  s.projectiles = {a, b};
  return s;
}
// A block held whole by a grip, struck by a free block from above and a free ball from the side: every
// contact is with a held automaton (the free one's own mass in the dashpots), on both lattices.
SceneDef held_anvil(SolverDef::Lattice lattice) {
  SceneDef s = test::block_scene(6, 6, 3, 0.02, *find_builtin_material("concrete"));
  s.solver.lattice = lattice;
  s.objects[0].name = "anvil";
  ObjectDef hammer = s.objects[0];
  hammer.name = "hammer";
  hammer.size = {0.06, 0.06, 0.06};
  hammer.position = {0.01, 0.005, 0.0605};
  hammer.velocity = {0, 0, -5};
  s.objects.push_back(hammer);
  GripDef hold;
  hold.min = {-0.07, -0.07, -0.031};
  hold.max = {0.07, 0.07, 0.031};
  s.grips = {hold};
  ProjectileDef ball;
  ball.name = "ball";
  ball.radius = 0.03;
  ball.position = {-0.0905, 0.0, 0.0};
  ball.velocity = {10, 0, 0};
  s.projectiles = {ball};
  return s;
}
TEST(CudaEmulation, GripsAndCollidingBallsAreTheCpusBitForBit) {
  EXPECT_GT(run_both(pulled_bar(), 4000, 1000).breaks, 0);
  run_both(test::loaded_cantilever(), 1500, 256);  // (the load's work in the energy check)
  const Compared d = run_both(colliding_balls(), 8000, 50);
  EXPECT_GT(d.breaks, 0);
  EXPECT_GT(d.projectile_contacts, 0u);
  EXPECT_GT(d.pairs, 0u) << "the balls never met";
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random}) {
    const Compared h = run_both(held_anvil(lattice), 3000, 100);
    EXPECT_GT(h.contacts, 0u);
    EXPECT_GT(h.projectile_contacts, 0u);
  }
}

// Two bodies meeting face to face, turned against each other, fast enough to break links: the faces'
// contacts (ModelView::contact_faces), their ways of touching (ContactPair::face) and the contact search's
// wider reach for them are the CPU's.
SceneDef bodies_meeting(SolverDef::Lattice lattice) {
  const std::string name = lattice == SolverDef::Lattice::cubic ? "cubic" : "random";
  SceneDef s = io::parse_scene("name = \"faces_" + name + "\"\n[solver]\nspacing = 0.05\nlattice = \"" + name +
                                   "\"\ngravity = [0.0, 0.0, -9.81]\n[ground]\nenabled = true\n"
                                   "[[object]]\nname = \"a\"\nsize = [0.2, 0.2, 0.2]\nposition = [-0.1005, 0.0, 0.1]\n"
                                   "velocity = [4.0, 0.0, 0.0]\n"
                                   "[[object]]\nname = \"b\"\nsize = [0.2, 0.15, 0.15]\nposition = [0.104, 0.01, 0.1]\n"
                                   "velocity = [-4.0, 0.0, 0.0]\nrotation = [10.0, 0.0, 5.0]\n",
                               "faces.toml");
  return s;
}
TEST(CudaEmulation, BodiesMeetingFaceToFaceAreTheCpusBitForBit) {
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random}) {
    std::size_t touching = 0;  // contacts as faces, at the ends of the chunks
    Watch w;
    const SceneDef scene = bodies_meeting(lattice);
    w.each = [&](const State& st) {
      for (const auto& c : st.contacts) {
        touching += c.face >= ContactPair::kAsFaces;
      }
    };
    const Compared c = run_both(scene, 4000, 100, SolverDef::Backend::cuda_emulation, SolverDef::Backend::cpu, w);
    std::printf("%s: %zu face contacts pressing at the chunks' ends\n", scene.name.c_str(), touching);
    EXPECT_GT(touching, 0u) << "the faces never touched as faces";
    EXPECT_GT(c.breaks, 0);
    EXPECT_GT(c.ground, 0u);
  }
}

// A ball breaking a block on the ground 9.4e5 m from the origin (a scene may go to 1e6 m), off every axis,
// where a position's last place is 1.2e-10 m: the CUDA backend's arithmetic on positions (the links'
// lengths, contacts, the ground, the projectile) keeps the CPU's order there too, on both lattices.
SceneDef far_from_origin(SolverDef::Lattice lattice) {
  const Vec3d at{-5.7e5, 4.1e5, 6.2e5};
  SceneDef s = test::block_scene(6, 4, 6, 0.05, *find_builtin_material("concrete"));
  s.name = lattice == SolverDef::Lattice::cubic ? "far_from_origin_cubic" : "far_from_origin_random";
  s.solver.lattice = lattice;
  s.solver.gravity = {0, 0, -9.81};
  s.ground.enabled = true;
  s.ground.height = at[2];
  s.objects[0].position = {at[0], at[1], at[2] + 0.15};
  ProjectileDef ball;
  ball.name = "ball";
  ball.radius = 0.05;
  ball.position = {at[0], at[1] - 0.2, at[2] + 0.15};
  ball.velocity = {0, 30, 0};
  s.projectiles = {ball};
  return s;
}
void far_from_origin_on(SolverDef::Backend second) {
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random}) {
    const Compared c = run_both(far_from_origin(lattice), 2000, 100, second);
    EXPECT_GT(c.breaks, 0);
    EXPECT_GT(c.ground, 0u);
    EXPECT_GT(c.projectile_contacts, 0u);
  }
}
TEST(CudaEmulation, AnObjectFarFromTheOriginIsTheCpusBitForBit) {
  far_from_origin_on(SolverDef::Backend::cuda_emulation);
}

// The two ways the CUDA backend runs a lattice without explicit links (MCA_CUDA_LATTICE, read as a backend
// is made): one fused kernel, each automaton computing its six links (the default), or the links and
// automata kernels apart. Each is the CPU's bit for bit on the cubic wall as it is (instant break,
// clustered classes) and jittered, with softening, spread and exponentially strengthening links; the fused
// one also with every launch run backwards and resumed across backends. The random lattice (explicit
// links) takes the split kernels whatever the variable says.
void resumes_across(SceneDef scene, SolverDef::Backend first, SolverDef::Backend second, int before, int after);
struct LatticeKernels : ForceEnv {  // (the variable as it was restored after)
  explicit LatticeKernels(const char* how) : ForceEnv("MCA_CUDA_LATTICE", how) {}
};
SceneDef cubic_wall() {  // its ball moved to 1 cm from the wall
  SceneDef s = io::load_scene_file(scene_file("wall_ball_cubic.toml"));
  for (auto& p : s.projectiles) p.position[1] = -0.31;
  return s;
}
SceneDef soft_jittered_cubic_wall() {
  SceneDef s = cubic_wall();
  MaterialDef c = *find_builtin_material("concrete");
  c.fracture_energy = 100;
  c.weibull_modulus = 6;
  c.strengthening = StrengtheningLaw::exponential;
  c.strengthening_alpha = 50;
  s.materials.push_back(c);
  s.solver.lattice_jitter = 0.25;
  s.name += "_soft_jittered";
  return s;
}
bool fused_lattice(SceneDef scene) {
  scene.solver.backend = SolverDef::Backend::cuda_emulation;
  Engine e(scene);
  const auto* dev = dynamic_cast<const gpu::DeviceBackend<gpu::HostDevice>*>(&e.backend());
  return dev && dev->fused_lattice();
}
// The steps the fused kernel ran compiled for a plain lattice step (is_plain), in `calls` calls of `steps`,
// and the launches of the many-body kernel so compiled.
std::pair<std::size_t, std::size_t> plain_steps(SceneDef scene, int calls, int steps) {
  scene.solver.backend = SolverDef::Backend::cuda_emulation;
  Engine e(scene);
  for (int k = 0; k < calls; ++k) e.advance(steps);
  const auto* dev = dynamic_cast<const gpu::DeviceBackend<gpu::HostDevice>*>(&e.backend());
  if (!dev) return {};
  return {dev->plain_lattice_steps(), dev->plain_many_body_steps()};
}
// A plain step (none of a strengthening law, softening, rest lengths of their own, spread strengths, grips,
// loads, nor a call's last step) takes the lattice kernels compiled for it: the cubic wall's every step but
// each call's last (the many-body kernel, for which a call's last step is no different, every step and the
// one after); never the jittered wall with softening, spread and strengthening links, nor grips.
TEST(CudaEmulation, PlainLatticeStepsTakeTheKernelsCompiledForThem) {
  const LatticeKernels kernels("fused");
  using Counts = std::pair<std::size_t, std::size_t>;
  EXPECT_EQ(plain_steps(cubic_wall(), 3, 10), Counts(27, 31));
  EXPECT_EQ(plain_steps(soft_jittered_cubic_wall(), 3, 10), Counts(0, 0));
  SceneDef gripped = cubic_wall();  // its bottom row held
  GripDef hold;
  hold.min = {-1.1, -0.2, 0.0};
  hold.max = {1.1, 0.2, 0.06};
  gripped.grips.push_back(hold);
  EXPECT_EQ(plain_steps(gripped, 3, 10), Counts(0, 0));
  // Each field that makes a step not plain, alone; plain() clears it.
  std::apply(
      [](auto... field) {
        auto check = [](auto f) {
          cpu::LatticeView v;
          EXPECT_TRUE(gpu::is_plain(v));
          using T = std::remove_reference_t<decltype(v.*f)>;
          if constexpr (std::is_same_v<T, bool>) v.*f = true;
          else v.*f = reinterpret_cast<T>(std::uintptr_t{64});
          EXPECT_FALSE(gpu::is_plain(v));
          EXPECT_TRUE(gpu::is_plain(gpu::plain(v)));
        };
        (check(field), ...);
      },
      gpu::not_plain_fields());
}
TEST(CudaEmulation, TheFusedAndSplitLatticeKernelsAreTheCpusBitForBit) {
  const SceneDef walls[] = {cubic_wall(), soft_jittered_cubic_wall()};
  for (const char* how : {"fused", "split"}) {
    LatticeKernels kernels(how);
    EXPECT_EQ(fused_lattice(walls[0]), std::string(how) == "fused") << how;
    EXPECT_FALSE(fused_lattice(io::load_default_scene())) << how << ": the random lattice";
    for (const SceneDef& s : walls) {
      SCOPED_TRACE(fmt::format("MCA_CUDA_LATTICE={}, {}", how, s.name));
      const Compared c = run_both(s, 1500, 500);
      EXPECT_GT(c.breaks, 0);
      EXPECT_GT(c.projectile_contacts, 0u);
    }
  }
  EXPECT_TRUE(fused_lattice(walls[1])) << "the default";
  {
    const Backwards backwards;
    EXPECT_GT(run_both(walls[1], 1500, 500).breaks, 0);
  }
  resumes_across(walls[1], SolverDef::Backend::cpu, SolverDef::Backend::cuda_emulation, 900, 600);
  resumes_across(walls[1], SolverDef::Backend::cuda_emulation, SolverDef::Backend::cpu, 900, 600);
}
TEST(CudaEmulation, AnUnknownLatticeKernelChoiceIsRefused) {
  for (const char* how : {"fast", "fused:5", "fused:1", "fused:", "fused:3x", "Fused"}) {
    LatticeKernels kernels(how);
    const std::string e = error_of([] { Engine::check_environment(); });
    EXPECT_NE(e.find(fmt::format("MCA_CUDA_LATTICE = '{}'", how)), std::string::npos) << how << " was taken: " << e;
    EXPECT_NE(e.find("fused:4"), std::string::npos) << e;
  }
  // What is taken: the fused kernel's blocks per multiprocessor (3 unless given), or the split kernels.
  const std::tuple<const char*, bool, int> taken[] = {{"", true, 3},        {"fused", true, 3}, {"fused:2", true, 2},
                                                      {"fused:3", true, 3}, {"fused:4", true, 4}, {"split", false, 3}};
  for (const auto& [how, fused, blocks] : taken) {
    LatticeKernels kernels(how);
    const CudaLattice got = cuda_lattice();
    EXPECT_EQ(got.fused, fused) << how;
    EXPECT_EQ(got.blocks, blocks) << how;
  }
}

// A step's breaks in one block where they are few (SmallBreaksKernel), through the sorts and scans where
// they are more: a concrete slab dropped flat onto the ground at 60 m/s breaks hundreds of links in a step
// and few in others, on the cubic lattice (the fused kernel) and the random one (explicit links). Returns
// the steps with few breaks and the most in a step.
SceneDef dropped_slab(SolverDef::Lattice lattice) {
  SceneDef s = test::block_scene(24, 24, 3, 0.02, *find_builtin_material("concrete"));
  s.name = lattice == SolverDef::Lattice::cubic ? "dropped_slab" : "dropped_slab_random";
  s.solver.lattice = lattice;
  s.objects[0].position = {0, 0, 0.031};
  s.objects[0].velocity = {0, 0, -60};
  s.ground.enabled = true;
  s.ground.height = 0;
  return s;
}
void few_and_many_breaks(SolverDef::Backend second) {
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random}) {
    const SceneDef s = dropped_slab(lattice);
    std::int64_t most = 0, small_steps = 0, last = 0;
    std::size_t large = 0;
    run_both(s, 300, 1, second, SolverDef::Backend::cpu,
             {[&](const State& a) {
                const std::int64_t broken = a.broken_by[0] + a.broken_by[1], now = broken - last;
                last = broken;
                most = std::max(most, now);
                if (now > 0 && now <= static_cast<std::int64_t>(gpu::kSmallBreaks)) ++small_steps;
              },
              [&](const Engine& e) {
                if (const auto* dev = dynamic_cast<const gpu::DeviceBackend<gpu::HostDevice>*>(&e.backend()))
                  large = dev->large_break_steps();
              }});
    std::printf("%s: 300 steps equal bit for bit; %lld links broken, up to %lld in a step, %lld steps with %u or fewer\n",
                s.name.c_str(), static_cast<long long>(last), static_cast<long long>(most),
                static_cast<long long>(small_steps), gpu::kSmallBreaks);
    EXPECT_GT(most, static_cast<std::int64_t>(gpu::kSmallBreaks));
    EXPECT_GT(small_steps, 0);
    if (second == SolverDef::Backend::cuda_emulation) {
      EXPECT_GT(large, 0u);
    }
  }
}
TEST(CudaEmulation, FewAndManyBreaksInAStepAreTheCpusBitForBit) {
  few_and_many_breaks(SolverDef::Backend::cuda_emulation);
}

// The projectiles' candidates from the lattice kernel's list (sorted by automaton), and written again from
// the counts where they are more than it had room for: 49 balls driven into a slab. Returns the most
// projectile contacts at once.
std::size_t hail(SolverDef::Backend second, const std::function<void(const Engine&)>& after = {}) {
  SceneDef s = test::block_scene(40, 40, 3, 0.025, *find_builtin_material("concrete"));
  s.name = "hail";
  s.objects[0].position = {0, 0, 0};
  for (int i = 0; i < 7; ++i)
    for (int j = 0; j < 7; ++j) {
      ProjectileDef p;
      p.name = fmt::format("ball{}_{}", i, j);
      p.radius = 0.06;
      p.position = {-0.42 + 0.14 * i, -0.42 + 0.14 * j, 0.0375 + 0.06 + 0.001};
      p.velocity = {0, 0, -15};
      s.projectiles.push_back(p);
    }
  std::size_t most = 0;
  run_both(s, 600, 10, second, SolverDef::Backend::cpu,
           {[&](const State& a) {
              std::size_t touching = 0;
              for (const auto& p : a.projectiles) touching += p.contacts.size();
              most = std::max(most, touching);
            },
            after});
  return most;
}
// In the emulation the list has room for 8 at first (then at least twice the last step's), and every launch runs
// backwards (run forwards, the automata would list their entries in order, and the sort would have
// nothing to do). The contacts of up to 16 candidates take one block (ProjectilePassKernel, its scan in 4
// chunks: up to 4 candidates in each, or none), more take four launches.
TEST(CudaEmulation, ProjectileCandidatesListedOrCountedAreTheCpusBitForBit) {
  struct SmallRoomBackwards {
    SmallRoomBackwards() {
      gpu::DeviceBackend<gpu::HostDevice>::first_touch_room = 8;
      gpu::DeviceBackend<gpu::HostDevice>::small_candidates = 16;
      gpu::DeviceBackend<gpu::HostDevice>::pass_chunks = 4;
    }
    ~SmallRoomBackwards() {
      gpu::DeviceBackend<gpu::HostDevice>::first_touch_room = 1024;
      gpu::DeviceBackend<gpu::HostDevice>::small_candidates = gpu::kSmallCandidates;
      gpu::DeviceBackend<gpu::HostDevice>::pass_chunks = gpu::ProjectilePassKernel::kChunks;
    }
    const Backwards backwards;
  } setting;
  std::size_t sorted = 0, rewritten = 0, one_block = 0;
  const std::size_t most = hail(SolverDef::Backend::cuda_emulation, [&](const Engine& e) {
    const auto* dev = dynamic_cast<const gpu::DeviceBackend<gpu::HostDevice>*>(&e.backend());
    ASSERT_NE(dev, nullptr);
    sorted = dev->candidates_sorted();
    rewritten = dev->candidates_rewritten();
    one_block = dev->candidates_in_one_block();
  });
  const std::size_t with = sorted + rewritten;
  std::printf("hail: 600 steps equal bit for bit; up to %zu projectile contacts; candidates listed in %zu steps, "
              "written again in %zu; their contacts in one block in %zu, in four launches in %zu\n",
              most, sorted, rewritten, one_block, with - one_block);
  EXPECT_GT(most, 8u);
  EXPECT_GT(sorted, 100u);
  EXPECT_GT(rewritten, 0u);  // (more than the room of 8: the first step after the upload touches nothing)
  EXPECT_GT(one_block, 0u);
  EXPECT_GT(with - one_block, 100u);
}

// Three small balls driven into an upper corner of a concrete block from above (kinematic), and from two
// sides: the corner automaton touches all three at once, and adds their contacts in projectile order (an
// order that two contributions alone would not show: x + y = y + x).
SceneDef three_balls() {
  SceneDef s = test::block_scene(12, 12, 4, 0.02);
  s.materials[0] = *find_builtin_material("concrete");
  s.objects[0].material = "concrete";
  s.solver.gravity = {0, 0, -9.81};
  s.ground.enabled = true;
  s.ground.height = -0.04;
  const double edge = 0.11, top = 0.03, clear = 0.0305;  // the corner automaton's centre; a ball's, 0.0005 m off it
  const DVec3 at[3] = {{edge, edge, top + clear}, {edge + clear, edge, top}, {edge, edge + clear, top}};
  const DVec3 v[3] = {{0, 0, -2}, {-2, 0, 0}, {0, -2, 0}};
  for (int k = 0; k < 3; ++k) {
    ProjectileDef p;
    p.name = fmt::format("ball{}", k);
    p.radius = 0.02;
    p.position = {at[k].x, at[k].y, at[k].z};
    p.velocity = {v[k].x, v[k].y, v[k].z};
    p.kinematic = k == 0;
    s.projectiles.push_back(p);
  }
  return s;
}

// A CUDA grid runs its threads in no set order, so no launch may depend on one: with every launch of the
// emulation run backwards (and the breaks appended backwards), the states are the CPU's still.
TEST(CudaEmulation, LaunchesRunBackwardsGiveTheSameBits) {
  const Backwards backwards;
  const Compared c = run_both(io::load_default_scene(), 5000, 1000);
  EXPECT_GT(c.breaks, 0);
  EXPECT_GT(c.contacts, 0u);
  const Compared d = run_both(three_balls(), 3000, 100);
  EXPECT_GT(d.breaks, 0);
  EXPECT_GT(d.shared, 0u) << "no automaton touched two balls at once";
  std::printf("three balls: up to %zu automata touching two balls or more at once\n", d.shared);
}

// On a GPU each copy back to the host waits for the device to finish. A step reads the device once (its
// status): without breaks, and with few (up to kSmallBreaks) after a step with breaks (they are applied
// before the status is read); twice with breaks after a step without, or with many (the status, then what
// the breaks changed); more only to rebuild the contact lists (the new lists' sizes).
// Each step but the first uses the many-body terms the step before launched behind the copy of its last
// status (its second where it applied breaks after the first: breaks after a step without, or more than
// kSmallBreaks); a state uploaded into the backend has them computed again. (The default wall's random
// lattice has no lattice links, and no many-body terms: they are never launched.)
TEST(CudaEmulation, AStepReadsTheDeviceOnceTwiceWithBreaksMoreOnlyToRebuildContacts) {
  for (SceneDef scene : {io::load_default_scene(), three_balls()}) {
    scene.solver.backend = SolverDef::Backend::cuda_emulation;
    Engine e(scene);
    auto* dev = dynamic_cast<gpu::DeviceBackend<gpu::HostDevice>*>(&e.backend());
    ASSERT_NE(dev, nullptr);
    int once = 0, once_breaking = 0, twice = 0, rebuilt = 0;
    std::size_t rebuild_reads = 0;
    bool broke = false;
    const bool lattice = e.model().has_lattice_links();
    EXPECT_EQ(lattice, scene.name != "wall_ball") << scene.name;
    std::optional<State> half;
    for (int s = 0; s < 4000; ++s) {
      if (s == 2000) half = e.state();
      const std::size_t reads = gpu::HostDevice::reads, rebuilds = dev->contact_rebuilds();
      const std::size_t early = dev->early_many_body_steps();
      const std::int64_t broken = e.backend().broken_links();
      ASSERT_EQ(e.backend().step(1).flags, kHealthy);
      ASSERT_EQ(dev->early_many_body_steps() - early, s > 0 && lattice ? 1u : 0u) << scene.name << ", step " << s;
      const std::size_t r = gpu::HostDevice::reads - reads;
      const std::int64_t now = e.backend().broken_links() - broken;
      if (dev->contact_rebuilds() != rebuilds) {
        ++rebuilt;
        rebuild_reads += r;
      } else if (now > 0 && broke && now <= static_cast<std::int64_t>(gpu::kSmallBreaks)) {
        ASSERT_EQ(r, 1u) << scene.name << ", step " << s << ", with " << now << " breaks after a step with breaks";
        ++once_breaking;
      } else if (now > 0) {
        ASSERT_EQ(r, 2u) << scene.name << ", step " << s << ", with " << now << " breaks";
        ++twice;
      } else {
        ASSERT_EQ(r, 1u) << scene.name << ", step " << s;
        ++once;
      }
      broke = now > 0;
    }
    std::printf("%s: %d steps read the device once without breaks, %d with breaks once, %d twice, %d rebuilt the contact "
                "lists (%.1f reads each)\n",
                scene.name.c_str(), once, once_breaking, twice, rebuilt,
                rebuilt ? static_cast<double>(rebuild_reads) / rebuilt : 0.0);
    EXPECT_GT(once, 2000);
    EXPECT_GT(once_breaking, 0);
    EXPECT_GT(twice, 0);
    EXPECT_GT(rebuilt, 0);
    // Step 2000's state uploaded into the backend at step 4000, then stepped: the state a backend started
    // from it reaches.
    const std::size_t early = dev->early_many_body_steps();
    dev->upload(*half);
    ASSERT_EQ(e.backend().step(2).flags, kHealthy);
    EXPECT_EQ(dev->early_many_body_steps() - early, lattice ? 1u : 0u);
    Engine fresh(scene, *half);
    ASSERT_EQ(fresh.advance(2).flags, kHealthy);
    const std::string d = first_difference(fresh.state(), e.state());
    EXPECT_TRUE(d.empty()) << scene.name << ": step 2000's state uploaded at step 4000 differs after 2 steps, first in " << d;
  }
}

// --- The draw list ---

// The snapshot the backend builds from its own arrays (Backend::draw_list) against the one built from its
// state (render/snapshot.cpp), byte for byte, in every colour mode and draw mode but links (which the
// host draws), for a few origins; returns what was drawn at most (to show that the test saw something).
struct Drawn {
  std::size_t automata = 0, triangles = 0;
  std::int32_t fragments = 0;
  float largest_stress = 0;
};
std::string first_draw_difference(const render::Snapshot& a, const render::Snapshot& b) {
  const auto same_vec = [](const auto& x, const auto& y) {
    return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])) == 0);
  };
  if (a.automata.size() != b.automata.size())
    return fmt::format("automata drawn: {} against {}", a.automata.size(), b.automata.size());
  for (std::size_t k = 0; k < a.automata.size(); ++k)
    if (!same_bits(a.automata[k], b.automata[k])) return fmt::format("automata[{}]", k);
  if (!same_vec(a.radius, b.radius)) return "radius";
  if (a.surface.size() != b.surface.size()) return fmt::format("surface: {} corners against {}", a.surface.size(), b.surface.size());
  for (std::size_t k = 0; k < a.surface.size(); ++k)
    if (!same_bits(a.surface[k], b.surface[k]))
      return fmt::format("surface[{}]: ({}, {}, {}) against ({}, {}, {})", k, a.surface[k].x, a.surface[k].y, a.surface[k].z,
                         b.surface[k].x, b.surface[k].y, b.surface[k].z);
  if (!same_vec(a.projectiles, b.projectiles)) return "projectiles";
  if (a.fragments != b.fragments) return fmt::format("fragments: {} against {}", a.fragments, b.fragments);
  if (a.time != b.time || a.step != b.step || a.broken_links != b.broken_links) return "counters";
  const render::Legend &p = a.legend, &q = b.legend;
  if (p.title != q.title || p.continuous != q.continuous || p.min != q.min || p.max != q.max || p.unit != q.unit ||
      p.swatches != q.swatches || p.ramp != q.ramp)
    return fmt::format("legend: '{}' {}..{} against '{}' {}..{}", p.title, p.min, p.max, q.title, q.min, q.max);
  if (a.origin != b.origin || a.cube_size != b.cube_size || a.ground != b.ground || a.up != b.up ||
      a.ground_height != b.ground_height || a.automata_total != b.automata_total)
    return "frame";
  return "";
}
Drawn expect_draws_equal(const Engine& sim, const std::string& where) {
  using render::ColourMode;
  using render::DrawMode;
  Drawn seen;
  const Model& m = sim.model();
  const std::array<std::array<double, 3>, 2> origins = {{{0, 0, 0}, {0.0371, -1.25, 3e3}}};
  for (const auto& origin : origins)
    for (const DrawMode draw : {DrawMode::cubes, DrawMode::spheres, DrawMode::surface})
      for (const ColourMode colour : {ColourMode::fragment, ColourMode::damage, ColourMode::strength_class, ColourMode::group,
                                      ColourMode::stress, ColourMode::speed})
        for (const bool all : {false, true})
          for (const double scale : {0.0, 2.5}) {
            if (scale > 0 && colour != ColourMode::stress && colour != ColourMode::speed) continue;
            render::SnapshotOptions o;
            o.draw = draw;
            o.colour = colour;
            o.all_automata = all;
            o.scale_max = scale;
            const std::size_t reads = gpu::HostDevice::reads;
            render::DrawList probe;
            EXPECT_TRUE(sim.backend().draw_list(o, origin, probe, nullptr)) << "the backend left the draw list to the host";
            EXPECT_LE(gpu::HostDevice::reads - reads, 8u) << "a draw read more of the device than its lists";
            const render::Snapshot device = render::make_snapshot(m, sim.backend(), o, origin);
            const State& st = sim.state();
            const render::Snapshot host =
                render::make_snapshot(m, st, analysis::label_model_fragments(m, st.intact.data()), o, origin);
            const std::string d = first_draw_difference(device, host);
            if (!d.empty()) {
              ADD_FAILURE() << where << ", " << render::name(draw) << ", colour " << render::name(colour)
                            << (all ? ", all automata" : "") << ", scale " << scale << ", origin (" << origin[0] << ", "
                            << origin[1] << ", " << origin[2] << "): the device's draw list differs from the host's in " << d;
              return seen;
            }
            seen.automata = std::max(seen.automata, device.automata.size());
            seen.triangles = std::max(seen.triangles, device.surface.size() / 3);
            seen.fragments = std::max(seen.fragments, device.fragments);
            if (colour == ColourMode::stress && scale == 0) seen.largest_stress = std::max<float>(seen.largest_stress, device.legend.max);
          }
  return seen;
}
// Runs the scene on the emulation and compares the draw lists after each of `at` steps.
Drawn draws_equal(SceneDef scene, std::initializer_list<std::int64_t> at,
                  SolverDef::Backend backend = SolverDef::Backend::cuda_emulation) {
  scene.solver.backend = backend;
  Engine sim(scene);
  Drawn seen;
  std::int64_t done = 0;
  for (const std::int64_t step : at) {
    EXPECT_EQ(sim.advance(static_cast<int>(step - done)).flags, kHealthy);
    done = step;
    const Drawn d = expect_draws_equal(sim, fmt::format("{} at step {}", scene.name, step));
    seen.automata = std::max(seen.automata, d.automata);
    seen.triangles = std::max(seen.triangles, d.triangles);
    seen.fragments = std::max(seen.fragments, d.fragments);
    seen.largest_stress = std::max(seen.largest_stress, d.largest_stress);
  }
  return seen;
}

// The default wall (softening links: damage counts them) before and after the ball broke it.
TEST(CudaEmulation, TheDrawListIsTheHostSnapshotsOnTheBrokenWall) {
  const Drawn d = draws_equal(io::load_default_scene(), {0, 1500, 4000});
  EXPECT_GT(d.fragments, 10) << "the wall did not break up";
  EXPECT_GT(d.automata, 1000u);
  EXPECT_GT(d.largest_stress, 0.0f);
}
// The cow shell (its bound surface split where it cracked), the bunny on the random lattice (boxed
// automata), and balls that collide over a block (several projectiles).
TEST(CudaEmulation, TheDrawListIsTheHostSnapshotsOnSurfacesAndRandomLattices) {
  std::string why;
  const auto shell = cow(why);
  if (!shell) GTEST_SKIP() << why;
  const Drawn c = draws_equal(*shell, {0, 3000});
  EXPECT_GT(c.triangles, 5000u);
  EXPECT_GT(c.fragments, 1);
  const auto filled = bunny(why);
  ASSERT_TRUE(filled) << why;
  EXPECT_GT(draws_equal(*filled, {0, 2500}).fragments, 1);
  EXPECT_GT(draws_equal(colliding_balls(), {3000}).automata, 0u);
}
// A CUDA grid runs its threads in no set order: the fragments' union-find gives each fragment its
// smallest automaton however its threads ran.
TEST(CudaEmulation, TheDrawListDoesNotDependOnTheLaunchOrder) {
  const Backwards backwards;
  EXPECT_GT(draws_equal(io::load_default_scene(), {4000}).fragments, 10);
}

// Whether GL buffer `which` of the target begins with the bytes of `list` (read back from OpenGL).
template <class T>
bool buffer_holds(render::DrawTarget& target, render::DrawTarget::Which which, const std::vector<T>& list) {
  const std::size_t bytes = list.size() * sizeof(T);
  std::vector<std::uint8_t> b(bytes);
  if (bytes) glGetNamedBufferSubData(target.buffer(which), 0, static_cast<GLsizeiptr>(bytes), b.data());
  return bytes == 0 || std::memcmp(b.data(), list.data(), bytes) == 0;
}

// Zero copy: the draw list written by the backend into the renderer's own buffers (mapped into host
// memory for the emulation; registered with CUDA on a GPU) holds the host snapshot's bytes and draws the
// same picture, in the cubes and the surface modes; the spheres mode is copied, and says so.
void expect_shared_draw_is_the_hosts(SceneDef scene, std::int64_t steps, render::DrawMode draw,
                                     SolverDef::Backend backend = SolverDef::Backend::cuda_emulation) {
  constexpr int W = 320, H = 180;
  scene.solver.backend = backend;
  Engine sim(scene);
  ASSERT_EQ(sim.advance(static_cast<int>(steps)).flags, kHealthy);
  render::EglContext context;
  render::Renderer renderer;
  render::OffscreenTarget target(W, H);
  const Model& m = sim.model();
  const auto framing = render::objects_box(m, sim.state());
  const auto cam = render::make_camera(sim.scene().camera, m, framing, float(W) / H, "test");
  render::SnapshotOptions o;
  o.draw = draw;
  std::vector<std::uint8_t> shared_pixels, host_pixels;
  for (int frame = 0; frame < 2; ++frame) {  // the second into the buffers of the first
    std::string why;
    const render::Snapshot shared = render::make_snapshot(m, sim.backend(), o, framing.origin, &renderer.draw_target(), &why);
    const State& st = sim.state();
    const render::Snapshot host =
        render::make_snapshot(m, st, analysis::label_model_fragments(m, st.intact.data()), o, framing.origin);
    const std::string where = fmt::format("{} at step {}, {}", scene.name, st.step, render::name(draw));
    // On a GPU whose OpenGL context CUDA cannot share (Mesa's, on a machine without NVIDIA's EGL), the
    // list is copied, and says why.
    const bool gpu_copies = backend == SolverDef::Backend::cuda && !why.empty();
    if (draw == render::DrawMode::spheres || gpu_copies) {
      if (gpu_copies) std::printf("%s: %s\n", where.c_str(), why.c_str());
      EXPECT_EQ(shared.shared_automata, 0u);
      EXPECT_FALSE(why.empty()) << where << ": the copy was not explained";
      EXPECT_EQ(first_draw_difference(shared, host), "") << where;
      return;
    }
    ASSERT_EQ(why, "") << where;
    EXPECT_TRUE(shared.automata.empty() && shared.surface.empty()) << where << ": copied as well as shared";
    ASSERT_EQ(shared.shared_automata, host.automata.size()) << where;
    ASSERT_EQ(shared.shared_corners, host.surface.size()) << where;
    // The buffers' bytes.
    EXPECT_TRUE(buffer_holds(renderer.draw_target(), render::DrawTarget::automata, host.automata))
        << where << ": the shared instance buffer is not the host's list";
    EXPECT_TRUE(buffer_holds(renderer.draw_target(), render::DrawTarget::surface, host.surface))
        << where << ": the shared surface buffer is not the host's list";
    // The pictures.
    target.bind();
    renderer.draw(shared, draw, cam, W, H);
    target.read_rgba(shared_pixels);
    renderer.draw(host, draw, cam, W, H);
    target.read_rgba(host_pixels);
    EXPECT_TRUE(shared_pixels == host_pixels) << where << ": the picture drawn from the shared buffers differs";
    std::size_t lit = 0;
    for (std::size_t k = 0; k < host_pixels.size(); k += 4) lit += host_pixels[k] != host_pixels[0];
    EXPECT_GT(lit, 1000u) << where << ": next to nothing drawn";
    ASSERT_EQ(sim.advance(500).flags, kHealthy);
  }
}
TEST(CudaEmulation, TheDrawListWrittenIntoTheRenderersBuffersDrawsTheSamePicture) {
  expect_shared_draw_is_the_hosts(io::load_default_scene(), 4000, render::DrawMode::cubes);
  expect_shared_draw_is_the_hosts(io::load_default_scene(), 100, render::DrawMode::spheres);
  std::string why;
  const auto shell = cow(why);
  if (!shell) GTEST_SKIP() << why;
  expect_shared_draw_is_the_hosts(*shell, 3000, render::DrawMode::surface);
}

// One backend, several targets: each draw goes into the buffers of the target it is given (a backend
// that kept the state of the first one's buffers mapped a deleted one for the second).
TEST(CudaEmulation, OneBackendWritesTheTargetItIsGiven) {
  SceneDef scene = io::load_default_scene();
  scene.solver.backend = SolverDef::Backend::cuda_emulation;
  Engine sim(scene);
  ASSERT_EQ(sim.advance(1500).flags, kHealthy);
  render::EglContext context;
  const Model& m = sim.model();
  const State& st = sim.state();
  const render::Snapshot host = render::make_snapshot(m, st, analysis::label_model_fragments(m, st.intact.data()), {}, {0, 0, 0});
  const auto expect_holds_the_list = [&](render::DrawTarget& target, const char* which) {
    std::string why;
    const render::Snapshot s = render::make_snapshot(m, sim.backend(), {}, {0, 0, 0}, &target, &why);
    ASSERT_EQ(why, "") << which;
    ASSERT_EQ(s.shared_automata, host.automata.size()) << which;
    EXPECT_TRUE(buffer_holds(target, render::DrawTarget::automata, host.automata)) << which << ": not the host's list";
  };
  render::Renderer first;
  expect_holds_the_list(first.draw_target(), "the first renderer");
  {
    render::Renderer second;
    expect_holds_the_list(second.draw_target(), "a second renderer");
  }
  render::SharedBuffers third;
  expect_holds_the_list(third, "buffers of their own");
  expect_holds_the_list(first.draw_target(), "the first renderer again");
}

// A run stopped on backend `first` and continued on `second` from its state (what mca resume does with a
// checkpoint: Engine(scene, state), the state uploaded mid-run, contact lists and histories included): the
// straight CPU run's state bit for bit.
void resumes_across(SceneDef scene, SolverDef::Backend first, SolverDef::Backend second, int before, int after) {
  scene.solver.backend = SolverDef::Backend::cpu;
  Engine straight(scene);
  ASSERT_EQ(straight.advance(before + after).flags, kHealthy);
  scene.solver.backend = first;
  Engine a(scene);
  ASSERT_EQ(a.advance(before).flags, kHealthy);
  ASSERT_FALSE(a.state().contacts.empty());
  scene.solver.backend = second;
  Engine b(scene, a.state());
  ASSERT_EQ(b.advance(after).flags, kHealthy);
  const std::string d = first_difference(straight.state(), b.state());
  EXPECT_TRUE(d.empty()) << scene.name << ": stopped on " << a.backend().name() << " at step " << before << ", continued on "
                         << b.backend().name() << ": differs from the straight run after step " << straight.state().step
                         << ", first in " << d;
  EXPECT_GT(b.state().broken_by[0] + b.state().broken_by[1], a.state().broken_by[0] + a.state().broken_by[1]);
}

TEST(CudaEmulation, AStateResumesAcrossBackendsWithTheSameBits) {
  resumes_across(io::load_default_scene(), SolverDef::Backend::cpu, SolverDef::Backend::cuda_emulation, 3000, 1500);
  resumes_across(io::load_default_scene(), SolverDef::Backend::cuda_emulation, SolverDef::Backend::cpu, 3000, 1500);
}

// A GPU whose memory is full (the emulation playing one of MCA_EMULATED_GPU_MEMORY_MB), on the default
// wall in frames of about 1,000 steps: a model that does not fit is refused as the backend is made; the
// first energy check's arrays that do not fit, and a step whose contact lists outgrow the GPU, stop the
// simulation with the error that says what to do, at the step where the memory ran out, and it then
// refuses to step or be read; its state saved before resumes on the CPU with the bits of a straight run,
// and so does `mca run`'s newest checkpoint, which the run's message names with the command to use (its
// folder's name quoted for the shell). The device arrays are counted as a GPU holds them, and given back.
std::string emulated_gpu(std::size_t bytes) { return fmt::format("{:.6f}", static_cast<double>(bytes) / 1e6); }
TEST(CudaEmulation, AFullGpuStopsARunWhichResumesOnTheCpuWithTheSameBits) {
  SceneDef scene = io::load_default_scene();
  scene.output.frame_rate = 1000;
  scene.output.duration = 0.006;
  const std::size_t before = gpu::DeviceMemory::held();
  const auto peak = [&] { return gpu::DeviceMemory::peak() - before; };
  struct Emulated {  // the emulation's engine, and its peak counted from when it was made
    explicit Emulated(SceneDef s) : sim((s.solver.backend = SolverDef::Backend::cuda_emulation, s)) {
      gpu::DeviceMemory::reset_peak();
    }
    Engine sim;
  };
  std::int64_t spf = 0, total = 0;
  std::size_t start = 0, before_check = 0, after_check = 0, frame1 = 0, most = 0;
  std::vector<std::size_t> after;  // the peak after each step (and its energy check) from frame 1's end on
  {
    Emulated e(scene);
    spf = e.sim.steps_per_frame();
    total = e.sim.total_steps();
    start = peak();
    ASSERT_EQ(e.sim.advance(255).flags, kHealthy);
    before_check = peak();
    ASSERT_EQ(e.sim.advance(1).flags, kHealthy);  // (the first energy check, at step 256)
    after_check = peak();
    ASSERT_EQ(e.sim.advance(static_cast<int>(spf - 256)).flags, kHealthy);
    frame1 = peak();
    while (e.sim.step() < total) {
      ASSERT_EQ(e.sim.advance(1).flags, kHealthy);
      after.push_back(peak());
    }
    most = peak();
  }
  EXPECT_EQ(gpu::DeviceMemory::held(), before) << "every device array given back";
  std::printf("the default wall on the device: %.2f MB at the start, %.2f MB to step 255, %.2f MB at step 256, %.2f MB in "
              "frame 1 (%lld steps), %.2f MB in %lld steps\n",
              start / 1e6, before_check / 1e6, after_check / 1e6, frame1 / 1e6, static_cast<long long>(spf), most / 1e6,
              static_cast<long long>(total));
  ASSERT_GT(after_check, before_check + 100'000) << "the energy check's arrays";
  ASSERT_GT(most, frame1 + (frame1 >> 5)) << "the contact lists grow after frame 1";
  scene.solver.backend = SolverDef::Backend::cpu;
  Engine straight(scene);
  ASSERT_EQ(straight.advance(static_cast<int>(total)).flags, kHealthy);

  // Too little for the start: refused as the backend is made, saying what to do.
  {
    const ForceEnv gpu("MCA_EMULATED_GPU_MEMORY_MB", emulated_gpu(before + start / 2).c_str());
    const std::string e = error_of([&] { Emulated emu(scene); });
    EXPECT_NE(e.find("the GPU's memory is full"), std::string::npos) << e;
    EXPECT_NE(e.find("--backend cpu"), std::string::npos) << e;
    EXPECT_EQ(gpu::DeviceMemory::held(), before) << "the arrays made before are given back";
  }
  // What a simulation stopped by a full GPU answers: the error it named (`stopped`: "inside step N," or
  // "at step N, computing its energies"), every time.
  const auto refuses = [](const Engine& sim, const std::string& stopped) {
    for (const auto& [what, call] : std::initializer_list<std::pair<const char*, std::function<void()>>>{
             {"advance", [&] { const_cast<Engine&>(sim).advance(1); }},
             {"advance 0 steps", [&] { const_cast<Engine&>(sim).advance(0); }},
             {"state", [&] { (void)sim.state(); }},
             {"energies", [&] { (void)sim.backend().energies(); }}}) {
      const std::string e = error_of(call);
      EXPECT_EQ(e.rfind("this simulation stopped " + stopped, 0), 0u) << what << ": " << e;
      EXPECT_NE(e.find("the GPU's memory is full"), std::string::npos) << what << ": " << e;
    }
  };
  // Room for the start, not for the first energy check's arrays.
  {
    const ForceEnv gpu("MCA_EMULATED_GPU_MEMORY_MB", emulated_gpu(before + (before_check + after_check) / 2).c_str());
    Emulated emu(scene);
    ASSERT_EQ(emu.sim.advance(255).flags, kHealthy);
    const std::string e = error_of([&] { emu.sim.advance(10); });
    EXPECT_EQ(e.rfind("the GPU's memory is full", 0), 0u) << e;
    EXPECT_EQ(emu.sim.step(), 256) << "the step is whole; the check after it failed";
    refuses(emu.sim, "at step 256, computing its energies");
  }
  // Room for the steps to one after frame 1 whose own arrays grow (not an energy check's step): the run
  // stops inside that step, where the memory ran out (step `stopped`).
  std::optional<State> saved;  // the state after the last whole call
  std::int64_t stopped = 0, grows = 0;
  for (std::size_t k = 1; k < after.size() && !grows; ++k)
    if (after[k] > after[k - 1] && (spf + 1 + static_cast<std::int64_t>(k)) % Engine::kEnergyCheckInterval != 0)
      grows = spf + 1 + static_cast<std::int64_t>(k);
  ASSERT_GT(grows, 0) << "no step after frame 1 grows the device arrays";
  const std::size_t room_bytes = before + after[static_cast<std::size_t>(grows - spf - 2)];
  const std::string room = emulated_gpu(room_bytes);
  {
    const ForceEnv gpu("MCA_EMULATED_GPU_MEMORY_MB", room.c_str());
    Emulated emu(scene);
    std::string e;
    while (e.empty() && emu.sim.step() < total) {
      e = error_of([&] { emu.sim.advance(static_cast<int>(spf)); });
      if (e.empty()) saved = emu.sim.state();
    }
    EXPECT_EQ(e.rfind("the GPU's memory is full", 0), 0u) << e;
    EXPECT_NE(e.find("mca resume DIR --backend cpu"), std::string::npos) << e;
    ASSERT_TRUE(saved) << "frame 1 fitted";
    const std::string again = error_of([&] { (void)emu.sim.state(); });
    long long at = 0;
    if (std::sscanf(again.c_str(), "this simulation stopped inside step %lld,", &at) == 1) {
      EXPECT_EQ(emu.sim.step(), at - 1) << "the last whole step";
      refuses(emu.sim, fmt::format("inside step {},", at));
    } else {
      ASSERT_EQ(std::sscanf(again.c_str(), "this simulation stopped at step %lld, computing its energies", &at), 1) << again;
      EXPECT_EQ(emu.sim.step(), at);
      EXPECT_EQ(at % Engine::kEnergyCheckInterval, 0);
      refuses(emu.sim, fmt::format("at step {}, computing its energies", at));
    }
    stopped = at;
    std::printf("with %s MB: stopped at step %lld (%s)\n", room.c_str(), at, again.substr(0, again.find(':')).c_str());
    EXPECT_EQ(stopped, grows);
    EXPECT_EQ(again.rfind(fmt::format("this simulation stopped inside step {},", grows), 0), 0u) << again;
    EXPECT_GT(stopped, saved->step);
    EXPECT_LE(stopped, saved->step + spf);
  }
  EXPECT_EQ(gpu::DeviceMemory::held(), before);
  {
    Emulated e(scene);  // without the limit: the step named is the first beyond it
    ASSERT_EQ(e.sim.advance(static_cast<int>(stopped - 1)).flags, kHealthy);
    EXPECT_LE(before + peak(), room_bytes);
    ASSERT_EQ(e.sim.advance(1).flags, kHealthy);
    EXPECT_GT(before + peak(), room_bytes);
  }
  scene.solver.backend = SolverDef::Backend::cpu;
  Engine resumed(scene, *saved);
  ASSERT_EQ(resumed.advance(static_cast<int>(total - saved->step)).flags, kHealthy);
  const std::string d = first_difference(straight.state(), resumed.state());
  EXPECT_TRUE(d.empty()) << "resumed on the CPU from step " << saved->step << ": differs from the straight run, first in " << d;

  // mca run, stopped so: exit code 2, no summary, the newest checkpoint and the command that continues it.
  const test::TempDir tmp;
  const auto file = tmp.path() / "wall.toml", out = tmp.path() / "my run";
  {
    std::ofstream(file) << io::scene_to_toml(scene);
  }
  const test::Result r = test::shell("MCA_EMULATED_GPU_MEMORY_MB=" + room + " " + MCA_BINARY + " run " + file.string() +
                                     " --backend cuda-emulation --checkpoint-every 1 --quiet --out '" + out.string() + "'");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("error: the GPU's memory is full"), std::string::npos) << r.output;
  const auto frames_done = (stopped - 1) / spf;
  ASSERT_GE(frames_done, 1);
  const std::string command = "mca resume '" + out.string() + "' --backend cpu";
  EXPECT_NE(r.output.find(fmt::format("The run stopped inside frame {}; continue it from the newest checkpoint "
                                      "(frame_{:06d}.mcack) with:\n  {}\n",
                                      frames_done + 1, frames_done, command)),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(std::filesystem::exists(out / "summary.json"));
  const auto newest = out / "checkpoints" / fmt::format("frame_{:06d}.mcack", frames_done);
  std::filesystem::copy_file(newest, tmp.path() / "kept.mcack");  // (for the resume below)
  const test::Result resume = test::shell(std::string(MCA_BINARY) + command.substr(3) + " --quiet");
  ASSERT_EQ(resume.code, 0) << resume.output;
  EXPECT_NE(test::slurp(out / "summary.json").find(fmt::format("\"state_hash\": \"{:016x}\"", state_hash(straight.state()))),
            std::string::npos)
      << "mca resume --backend cpu from the newest checkpoint: not the straight run's state";
  // The same resume on the full GPU again (from the same checkpoint, the later ones removed): it stops as the
  // run did, and leaves no summary or fragments.csv of the finished session before (they would say
  // "finished").
  for (const auto& c : io::list_checkpoints(out / "checkpoints")) std::filesystem::remove(c);
  std::filesystem::copy_file(tmp.path() / "kept.mcack", newest);
  ASSERT_TRUE(std::filesystem::exists(out / "fragments.csv"));
  const test::Result full = test::shell("MCA_EMULATED_GPU_MEMORY_MB=" + room + " " + MCA_BINARY + command.substr(3, command.size() - 17) +
                                        " --backend cuda-emulation --quiet");
  EXPECT_EQ(full.code, 2) << full.output;
  EXPECT_NE(full.output.find(fmt::format("The run stopped inside frame {};", frames_done + 1)), std::string::npos)
      << full.output;
  EXPECT_FALSE(std::filesystem::exists(out / "summary.json"));
  EXPECT_FALSE(std::filesystem::exists(out / "fragments.csv"));
}
TEST(CudaEmulation, AnEmulatedGpuMemoryThatIsNotANumberIsRefused) {
  for (const char* given : {"0", "-1", "abc", "12MB", "1e400", "nan", " 5"}) {
    const ForceEnv gpu("MCA_EMULATED_GPU_MEMORY_MB", given);
    const std::string e = error_of([] { gpu::emulated_gpu_memory(); });
    EXPECT_NE(e.find(fmt::format("MCA_EMULATED_GPU_MEMORY_MB = '{}'", given)), std::string::npos) << e;
  }
  const ForceEnv gpu("MCA_EMULATED_GPU_MEMORY_MB", "2.5");
  EXPECT_EQ(gpu::emulated_gpu_memory(), std::optional<std::size_t>(2'500'000));
  EXPECT_EQ(gpu::grown_capacity(0, 10), 10u);
  EXPECT_EQ(gpu::grown_capacity(10, 11), 15u);
  EXPECT_EQ(gpu::grown_capacity(10, 40), 40u);
  EXPECT_EQ(gpu::grown_capacity(10, 4), 10u);
}
// Where the CUDA runtime cannot start on the machine's driver (Debian 12's own driver, 535, is for CUDA 12.2;
// nvcc 13's runtime needs the 580 series), the reason says which driver there is, which one is needed and the
// ways out; without a driver it says that none is installed.
TEST(CudaEmulation, ADriverTooOldForTheRuntimeIsNamedWithTheOneItNeeds) {
  const std::string old = cuda_driver_problem(12020, 13000);
  EXPECT_NE(old.find("the NVIDIA driver supports CUDA 12.2 and this build's CUDA runtime 13.0 needs a driver for CUDA "
                     "13 or later (NVIDIA's 580 series or newer): update the driver, or build mca with a CUDA 12 toolkit"),
            std::string::npos)
      << old;
  // Older than the device code takes: no toolkit of its version is offered.
  const std::string older = cuda_driver_problem(11040, 13000);
  EXPECT_NE(older.find("supports CUDA 11.4 and this build's CUDA runtime 13.0 needs a driver for CUDA 13 or later "
                       "(NVIDIA's 580 series or newer): update the driver (mca's device code needs CUDA 12 or newer)"),
            std::string::npos)
      << older;
  EXPECT_EQ(older.find("toolkit"), std::string::npos) << older;
  const std::string none = cuda_driver_problem(0, 12080);
  EXPECT_NE(none.find("no NVIDIA driver is installed"), std::string::npos) << none;
  EXPECT_NE(none.find("runtime 12.8 needs a driver for CUDA 12 or later (NVIDIA's 525 series or newer)"), std::string::npos)
      << none;
  const std::string unread = cuda_driver_problem(-1, 13000);
  EXPECT_NE(unread.find("could not be asked for its version"), std::string::npos) << unread;
  EXPECT_EQ(unread.find("no NVIDIA driver is installed"), std::string::npos) << unread;
  const std::string later = cuda_driver_problem(13000, 14010);
  EXPECT_NE(later.find("supports CUDA 13.0 and this build's CUDA runtime 14.1 needs a driver for CUDA 14 or later: "
                       "update the driver, or build mca with a CUDA 13 toolkit"),
            std::string::npos)
      << later;
  EXPECT_EQ(later.find("series"), std::string::npos) << later;  // (no series named that is not known)
  const std::string same = cuda_driver_problem(13000, 13010);
  EXPECT_NE(same.find("the NVIDIA driver, for CUDA 13.0, reports that it is too old for this build's CUDA runtime "
                      "13.1: update it to the newest driver for CUDA 13 or later (NVIDIA's 580 series or newer)"),
            std::string::npos)
      << same;
}
// mca info on a GPU backend says what its device arrays hold at the start, and describes a scene whose GPU
// cannot hold it (on the CPU), saying so; mca bench names the benchmark a full GPU stopped, after the results
// of those before it.
TEST(CudaEmulation, InfoAndBenchSayWhereTheGpusMemoryIsTooSmall) {
  const std::string info = std::string(MCA_BINARY) + " info --json";
  {
    const test::Result r = test::shell("MCA_BACKEND=cuda-emulation " + info + " 2>/dev/null");
    ASSERT_EQ(r.code, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_EQ(j["backend"], "cuda-emulation");
    EXPECT_EQ(j["backend_runs_here"], true);
    // The default wall's arrays: 8.6 MB (docs/benchmarks.md, "Device memory").
    EXPECT_GT(j["gpu_memory_bytes"].get<double>(), 8e6);
    EXPECT_LT(j["gpu_memory_bytes"].get<double>(), 9e6);
    EXPECT_FALSE(j.contains("gpu_memory_full"));
  }
  {
    const test::Result r = test::shell("MCA_EMULATED_GPU_MEMORY_MB=1 MCA_BACKEND=cuda-emulation " + info + " 2>/dev/null");
    ASSERT_EQ(r.code, 0) << r.output;
    const auto j = nlohmann::json::parse(r.output);
    EXPECT_EQ(j["backend"], "cuda-emulation");  // (a name: it read "cuda-emulation (the scene does not fit ...)")
    EXPECT_EQ(j["backend_runs_here"], false);
    EXPECT_TRUE(j["gpu_memory_bytes"].is_null());
    EXPECT_EQ(j["gpu_memory_full"].get<std::string>().rfind("the GPU's memory is full: ", 0), 0u) << j.dump();
    EXPECT_NE(j["gpu_memory_full"].get<std::string>().find("free of 1 MB"), std::string::npos) << j.dump();
    EXPECT_EQ(j["automata"], 4800);  // described all the same
  }
  {
    const test::Result r = test::shell("MCA_EMULATED_GPU_MEMORY_MB=1 " + std::string(MCA_BINARY) + " info 2>&1");
    ASSERT_EQ(r.code, 0) << r.output;  // (a scene on the CPU: the emulated GPU's size is not used)
    EXPECT_EQ(r.output.find("gpu memory"), std::string::npos) << r.output;
  }
  // wall_3k fits in 4 MB, walls_12k does not.
  const test::Result r = test::shell("MCA_EMULATED_GPU_MEMORY_MB=4 " + std::string(MCA_BINARY) +
                                     " bench wall_3k walls_12k --backend cuda-emulation --steps 5 --repeats 1 --json "
                                     "2>/dev/null; echo rc=$?");
  const auto rc = r.output.rfind("rc=");
  ASSERT_NE(rc, std::string::npos) << r.output;
  EXPECT_EQ(r.output.substr(rc), "rc=2\n");
  const auto j = nlohmann::json::parse(r.output.substr(0, rc));
  ASSERT_EQ(j.size(), 1u) << r.output;
  EXPECT_EQ(j[0]["name"], "wall_3k");
  EXPECT_EQ(j[0]["steps_run_on"], "one core");
  EXPECT_EQ(j[0]["cuda_lattice"], "fused:3");
  const test::Result text = test::shell("MCA_EMULATED_GPU_MEMORY_MB=4 " + std::string(MCA_BINARY) +
                                        " bench wall_3k walls_12k --backend cuda-emulation --steps 5 --repeats 1 2>&1");
  EXPECT_EQ(text.code, 2);
  EXPECT_NE(text.output.find("error: benchmark 'walls_12k': the GPU's memory is full"), std::string::npos) << text.output;
}

// The emulation keeps its device arrays in the host's memory: the memory estimate and solver.max_memory_gb
// count them (a review ran a wall at 187 MB under a limit of 160 MB that mca info put at 141 MB). A limit
// between the two estimates refuses the emulation's run and lets the CPU's go.
TEST(CudaEmulation, TheEmulatedGpusArraysCountInTheMemoryEstimate) {
  const test::TempDir tmp;
  const double cpu_bytes = nlohmann::json::parse(test::run_mca("info --json --backend cpu").output)["memory_bytes"].get<double>();
  const auto emulated = nlohmann::json::parse(test::run_mca("info --json --backend cuda-emulation").output);
  const double gpu_bytes = emulated["gpu_memory_bytes"].get<double>();
  EXPECT_DOUBLE_EQ(emulated["memory_bytes"].get<double>(), cpu_bytes + gpu_bytes);
  const std::filesystem::path scene = tmp.path() / "capped.toml";
  std::ifstream in(scene_file("wall_ball.toml"));
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  text.replace(text.find("[solver]\n"), 9,
               fmt::format("[solver]\nmax_memory_gb = {:.6f}\n", (cpu_bytes + 0.5 * gpu_bytes) / 1e9));
  std::ofstream(scene) << text;
  const test::Result refused = test::run_mca("run " + scene.string() + " --steps 1 -q --no-vtk --backend cuda-emulation --out " +
                                             (tmp.path() / "emulated").string());
  EXPECT_EQ(refused.code, 2) << refused.output;
  EXPECT_NE(refused.output.find("the emulated GPU's arrays"), std::string::npos) << refused.output;
  EXPECT_NE(refused.output.find("over solver.max_memory_gb"), std::string::npos) << refused.output;
  const test::Result cpu = test::run_mca("run " + scene.string() + " --steps 1 -q --no-vtk --backend cpu --out " +
                                         (tmp.path() / "cpu").string());
  EXPECT_EQ(cpu.code, 0) << cpu.output;
}

// MCA_CUDA_SYNC alike (it took "true" or "yes" for off without a word).
TEST(CudaEmulation, ACudaSyncSettingThatIsNeitherZeroNorOneIsRefused) {
  for (const char* given : {"2", "yes", "true", " 1"}) {
    const ForceEnv sync("MCA_CUDA_SYNC", given);
    const std::string e = error_of([] { Engine::check_environment(); });
    EXPECT_NE(e.find(fmt::format("MCA_CUDA_SYNC = '{}': give 1", given)), std::string::npos) << e;
  }
  for (const auto& [given, on] : {std::pair{"", false}, {"0", false}, {"1", true}}) {
    const ForceEnv sync("MCA_CUDA_SYNC", given);
    EXPECT_EQ(cuda_sync_requested(), on) << given;
  }
  const test::Result r = test::shell("MCA_CUDA_SYNC=yes " + std::string(MCA_BINARY) + " info");
  EXPECT_EQ(r.code, 2) << r.output;
}

// MCA_PROFILE: 0 or empty is off, 1 on, anything else refused before anything is built.
TEST(CudaEmulation, AProfileSettingThatIsNeitherZeroNorOneIsRefused) {
  for (const char* given : {"2", "yes", "true", " 1", "01"}) {
    const ForceEnv profile("MCA_PROFILE", given);
    const std::string e = error_of([] { Engine::check_environment(); });
    EXPECT_NE(e.find(fmt::format("MCA_PROFILE = '{}'", given)), std::string::npos) << e;
  }
  for (const auto& [given, on] : {std::pair{"", false}, {"0", false}, {"1", true}}) {
    const ForceEnv profile("MCA_PROFILE", given);
    EXPECT_EQ(profile_requested(), on) << given;
  }
  const test::Result r = test::shell("MCA_PROFILE=0 " + std::string(MCA_BINARY) +
                                     " bench wall_3k --backend cuda-emulation --steps 5 --repeats 1 2>&1");
  EXPECT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output.find("profile"), std::string::npos) << r.output;
  const test::Result on = test::shell("MCA_PROFILE=1 " + std::string(MCA_BINARY) +
                                      " bench wall_3k --backend cuda-emulation --steps 5 --repeats 1 2>&1");
  EXPECT_NE(on.output.find("device arrays:"), std::string::npos) << on.output;
}

// Threads growing arrays at once against an emulated GPU's memory: together they take no more than it holds.
TEST(CudaEmulation, ThreadsGrowingArraysAtOnceStayWithinTheEmulatedGpusMemory) {
  const std::size_t limit = gpu::DeviceMemory::held() + 1000;
  std::atomic<int> taken{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < 8; ++t)
    threads.emplace_back([&] {
      for (int k = 0; k < 2000; ++k)
        if (gpu::DeviceMemory::add_within(7, limit)) ++taken;
    });
  for (std::thread& t : threads) t.join();
  EXPECT_EQ(taken.load(), 1000 / 7);
  EXPECT_LE(gpu::DeviceMemory::held(), limit);
  gpu::DeviceMemory::remove(static_cast<std::size_t>(taken.load()) * 7);
  EXPECT_FALSE(gpu::DeviceMemory::add_within(SIZE_MAX, limit));
}

// --- On a GPU (skipped, with the reason, without one: scripts/gpu_check.sh runs them on a GPU machine) ---

#define MCA_NEEDS_GPU()                                                     \
  do {                                                                      \
    std::string why;                                                        \
    if (cuda_device(&why).empty()) GTEST_SKIP() << "no GPU here: " << why; \
  } while (0)

constexpr auto kCuda = SolverDef::Backend::cuda;

TEST(CudaDevice, TheDefaultWallIsTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  EXPECT_GT(run_both(io::load_default_scene(), 6000, 1000, kCuda).breaks, 0);
}
TEST(CudaDevice, TheFusedAndSplitLatticeKernelsAreTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  // (fused:2 and fused:4 are the same kernel compiled with other register bounds: half the steps.)
  for (const char* how : {"fused", "split", "fused:2", "fused:4"}) {
    LatticeKernels kernels(how);
    const bool bounds = std::string(how).find(':') != std::string::npos;
    for (const SceneDef& s : {cubic_wall(), soft_jittered_cubic_wall()}) {
      SCOPED_TRACE(fmt::format("MCA_CUDA_LATTICE={}, {}", how, s.name));
      EXPECT_GT(run_both(s, bounds ? 1500 : 3000, bounds ? 500 : 1000, kCuda).breaks, 0);
    }
  }
  resumes_across(soft_jittered_cubic_wall(), kCuda, SolverDef::Backend::cpu, 900, 600);
}
TEST(CudaDevice, FewAndManyBreaksInAStepAreTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  few_and_many_breaks(kCuda);
}
TEST(CudaDevice, ProjectileCandidatesListedByTheLatticeKernelAreTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  EXPECT_GT(hail(kCuda), 8u);
}
TEST(CudaDevice, FourWallsAreTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  EXPECT_GT(run_both(four_walls(), 3000, 750, kCuda).breaks, 0);
}
TEST(CudaDevice, AVolumeFilledMeshIsTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  std::string why;
  const auto s = bunny(why);
  if (!s) GTEST_SKIP() << why;
  EXPECT_GT(run_both(*s, 6000, 1500, kCuda).breaks, 0);
}
TEST(CudaDevice, TheCowShellIsTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  std::string why;
  const auto s = cow(why);
  if (!s) GTEST_SKIP() << why;
  EXPECT_GT(run_both(*s, 10000, 500, kCuda).breaks, 0);
}
TEST(CudaDevice, GripsAndBallsAreTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  EXPECT_GT(run_both(pulled_bar(), 4000, 1000, kCuda).breaks, 0);
  run_both(test::loaded_cantilever(), 1500, 256, kCuda);
  EXPECT_GT(run_both(colliding_balls(), 8000, 50, kCuda).pairs, 0u);
  for (const auto lattice : {SolverDef::Lattice::cubic, SolverDef::Lattice::random})
    EXPECT_GT(run_both(held_anvil(lattice), 3000, 100, kCuda).projectile_contacts, 0u);
  EXPECT_GT(run_both(three_balls(), 3000, 100, kCuda).shared, 0u);
}
TEST(CudaDevice, AnObjectFarFromTheOriginIsTheCpusBitForBit) {
  MCA_NEEDS_GPU();
  far_from_origin_on(kCuda);
}
TEST(CudaDevice, TheDrawListIsTheHostSnapshots) {
  MCA_NEEDS_GPU();
  EXPECT_GT(draws_equal(io::load_default_scene(), {0, 4000}, kCuda).fragments, 10);
  std::string why;
  const auto shell = cow(why);
  if (!shell) GTEST_SKIP() << why;
  EXPECT_GT(draws_equal(*shell, {3000}, kCuda).triangles, 5000u);
}
// Its own suite: it needs OpenGL as well (NVIDIA's, for CUDA to share the buffers), which a GPU machine
// without the driver's graphics libraries lacks (scripts/gpu_check.sh reports it apart).
TEST(CudaDeviceGl, TheDrawListWrittenIntoTheRenderersBuffersDrawsTheSamePicture) {
  MCA_NEEDS_GPU();
  try {
    render::EglContext probe;
  } catch (const Error& e) {
    GTEST_SKIP() << "no OpenGL context here: " << e.what();
  }
  expect_shared_draw_is_the_hosts(io::load_default_scene(), 4000, render::DrawMode::cubes, kCuda);
  std::string why;
  const auto shell = cow(why);
  if (!shell) GTEST_SKIP() << why;
  expect_shared_draw_is_the_hosts(*shell, 3000, render::DrawMode::surface, kCuda);
}
TEST(CudaDevice, TheSortsScansAndBlockLaunchesAreTheirSerialResults) {
  MCA_NEEDS_GPU();
  EXPECT_EQ(cuda_primitives_check(), "");
}
TEST(CudaDevice, AnArrayLargerThanTheGpuIsRefusedWithTheFullGpusError) {
  MCA_NEEDS_GPU();
  EXPECT_EQ(cuda_memory_check(), "");
}

TEST(CudaDevice, AStateResumesAcrossBackendsWithTheSameBits) {
  MCA_NEEDS_GPU();
  resumes_across(io::load_default_scene(), SolverDef::Backend::cpu, kCuda, 3000, 1500);
  resumes_across(io::load_default_scene(), kCuda, SolverDef::Backend::cpu, 3000, 1500);
}

TEST(CudaDevice, TwoRunsAreEqual) {
  MCA_NEEDS_GPU();
  run_both(io::load_default_scene(), 6000, 3000, kCuda, kCuda);
}
// A free random-lattice block of concrete spinning at 50 rad/s about a tilted axis while it flies: its
// momentum and angular momentum stay (no outside force), and its energy within the CPU's conservation
// tests' bounds, on the backend given.
void free_block_keeps_momentum_and_energy(SolverDef::Backend backend) {
  SceneDef s = test::block_scene(6, 6, 6, 0.05, MaterialDef{});
  s.materials.clear();
  s.objects[0].material = "concrete";
  s.solver.lattice = SolverDef::Lattice::random;
  s.solver.backend = backend;
  Engine sim(s);
  const Model& m = sim.model();
  test::set_rigid_motion(sim, {1.0, -0.5, 0.25}, DVec3{0.3, 0.5, 0.8} * (50.0 / std::sqrt(0.98)));
  struct Momenta {
    DVec3 p, L;
  };
  const auto momenta = [&] {
    const State& q = sim.state();
    Momenta r{};
    for (std::size_t a = 0; a < q.x.size(); ++a) {
      r.p += q.v[a] * static_cast<double>(m.mass[a]);
      r.L += cross(q.x[a], q.v[a]) * static_cast<double>(m.mass[a]) + q.w[a] * static_cast<double>(m.inertia[a]);
    }
    return r;
  };
  const Momenta m0 = momenta();
  const double e0 = sim.energies().total();
  ASSERT_EQ(sim.advance(static_cast<int>(std::ceil(0.01 / static_cast<double>(m.dt)))).flags, kHealthy);
  const Momenta m1 = momenta();
  const double e1 = sim.energies().total();
  const DVec3 dp = m1.p - m0.p, dL = m1.L - m0.L;
  const double rp = std::sqrt(dot(dp, dp) / dot(m0.p, m0.p)), rL = std::sqrt(dot(dL, dL) / dot(m0.L, m0.L));
  std::printf("%s: over 10 ms momentum changed by %.3g of itself, angular momentum by %.3g, energy by %.3g; %lld "
              "links broken\n",
              sim.backend().name().c_str(), rp, rL, (e1 - e0) / e0, static_cast<long long>(sim.broken_links()));
  EXPECT_LT(rp, 1e-6);
  EXPECT_LT(rL, 1e-6);
  EXPECT_NEAR(e1, e0, 1e-3 * e0);
  EXPECT_EQ(sim.broken_links(), 0);
}
TEST(CudaEmulation, AFreeBlockKeepsItsMomentumAndEnergy) {
  free_block_keeps_momentum_and_energy(SolverDef::Backend::cuda_emulation);
}

TEST(CudaDevice, AFreeBlockKeepsItsMomentumAndEnergy) {
  MCA_NEEDS_GPU();
  free_block_keeps_momentum_and_energy(kCuda);
}

}  // namespace
}  // namespace mca
