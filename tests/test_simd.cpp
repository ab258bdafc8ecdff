// The CPU step's kernels (backend/cpu/lattice_kernels.*): every instruction set and thread count gives the
// same state bit for bit, and the direction-blocked layout gives the forces of a brute-force reference
// that finds the links by distance and adds them up in double.
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <string>
#include <tbb/global_control.h>

#include "backend/cpu/lattice_kernels.hpp"
#include "backend/step_kernels.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"
#include "mesh_fixtures.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

// Sets MCA_SIMD for the life of the object (then restores what was there).
class ForceSimd : public test::ForceEnv {
 public:
  explicit ForceSimd(const char* set) : ForceEnv("MCA_SIMD", set) {}
};

std::vector<const cpu::Kernels*> kernel_sets() {
  const cpu::Kernels* sets[4];
  const int count = cpu::available_kernels(sets);
  return {sets, sets + count};
}

TEST(Simd, EveryInstructionSetAndThreadCountGivesTheStoredHash) {
  // The default scene's stored hash (Determinism.TheDefaultSceneGivesItsStoredHash), on every set this
  // processor runs (at least scalar and SSE2; AVX2 and AVX-512 where present) and on 1 and 2 threads.
  const auto sets = kernel_sets();
  ASSERT_GE(sets.size(), 2u);
  for (const cpu::Kernels* k : sets)
    for (int threads : {1, 2}) {
      ForceSimd force(k->name);
      tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
      Engine sim(test::cubic_wall_scene());
      EXPECT_EQ(sim.backend().name(), std::string("cpu-") + k->name);
      ASSERT_EQ(sim.advance(3000).flags, kHealthy);
      EXPECT_GT(sim.state().broken_by[0] + sim.state().broken_by[1], 0);
      EXPECT_FALSE(sim.state().contacts.empty());
      const std::uint64_t h = state_hash(sim.state());
      std::printf("%-6s %d thread(s): state_hash %016llx\n", k->name, threads, static_cast<unsigned long long>(h));
      EXPECT_EQ(h, 0xd7e529ebcd8f63bfull) << k->name << " on " << threads << " threads";
    }
}

// Sets MCA_SWEEP for the life of the object (then restores what was there).
class ForceSweep : public test::ForceEnv {
 public:
  explicit ForceSweep(const char* how) : ForceEnv("MCA_SWEEP", how) {}
};

// The state after `steps` steps of s on 1 and 2 threads, with the lattice's kernels one at a time
// (MCA_SWEEP=passes) and chunk by chunk (fused): [threads - 1][fused].
struct SweepRuns {
  std::uint64_t hash[2][2] = {};
  std::size_t automata = 0, broken = 0;
};
SweepRuns sweep_runs(const SceneDef& s, int steps) {
  SweepRuns r;
  for (int threads : {1, 2})
    for (int fused : {0, 1}) {
      ForceSweep how(fused ? "fused" : "passes");
      tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
      Engine sim(s);
      EXPECT_EQ(sim.advance(steps).flags, kHealthy);
      r.automata = sim.model().size();
      r.broken = sim.state().broken_by[0] + sim.state().broken_by[1];
      r.hash[threads - 1][fused] = state_hash(sim.state());
    }
  return r;
}

void expect_same_sweeps(const SweepRuns& r) {
  EXPECT_EQ(r.hash[0][1], r.hash[0][0]) << "1 thread: the sweep against one pass at a time";
  EXPECT_EQ(r.hash[1][1], r.hash[1][0]) << "2 threads: the sweep against one pass at a time";
  EXPECT_EQ(r.hash[1][1], r.hash[0][1]) << "the sweep on 2 threads against 1";
}

// A scene of 5 cm automata of medium heterogeneity on the ground, to be struck by balls (add_ball).
SceneDef struck_scene(const std::string& name) {
  SceneDef s;
  s.name = name;
  s.source = "<test>";
  s.solver.spacing = 0.05;
  s.solver.lattice = SolverDef::Lattice::cubic;
  s.heterogeneity.preset = "medium";
  heterogeneity_preset("medium", s.heterogeneity.shares);
  s.ground.enabled = true;
  s.output.duration = 0.01;
  return s;
}

void add_ball(SceneDef& s, const std::string& name, double radius, Vec3d position, Vec3d velocity) {
  ProjectileDef p;
  p.name = name;
  p.radius = radius;
  p.position = position;
  p.velocity = velocity;
  s.projectiles.push_back(p);
}

