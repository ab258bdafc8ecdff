// `mca bench`: named benchmark scenes, timed as automaton-steps per second (median of repeats).
// Each repeat starts from the same snapshot taken after the ball has hit, so contacts and breaking are
// active during the timed steps.
#include <algorithm>
#include <filesystem>
#include <functional>
#include <chrono>
#include <iterator>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <thread>

#include "analysis/fragments.hpp"
#include "app/commands.hpp"
#include "core/text.hpp"
#include "io/json_text.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "render/camera.hpp"
#include "render/egl_context.hpp"
#include "render/renderer.hpp"
#include "render/snapshot.hpp"
#include "sim/engine.hpp"

namespace mca::app {
namespace {

struct BenchScene {
  std::string name;
  std::string description;
  SceneDef scene;
  int warmup_steps;  // steps before timing: the ball is in contact by then
  bool by_default = true;  // run when no names are given (the largest takes a minute and 2.7 GB: only by name)
};

// A concrete wall of nx x ny x nz automata (d = 0.05 m) on the paper's cubic lattice, standing on the
// ground, struck at its centre by a steel ball that starts just short of it.
SceneDef wall_scene(const std::string& name, int nx, int ny, int nz, int walls, double d) {
  SceneDef s;
  s.name = name;
  s.source = "<bench " + name + ">";
  s.solver.spacing = d;
  s.solver.lattice = SolverDef::Lattice::cubic;  // the paper's (wall_357k_random: the default's)
  s.heterogeneity.preset = "medium";
  heterogeneity_preset("medium", s.heterogeneity.shares);
  s.ground.enabled = true;
  const double wx = nx * d, wy = ny * d, wz = nz * d, gap = 6 * d;
  const double ball = std::max(3 * d, 0.1 * std::min(wx, wz));
  for (int k = 0; k < walls; ++k) {
    ObjectDef o;
    o.name = fmt::format("wall{}", k);
    o.size = {wx, wy, wz};
    o.position = {k * (wx + gap), 0, 0.5 * wz};
    s.objects.push_back(o);
    ProjectileDef p;
    p.name = fmt::format("ball{}", k);
    p.radius = ball;
    p.position = {k * (wx + gap), -0.5 * wy - ball - 0.05 * d, 0.5 * wz};  // 0.05 d from contact
    p.velocity = {0, 60, 0};
    s.projectiles.push_back(p);
  }
  s.output.duration = 0.01;
  return s;
}

// The same with softening links and spread link strengths (concrete with fracture_energy = 100 J/m^2 and
// weibull_modulus = 6): what those cost (docs/benchmarks.md).
SceneDef softening(SceneDef s) {
  MaterialDef c = *find_builtin_material("concrete");
  c.fracture_energy = 100;
  c.weibull_modulus = 6;
  s.materials.push_back(c);
  s.name += "_soft";
  s.source = "<bench " + s.name + ">";
  return s;
}

// The same on the jittered lattice (solver.lattice_jitter = 0.25): what a rest length per link costs.
SceneDef jittered(SceneDef s) {
  s.solver.lattice_jitter = 0.25;
  s.name += "_jitter";
  s.source = "<bench " + s.name + ">";
  return s;
}

// The same on the random lattice (solver.lattice = "random"): explicit links to the Voronoi neighbours.
SceneDef random_lattice(SceneDef s) {
  s.solver.lattice = SolverDef::Lattice::random;
  s.name += "_random";
  s.source = "<bench " + s.name + ">";
  return s;
}

std::vector<BenchScene> scenes() {
  return {
      {"wall_3k", "the paper's single wall: 30 x 4 x 25 automata, ball at 60 m/s", wall_scene("wall_3k", 30, 4, 25, 1, 0.05), 300},
      {"walls_12k", "the paper's four walls: 4 x (30 x 4 x 25) automata, a ball each", wall_scene("walls_12k", 30, 4, 25, 4, 0.05), 300},
      {"wall_357k", "a 101 x 35 x 101 lattice wall (357,035 automata), ball at 60 m/s", wall_scene("wall_357k", 101, 35, 101, 1, 0.02), 150},
      {"wall_357k_soft", "wall_357k with softening links and spread link strengths (fracture_energy 100, weibull_modulus 6)",
       softening(wall_scene("wall_357k", 101, 35, 101, 1, 0.02)), 150, false},
      {"wall_357k_jitter", "wall_357k on the jittered lattice (lattice_jitter 0.25)",
       jittered(wall_scene("wall_357k", 101, 35, 101, 1, 0.02)), 150, false},
      {"wall_357k_random", "wall_357k on the random lattice (lattice = \"random\")",
       random_lattice(wall_scene("wall_357k", 101, 35, 101, 1, 0.02)), 150, false},
      {"wall_2m", "a 202 x 35 x 404 lattice wall (2,856,280 automata; 2.7 GB while benchmarked), ball at 60 m/s", wall_scene("wall_2m", 202, 35, 404, 1, 0.02), 150, false},
  };
}

// Where a benchmark's steps ran, for --json: the backend, "2 threads" / "one core" / "the GPU", and the
// CUDA backend's lattice kernels as chosen (MCA_CUDA_LATTICE; null on the CPU).
nlohmann::json where_steps_ran(const std::string& backend, int threads) {
  const CudaLattice how = cuda_lattice();
  return {{"backend", backend},
          {"steps_run_on", steps_run_on(backend, threads)},
          {"cuda_lattice", backend.rfind("cpu", 0) == 0 ? nlohmann::json(nullptr)
                           : how.fused                  ? nlohmann::json(fmt::format("fused:{}", how.blocks))
                                                        : nlohmann::json("split")}};
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// One benchmark (`run`). An error (a GPU whose memory is full, a run that cannot go on) names the benchmark;
// with --json, the results of those before it are printed first (not lost with the error).
template <class F>
void run_named(const std::string& name, bool json, const nlohmann::json& done, F&& run) {
  try {
    run();
  } catch (const Error& e) {
    if (json && !done.empty()) fmt::print("{}\n", io::json_text(done));
    throw Error(fmt::format("benchmark '{}': {}", name, e.what()));
  } catch (...) {  // (the host out of memory: as it came, for its own message)
    if (json && !done.empty()) fmt::print("{}\n", io::json_text(done));
    throw;
  }
}

}  // namespace

int bench_render(const std::vector<std::string>& names, bool json, int threads_requested, int frames,
                 const std::optional<int>& steps_per_frame, const std::optional<std::string>& backend) {
  Engine::check_environment();
  if (frames < 1) throw Error(fmt::format("--frames {} must be at least 1", frames));
  const int steps = steps_per_frame.value_or(1);
  if (steps < 1) throw Error(fmt::format("--steps {} must be at least 1 (with --render: steps per frame)", steps));
  // Checked before the OpenGL context is made.
  const SolverDef::Backend backend_chosen = backend ? backend_from_name(*backend, "--backend") : SolverDef::Backend::automatic;
  const int threads = thread_count(threads_requested);
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  struct Case {
    std::string name;
    std::function<SceneDef()> scene;
    render::DrawMode draw;
    int warmup;
  };
  const auto builtin = [](const std::string& n) {
    return [n] {
      for (auto& b : scenes())
        if (b.name == n) return b.scene;
      return SceneDef{};
    };
  };
  const auto file = [](const std::string& f) {
    return [f] { return io::load_scene_file((std::filesystem::path(MCA_SCENES_DIR) / f).string()); };
  };
  const std::vector<Case> all = {
      {"wall_3k", builtin("wall_3k"), render::DrawMode::cubes, 300},
      {"walls_12k", builtin("walls_12k"), render::DrawMode::cubes, 300},
      {"wall_357k", builtin("wall_357k"), render::DrawMode::cubes, 150},
      {"wall_357k_spheres", builtin("wall_357k"), render::DrawMode::spheres, 150},
      {"bunny_cubes", file("bunny.toml"), render::DrawMode::cubes, 300},
      {"bunny_surface", file("bunny.toml"), render::DrawMode::surface, 300},
      {"cow_cubes", file("cow.toml"), render::DrawMode::cubes, 300},
      {"cow_surface", file("cow.toml"), render::DrawMode::surface, 300},
      {"armadillo_cubes", file("armadillo.toml"), render::DrawMode::cubes, 150},
      {"armadillo_surface", file("armadillo.toml"), render::DrawMode::surface, 150},
  };
  std::vector<Case> chosen;
  for (const auto& c : all)
    if (names.empty() || std::find(names.begin(), names.end(), c.name) != names.end()) chosen.push_back(c);
  for (const auto& n : names)
    if (std::none_of(all.begin(), all.end(), [&](const Case& c) { return c.name == n; })) {
      std::string list;
      for (const auto& c : all) list += (list.empty() ? "" : ", ") + c.name;
      throw Error(fmt::format("unknown render benchmark '{}'; they are: {}", n, list));
    }
  constexpr int W = 1280, H = 720;
  render::EglContext context;
  render::Renderer renderer;
  render::OffscreenTarget target(W, H);
  target.bind();
  if (!json)
    fmt::print("render benchmark: {}x{} offscreen, {} ({}), {}; {} per frame, {}\n", W, H,
               render::Renderer::gl_description(), context.source(), text::count(static_cast<std::size_t>(threads), "thread"),
               steps == 1 ? std::string("one step") : fmt::format("{} steps", steps),
               frames == 1 ? std::string("one frame") : fmt::format("median of {} frames", frames));
  nlohmann::json out = nlohmann::json::array();
  std::vector<std::uint8_t> pixels;
  for (const auto& c : chosen) {
    run_named(c.name, json, out, [&] {
      SceneDef scene;
      try {
        scene = c.scene();
      } catch (const Error& e) {
        // The mesh scenes need the paper's models (scripts/get_models.sh): the scene file's reader says so;
        // skip the case and go on. Other errors (MCA_SIMD, MCA_SWEEP, a bad model) stop the benchmark.
        fmt::print(stderr, "{}: skipped: {}\n", c.name, e.what());
        return;
      }
      if (backend) scene.solver.backend = backend_chosen;
      Engine sim(scene);
      const Model& m = sim.model();
      const auto framing = render::objects_box(m, sim.state());
      const auto cam = render::make_camera(sim.scene().camera, m, framing, float(W) / H, sim.scene().source);
      sim.advance(c.warmup);
      render::SnapshotOptions so;
      so.draw = c.draw;
      so.colour = render::ColourMode::fragment;
      std::vector<double> step_s, prep_s, draw_s, read_s, total_s;
      std::size_t drawn = 0, triangles = 0;
      bool shared = false;  // the list was written into the renderer's buffers (zero copy)
      std::string why_not;
      using clock = std::chrono::steady_clock;
      const auto secs = [](clock::time_point a, clock::time_point b) { return std::chrono::duration<double>(b - a).count(); };
      for (int f = 0; f < frames + 1; ++f) {  // the first frame warms the caches and the shaders up
        const auto t0 = clock::now();
        sim.advance(steps);
        const auto t1 = clock::now();
        // The backend's draw list where it builds one (the CUDA backend: written into the renderer's buffers
        // where CUDA can share them), else from its state.
        const auto snap = render::make_snapshot(m, sim.backend(), so, framing.origin, &renderer.draw_target(), &why_not);
        const auto t2 = clock::now();
        renderer.draw(snap, c.draw, cam, W, H);
        target.read_rgba(pixels);  // waits for the drawing: what a frame of `mca run --render` costs before the PNG
        const auto t3 = clock::now();
        if (f == 0) continue;
        step_s.push_back(secs(t0, t1));
        prep_s.push_back(secs(t1, t2));
        draw_s.push_back(secs(t2, t3));
        total_s.push_back(secs(t0, t3));
        drawn = snap.drawn_automata();
        triangles = snap.triangles();
        shared = snap.drawn_from_shared_buffers();
      }
      const double fps = 1.0 / median(total_s);
      if (json) {
        nlohmann::json j = {{"name", c.name}, {"draw", render::name(c.draw)},
                            {"steps_per_frame", steps}, {"automata", m.size()},
                            {"automata_drawn", drawn}, {"triangles", triangles}, {"frames", frames},
                            {"median_step_seconds", median(step_s)}, {"median_snapshot_seconds", median(prep_s)},
                            {"median_draw_seconds", median(draw_s)}, {"frames_per_second", fps}, {"zero_copy", shared},
                            {"zero_copy_note", why_not}};
        j.update(where_steps_ran(sim.backend().name(), threads));
        out.push_back(std::move(j));
      } else {
        fmt::print("{:<18} {:>8} automata {:>8} drawn {:>8} triangles  {} {:7.1f} ms  snapshot {:6.1f} ms  draw+read "
                   "{:6.1f} ms  {:6.2f} frames/s\n",
                   c.name, m.size(), drawn, triangles, steps == 1 ? "step" : "steps", 1e3 * median(step_s),
                   1e3 * median(prep_s), 1e3 * median(draw_s), fps);
        fmt::print("{:<18} backend {}; {}\n", "", sim.backend().name(),
                   shared                ? "drawn without a copy: the backend wrote the renderer's buffers"
                   : !why_not.empty()    ? why_not
                   : drawn + triangles == 0 ? "nothing drawn"
                                         : "drawn from the backend's list, copied");
      }
    });
  }
  if (json) fmt::print("{}\n", io::json_text(out));
  return 0;
}

std::vector<std::string> bench_names(bool defaults_only) {
  std::vector<std::string> n;
  for (const auto& s : scenes())
    if (s.by_default || !defaults_only) n.push_back(s.name);
  return n;
}

int bench(const std::vector<std::string>& names, bool json, int threads_requested, int repeats, int steps,
          const std::optional<std::string>& backend) {
  Engine::check_environment();  // a bad MCA_SIMD or MCA_BACKEND, before any model is built
  auto all = scenes();
  std::vector<BenchScene> chosen;
  if (names.empty())
    std::copy_if(all.begin(), all.end(), std::back_inserter(chosen), [](const BenchScene& b) { return b.by_default; });
  for (const auto& n : names) {
    auto it = std::find_if(all.begin(), all.end(), [&](const BenchScene& b) { return b.name == n; });
    if (it == all.end())
      throw Error(fmt::format("unknown benchmark '{}'; the benchmarks are: {}", n, fmt::join(bench_names(), ", ")));
    chosen.push_back(*it);
  }
  if (repeats < 1) throw Error(fmt::format("--repeats {} must be at least 1", repeats));
  if (steps < 1) throw Error(fmt::format("--steps {} must be at least 1", steps));
  const SolverDef::Backend backend_chosen = backend ? backend_from_name(*backend, "--backend") : SolverDef::Backend::automatic;
  const int threads = thread_count(threads_requested);
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  nlohmann::json out = nlohmann::json::array();
  bool first = true;
  for (auto& b : chosen) {
    run_named(b.name, json, out, [&] {
      if (backend) b.scene.solver.backend = backend_chosen;
      Engine sim(b.scene);
      if (!json && first) {
        const std::string name = sim.backend().name();
        const bool cpu = name.rfind("cpu", 0) == 0;
        const std::string used = "steps on " + steps_run_on(name, threads);
        // The CUDA backend's lattice kernels as chosen (cuda_lattice; a lattice with explicit links takes
        // the split ones whatever the choice).
        const CudaLattice how = cuda_lattice();
        const std::string lattice =
            cpu         ? std::string()
            : how.fused ? fmt::format(" (lattice kernels fused:{} where a lattice has no explicit links)", how.blocks)
                        : std::string(" (lattice kernels split)");
        fmt::print("machine: {} hardware threads, {}; backend {}{}; {}\n", std::thread::hardware_concurrency(), used,
                   backend_text(name), lattice,
                   repeats == 1 ? fmt::format("one run of {} step{}", steps, steps == 1 ? "" : "s")
                                : fmt::format("median of {} runs of {} step{} each", repeats, steps, steps == 1 ? "" : "s"));
      }
      first = false;
      sim.advance(b.warmup_steps);
      const State snapshot = sim.state();
      const std::size_t n = sim.model().size();
      std::vector<double> rates, walls;
      std::int64_t broken_before = snapshot.broken_by[0] + snapshot.broken_by[1], broken_after = 0;
      std::size_t contacts = 0;
      for (int r = 0; r < repeats; ++r) {
        sim.backend().upload(snapshot);
        const auto t0 = std::chrono::steady_clock::now();
        sim.advance(steps);
        const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        walls.push_back(wall);
        rates.push_back(static_cast<double>(n) * steps / wall);
        broken_after = sim.state().broken_by[0] + sim.state().broken_by[1];
        contacts = sim.state().contacts.size();
      }
      // The rate of the median run (of an even count, the mean of the two middle runs' times): steps over
      // median_wall_seconds, as the two figures printed beside each other must agree.
      const double med = static_cast<double>(n) * steps / median(walls);
      if (json) {
        nlohmann::json j = {{"name", b.name}, {"description", b.description}, {"automata", n},
                            {"links", sim.model().link_count()}, {"steps", steps}, {"repeats", repeats},
                            {"threads", threads}, {"median_wall_seconds", median(walls)},
                            {"automaton_steps_per_second", med}, {"all_automaton_steps_per_second", rates},
                            {"links_broken_during_timed_steps", broken_after - broken_before},
                            {"contact_pairs_at_end", contacts}};
        j.update(where_steps_ran(sim.backend().name(), threads));
        out.push_back(std::move(j));
      } else {
        fmt::print("{:<10} {:>8} automata {:>8} links  {} steps  {:.3f} s  {:7.2f} M automaton-steps/s  "
                   "(runs: {:.2f}; {} links broke in the timed steps, {} contact pairs)\n",
                   b.name, n, sim.model().link_count(), steps, median(walls), med / 1e6,
                   fmt::join(std::vector<double>([&] {
                               std::vector<double> m;
                               for (double r : rates) m.push_back(r / 1e6);
                               return m;
                             }()),
                             " "),
                   broken_after - broken_before, contacts);
      }
    });
  }
  if (json) fmt::print("{}\n", io::json_text(out));
  return 0;
}

}  // namespace mca::app