// The CPU step runs the lattice's kernels chunk by chunk in one sweep, in regions of chunks whose
// boundaries are joined by whichever thread gets there second (cpu_backend.cpp, lattice_sweep). Whatever
// the grouping, it must give the bits of one kernel at a time over all chunks (MCA_SWEEP=passes): here on
// a scene of over 20,000 automata (eleven chunks; on 2 threads three regions, on any machine: the regions
// follow the threads allowed, not the processor's) with six struck walls, a rotated box, a sphere (other
// strides, neighbours gathered) and a shell of explicit links, while links break and contacts form.
TEST(Simd, TheSweepGivesTheResultsOfOnePassAtATime) {
  test::TempDir t;
  test::write_mesh_file(t.path() / "shell.off", test::sphere_mesh(0.3, 3));
  SceneDef s = struck_scene("sweep");
  double x = 0;
  for (int k = 0; k < 6; ++k, x += 2.0) {
    ObjectDef o;
    o.name = "wall" + std::to_string(k);
    o.size = {1.5, 0.2, 1.25};
    o.position = {x, 0, 0.625};
    s.objects.push_back(o);
    add_ball(s, "ball" + std::to_string(k), 0.15, {x, -0.1 - 0.15 - 0.0025, 0.625}, {0, 60, 0});
  }
  ObjectDef box;
  box.name = "box";
  box.size = {0.6, 0.5, 0.4};
  box.position = {x, 0, 1.0};
  box.rotation = {10, 20, 30};
  box.velocity = {0, 0, -3};
  s.objects.push_back(box);
  ObjectDef ball;
  ball.name = "sphere";
  ball.shape = Shape::sphere;
  ball.radius = 0.4;
  ball.position = {x + 2.0, 0, 0.41};
  ball.rotation = {0, 0, 45};
  s.objects.push_back(ball);
  ObjectDef shell;
  shell.name = "shell";
  shell.shape = Shape::mesh;
  shell.mesh = (t.path() / "shell.off").string();
  shell.fill = MeshFill::surface;
  shell.position = {x + 4.0, 0, 1.0};
  shell.velocity = {0, 0, -20};
  s.objects.push_back(shell);
  const SweepRuns r = sweep_runs(s, 400);
  EXPECT_GT(r.automata, 20480u);
  EXPECT_GT(r.broken, 0u);
  expect_same_sweeps(r);
}

// Sheets of 100 x 50 automata: their links along z span 5,000 automata, three chunks. Two layers are five
// chunks, too few for two regions: forced to sweep on 2 threads they sweep on one. Six layers are fifteen
// chunks, two regions of at least seven, joined across three chunks.
TEST(Simd, TheSweepOfLinksSpanningSeveralChunks) {
  for (const int layers : {2, 6}) {
    SCOPED_TRACE(layers);
    SceneDef s = struck_scene("sheet");
    ObjectDef sheet;
    sheet.name = "sheet";
    sheet.size = {5.0, 2.5, 0.05 * layers};
    sheet.position = {0, 0, 0.025 * layers};
    s.objects.push_back(sheet);
    add_ball(s, "ball", 0.2, {0, 0, 0.05 * layers + 0.203}, {0, 0, -80});
    const SweepRuns r = sweep_runs(s, 300);
    EXPECT_EQ(r.automata, 5000u * layers);
    EXPECT_GT(r.broken, 1000u);
    expect_same_sweeps(r);
  }
}

TEST(Simd, AnUnknownSweepIsAClearError) {
  ForceSweep how("fast");
  const std::string e = test::error_of([] { Engine sim(test::cubic_wall_scene()); });
  EXPECT_NE(e.find("MCA_SWEEP=fast"), std::string::npos) << e;
  EXPECT_NE(e.find("passes"), std::string::npos) << e;
  // Any case, and empty as unset (as MCA_SIMD).
  for (const char* ok : {"Passes", "FUSED", "auto", ""}) {
    ForceSweep fine(ok);
    EXPECT_EQ(test::error_of([] { Engine sim(test::cubic_wall_scene()); }), "") << "MCA_SWEEP=" << ok;
  }
}

TEST(Simd, AnUnknownOrMissingInstructionSetIsAClearError) {
  {
    ForceSimd force("avx9");
    try {
      Engine sim(test::cubic_wall_scene());
      FAIL() << "MCA_SIMD=avx9 was accepted";
    } catch (const Error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("MCA_SIMD"), std::string::npos) << what;
      EXPECT_NE(what.find("avx9"), std::string::npos) << what;
      EXPECT_NE(what.find("scalar"), std::string::npos) << what;  // what it can use instead
    }
  }
  if (kernel_sets().size() < 4) {  // a processor without AVX-512 names the sets it has
    ForceSimd force("avx512");
    EXPECT_THROW({ Engine sim(test::cubic_wall_scene()); }, Error);
  }
}

// Objects that are not one box: a rotated box, a sphere and two boxes of different materials that touch
// (so there are links between groups, blocks that straddle objects, and contacts), no ground.
SceneDef mixed_objects() {
  const double d = 0.01;
  MaterialDef a = test::test_material(30e9, 0.2, 2400), b = test::test_material(10e9, 0.3, 1800);
  a.name = "a";
  b.name = "b";
  a.damping_time = 2e-7;  // dashpots on, to be compared too
  b.damping_time = 5e-7;
  SceneDef s = test::block_scene(1, 1, 1, d, a);
  s.materials.push_back(b);
  s.solver.gravity = {0, 0, -9.81};
  s.solver.link_damping = 0.05;
  s.objects.clear();
  ObjectDef tilted;
  tilted.name = "tilted";
  tilted.material = "a";
  tilted.size = {7 * d, 5 * d, 9 * d};
  tilted.rotation = {20, 35, 10};
  s.objects.push_back(tilted);
  ObjectDef ball;
  ball.name = "ball";
  ball.material = "b";
  ball.shape = Shape::sphere;
  ball.radius = 3.3 * d;
  ball.position = {0.2, 0, 0};
  s.objects.push_back(ball);
  ObjectDef left, right;
  left.name = "left";
  left.material = "a";
  left.size = {5 * d, 4 * d, 3 * d};
  left.position = {0, 0.2, 0};
  right = left;
  right.name = "right";
  right.material = "b";
  right.position = {5 * d, 0.2, 0};  // face to face with `left` (pressed into it by the caller)
  s.objects.push_back(left);
  s.objects.push_back(right);
  return s;
}

struct Reference {
  std::vector<DVec3> f, t;
  std::vector<double> f_scale, t_scale;  // sums of the magnitudes of what was added (for the tolerance)
  std::size_t links = 0, touching = 0;
};

// The first step's forces and torques, from an explicit list of links found by distance: two automata of
// one object at the lattice spacing d (diagonals are at 1.41 d) are linked, along the axis their direction
// falls on (the axes of each object are the directions of the links it has, grouped by angle).
Reference brute_force(const Model& m, const State& s) {
  const std::size_t n = m.size();
  const float d = m.spacing, area = d * d;
  Reference r;
  r.f.assign(n, DVec3{});
  r.t.assign(n, DVec3{});
  r.f_scale.assign(n, 0.0);
  r.t_scale.assign(n, 0.0);
  struct Link {
    std::uint32_t i, j;
    int axis;
    LinkGeometry g;
  };
  std::vector<Link> links;
  std::vector<std::vector<DVec3>> axes(m.object_names.size());
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j) {
      if (m.object[i] != m.object[j]) continue;
      const DVec3 e = m.position0[j] - m.position0[i];
      const double len = std::sqrt(dot(e, e));
      if (std::fabs(len - d) > 1e-3 * d) continue;
      const DVec3 u = e * (1.0 / len);
      auto& ax = axes[m.object[i]];
      int axis = -1;
      for (std::size_t k = 0; k < ax.size(); ++k)
        if (std::fabs(dot(u, ax[k])) > 0.9) axis = static_cast<int>(k);
      if (axis < 0) {
        axis = static_cast<int>(ax.size());
        ax.push_back(u);
      }
      EXPECT_LT(axis, 3);
      links.push_back({i, j, axis, link_geometry(s.x[i], s.x[j], d, 1.0f / d)});
    }
  r.links = links.size();
  // Many-body terms: lambda theta of each automaton from the mean strain of its links along each axis.
  std::vector<std::array<float, 3>> sum(n, {0, 0, 0}), cnt(n, {0, 0, 0});
  for (const Link& l : links)
    for (std::uint32_t a : {l.i, l.j}) {
      sum[a][l.axis] += l.g.eps;
      cnt[a][l.axis] += 1.0f;
    }
  std::vector<float> lam_theta(n);
  for (std::size_t a = 0; a < n; ++a) {
    const GroupParams& g = m.groups[m.group[a]];
    float ff[4];
    free_axis_factors(g.lame_lambda, g.shear_modulus, ff);
    lam_theta[a] = g.lame_lambda * volumetric_strain(sum[a].data(), cnt[a].data(), ff);
  }
  auto add = [&](std::uint32_t a, Vec3 f, Vec3 t) {
    r.f[a] += DVec3{f.x, f.y, f.z};
    r.t[a] += DVec3{t.x, t.y, t.z};
    r.f_scale[a] += length(f);
    r.t_scale[a] += length(t);
  };
  for (const Link& l : links) {
    const GroupParams &gi = m.groups[m.group[l.i]], &gj = m.groups[m.group[l.j]];
    const float G = harmonic(gi.shear_modulus, gj.shear_modulus);
    const float P_i = lam_theta[l.i] * (cnt[l.i][l.axis] == 1.0f ? 1.0f : 0.5f);
    const float P_j = lam_theta[l.j] * (cnt[l.j][l.axis] == 1.0f ? 1.0f : 0.5f);
    LinkInputT<float> in;
    in.g = {l.g.n, d * (1.0f + l.g.eps), l.g.eps};
    in.area = area;
    in.sigma = 2.0f * G * l.g.eps + P_i + P_j;
    in.kt = kShearFactor * G * area / d;
    in.kt_slope = 0.0f;
    const LinkDashpots dp = link_dashpots(link_normal_stiffness(G, gi.lame_lambda, gj.lame_lambda, area, d), m.mass[l.i],
                                          m.mass[l.j], 0.5f * (gi.damping_time + gj.damping_time), m.link_damping);
    in.damp_normal = dp.normal;
    in.damp_tangential = dp.tangential;
    in.dv = delta(s.v[l.i], s.v[l.j]);
    in.wi = to_vec3(s.w[l.i]);
    in.wj = to_vec3(s.w[l.j]);
    in.ut = Vec3{};  // no shear displacement yet (checked by the caller)
    in.dt = m.dt;
    const LinkOutputT<float> o = link_force(in);
    const Vec3 torque = cross(l.g.n, o.force_i * (0.5f * d)) * (1.0f + l.g.eps);
    add(l.i, o.force_i, torque);
    add(l.j, -o.force_i, torque);
  }
  // Gravity, and contacts between every two automata that are not linked, by the contact law of every
  // backend (pair_contact: as spheres, or as faces where their free sides face each other), from the state's
  // arrays.
  for (std::uint32_t a = 0; a < n; ++a) add(a, m.gravity * m.mass[a], Vec3{});
  std::vector<double> x[3], v[3], w[3];
  std::vector<float> q[4];
  for (int c = 0; c < 3; ++c) x[c].resize(n), v[c].resize(n), w[c].resize(n);
  for (auto& c : q) c.resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    x[0][a] = s.x[a].x, x[1][a] = s.x[a].y, x[2][a] = s.x[a].z;
    v[0][a] = s.v[a].x, v[1][a] = s.v[a].y, v[2][a] = s.v[a].z;
    w[0][a] = s.w[a].x, w[1][a] = s.w[a].y, w[2][a] = s.w[a].z;
    q[0][a] = s.q[a].w, q[1][a] = s.q[a].x, q[2][a] = s.q[a].y, q[3][a] = s.q[a].z;
  }
  ContactPassView cv;
  cv.m = m.view();
  cv.px = x[0].data(), cv.py = x[1].data(), cv.pz = x[2].data();
  cv.vx = v[0].data(), cv.vy = v[1].data(), cv.vz = v[2].data();
  cv.wx = w[0].data(), cv.wy = w[1].data(), cv.wz = w[2].data();
  cv.qw = q[0].data(), cv.qx = q[1].data(), cv.qy = q[2].data(), cv.qz = q[3].data();
  cv.zeta_pair = m.zeta_pair.data();
  cv.zeta_pair_held = m.zeta_pair_held.empty() ? nullptr : m.zeta_pair_held.data();
  cv.dt = m.dt;
  for (std::uint32_t i = 0; i < n; ++i)
    for (std::uint32_t j = i + 1; j < n; ++j) {
      if (m.object[i] == m.object[j]) {
        const DVec3 e = m.position0[j] - m.position0[i];
        if (std::fabs(std::sqrt(dot(e, e)) - d) < 1e-3 * d) continue;  // linked
      }
      ContactPair cp{i, j, {}};
      const ContactOut o = pair_contact(cv, cp);
      if (!o.on) continue;
      add(i, o.f, o.ti);
      add(j, -o.f, o.tj);
      ++r.touching;
    }
  return r;
}

TEST(Simd, DirectionBlockedLayoutGivesTheForcesOfAnExplicitLinkList) {
  const SceneDef scene = mixed_objects();
  for (const cpu::Kernels* k : kernel_sets()) {
    ForceSimd force(k->name);
    Engine start(scene);
    const Model& m = start.model();
    // Every automaton displaced by up to 0.2 % of d and set moving and turning at random, so every link
    // is strained, sheared and damped on the first step.
    State s = start.state();
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    for (std::size_t a = 0; a < m.size(); ++a) {
      s.x[a] += DVec3{u(rng), u(rng), u(rng)} * (2e-3 * m.spacing);
      s.v[a] = DVec3{u(rng), u(rng), u(rng)} * 0.1;
      s.w[a] = DVec3{u(rng), u(rng), u(rng)} * 10.0;
      if (m.object_names[m.object[a]] == "right") s.x[a].x -= 0.01 * m.spacing;  // 12 contacts with `left`
    }
    for (const Vec3& ut : s.link_ut) ASSERT_EQ(dot(ut, ut), 0.0f);
    const Reference ref = brute_force(m, s);
    EXPECT_EQ(ref.links, m.link_count());
    EXPECT_GE(ref.touching, 12u) << "the two boxes should touch";
    Engine sim(scene, s);
    ASSERT_EQ(sim.advance(1).flags, kHealthy);
    const State& after = sim.state();
    double worst_f = 0, worst_t = 0;
    for (std::size_t a = 0; a < m.size(); ++a) {
      const DVec3 df = DVec3{after.f[a].x, after.f[a].y, after.f[a].z} - ref.f[a];
      const DVec3 dt = DVec3{after.t[a].x, after.t[a].y, after.t[a].z} - ref.t[a];
      worst_f = std::max(worst_f, std::sqrt(dot(df, df)) / ref.f_scale[a]);
      if (ref.t_scale[a] > 0) worst_t = std::max(worst_t, std::sqrt(dot(dt, dt)) / ref.t_scale[a]);
    }
    std::printf("%-6s %zu automata, %zu links, %zu touching pairs: largest force difference %.2g, torque %.2g "
                "(shares of the sum of the magnitudes added)\n",
                k->name, m.size(), ref.links, ref.touching, worst_f, worst_t);
    EXPECT_LT(worst_f, 1e-5) << k->name;
    EXPECT_LT(worst_t, 1e-5) << k->name;
  }
}

// The automata pass marks the automata near each projectile, and the next projectile pass tests only
// those. Twelve balls (more than the 8 bits of a mark: balls 0 and 8, 1 and 9... share one) hit a wall
// from both sides; a twin whose marks are dropped every step (an upload resets them, so its projectile
// pass tests every automaton) must stay bitwise equal.
TEST(Simd, ProjectileMarksMissNoContact) {
  SceneDef s = test::cubic_wall_scene();
  s.objects[0].size = {0.8, 0.2, 0.6};
  s.objects[0].position = {0, 0, 0.3};
  s.projectiles.clear();
  for (int k = 0; k < 12; ++k) {
    ProjectileDef p;
    p.name = "ball" + std::to_string(k);
    p.radius = 0.04 + 0.005 * (k % 3);
    const double side = k % 2 ? 1.0 : -1.0;
    p.position = {-0.3 + 0.05 * k, side * (0.1 + p.radius + 0.002), 0.1 + 0.04 * (k % 5)};
    p.velocity = {k % 3 == 0 ? 5.0 : 0.0, -side * (40.0 + 5 * k), 0};
    p.kinematic = k == 5;
    s.projectiles.push_back(p);
  }
  s.output.frame_rate = 1000;
  Engine marked(s), scanned(s);
  std::size_t touching = 0;  // projectile-automaton contacts, summed over the steps
  for (int step = 0; step < 600; ++step) {
    scanned.backend().upload(scanned.state());
    ASSERT_EQ(scanned.advance(1).flags, kHealthy);
    ASSERT_EQ(marked.advance(1).flags, kHealthy);
    for (const auto& p : marked.state().projectiles) touching += p.contacts.size();
  }
  std::printf("%zu projectile contacts over 600 steps\n", touching);
  EXPECT_GT(touching, 1000u) << "the balls should hit the wall";
  EXPECT_GT(marked.state().broken_by[0] + marked.state().broken_by[1], 0);
  EXPECT_EQ(state_hash(marked.state()), state_hash(scanned.state()));
}

}  // namespace
}  // namespace mca
