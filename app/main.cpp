// The `mca` command: run, resume, info, bench.
#include <CLI/CLI.hpp>
#include <charconv>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string_view>
#include <new>
#include <fmt/format.h>

#include "app/commands.hpp"
#include "app/render_output.hpp"
#include "core/text.hpp"
#include "mca/error.hpp"

namespace {
// An integer option's text, checked before CLI11 converts it: a whole number from lo to hi, else a message
// with the text as typed and what to give (CLI11's own says only "Could not convert", and it took a number
// past 64 bits for the largest one).
CLI::Validator whole_number(std::int64_t lo, std::int64_t hi, std::string what) {
  return CLI::Validator(
      [=](std::string& text) {
        // (Spaces around it and a leading '+' are taken, as CLI11 took them.)
        const std::size_t first = text.find_first_not_of(" \t"), last = text.find_last_not_of(" \t");
        std::string_view t =
            first == std::string::npos ? std::string_view() : std::string_view(text).substr(first, last - first + 1);
        if (t.size() > 1 && t[0] == '+' && t[1] != '-') t.remove_prefix(1);
        std::int64_t v = 0;
        const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
        if (!t.empty() && ec == std::errc() && ptr == t.data() + t.size() && v >= lo && v <= hi) return std::string();
        return fmt::format("{} is not a whole number from {} to {}; give {}", text, lo, hi, what);
      },
      "");
}
constexpr std::int64_t kIntMax = std::numeric_limits<int>::max();
const CLI::Validator kThreads = whole_number(0, kIntMax, "0 (all cores) or a count of worker threads");
}  // namespace

int main(int argc, char** argv) {
  // A file that reaches the process's size limit (ulimit -f) must give a write error that names it (EFBIG),
  // not kill the run with SIGXFSZ mid-file.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"mca: fracture of heterogeneous materials with movable cellular automata"};
  app.require_subcommand(1);
  app.set_version_flag("--version", "mca 0.1.0");

  mca::app::RunOptions ro;
  std::string scene_path, out_dir;
  double duration = 0;
  std::int64_t steps = 0;
  std::string seed_text;
  int checkpoint_every = 0;
  auto* run = app.add_subcommand("run", "Run a scene (the built-in wall_ball scene if none is given)");
  // A scene path given empty ("" from an unset shell variable) is refused, not taken for the built-in scene.
  const CLI::Validator not_empty(
      [](std::string& p) {
        return p.empty() ? std::string("an empty scene path: give the path of a .toml file, or leave it out for "
                                       "the built-in scene")
                         : std::string();
      },
      "SCENE");
  run->add_option("scene", scene_path, "Scene file (TOML, see docs/scene-format.md)")->check(not_empty);
  auto* out_opt = run->add_option("--out", out_dir, "Output folder (default out/<scene name>, see docs/scene-format.md)");
  run->add_option("--threads", ro.threads, "Worker threads (0 = all cores)")
      ->check(kThreads);
  auto* dur_opt = run->add_option("--duration", duration, "Simulated time [s] (overrides output.duration)");
  auto* steps_opt = run->add_option("--steps", steps, "Run exactly this many steps")
                         ->check(whole_number(1, std::numeric_limits<std::int64_t>::max(), "a number of steps"));
  dur_opt->excludes(steps_opt);
  run->add_option("--backend", ro.backend,
                  "Where the step runs: auto (the default: an NVIDIA GPU where there is one, else the CPU; MCA_BACKEND "
                  "changes it), cpu, cuda (an NVIDIA GPU), cuda-emulation (the CUDA "
                  "backend's algorithm on one CPU core, for checking; slow); overrides solver.backend");
  auto* seed_opt = run->add_option("--seed", seed_text, "Seed of the strength classes (overrides solver.seed), 0 .. 2^64-1");
  auto* ck_opt = run->add_option("--checkpoint-every", checkpoint_every, "Write a checkpoint every N frames")
                      ->check(whole_number(0, kIntMax, "0 (none) or a number of frames"));
  bool no_vtk = false;
  run->add_flag("--no-vtk", no_vtk, "Do not write per-frame VTK files (stats and summary only)");
  run->add_flag("-q,--quiet", ro.quiet, "No progress output");
  auto* render_flag = run->add_flag("--render", ro.render,
                "Render each frame offscreen (OpenGL through EGL): render/frame_NNNNNN.png, video.mp4, contact_sheet.png "
                "and plots in the output folder");
  run->add_option("--render-size", ro.render_size, "Size of the rendered frames, WIDTHxHEIGHT (default 1280x720)")->needs(render_flag);
  run->add_option("--render-colour,--render-color", ro.render_colour,
                  "Colour of the automata: fragment (default), damage, class, group, stress, speed")->needs(render_flag);
  run->add_option("--render-draw", ro.render_draw,
                  "What is drawn: cubes, spheres, surface (the mesh objects' triangles; the default when the scene has one, "
                  "else cubes), links")->needs(render_flag);
  run->add_option("--render-fps", ro.render_fps, "Frame rate of the video (default: frames / 4, 10 to 30)")->needs(render_flag);

  std::string resume_dir;
  int resume_threads = 0;
  bool resume_quiet = false;
  auto* resume = app.add_subcommand("resume", "Continue a run from the newest checkpoint in its output folder");
  resume->add_option("dir", resume_dir, "Output folder of the run")->required();
  resume->add_option("--threads", resume_threads, "Worker threads (0 = all cores)")
      ->check(kThreads);
  resume->add_flag("-q,--quiet", resume_quiet, "No progress output");
  std::optional<std::string> resume_backend;
  resume->add_option("--backend", resume_backend, "Continue on this backend (auto, cpu, cuda, cuda-emulation): the same bits");
  bool resume_no_render = false;
  resume->add_flag("--no-render", resume_no_render,
                   "Do not render the frames it adds, though the run was started with --render");

  std::string info_scene;
  bool info_json = false;
  auto* info = app.add_subcommand("info", "Automata, links, time step, steps per frame and memory of a scene");
  info->add_option("scene", info_scene, "Scene file (default: the built-in scene)")->check(not_empty);
  info->add_flag("--json", info_json, "Machine-readable output");
  std::optional<std::string> info_backend;
  info->add_option("--backend", info_backend,
                   "Describe the scene on this backend (auto, cpu, cuda, cuda-emulation; overrides solver.backend)");

  mca::app::ViewOptions vo;
  std::string view_scene, view_size = "1280x720", view_screenshot, view_script;
  int view_frames = 0;
  auto* view = app.add_subcommand("view", "Live viewer: watch a scene break, shoot balls with the mouse (a window; "
                                          "keys in the README)");
  view->add_option("scene", view_scene, "Scene file (default: the built-in scene)")->check(not_empty);
  view->add_option("--size", view_size, "Window size, WIDTHxHEIGHT (default 1280x720)");
  view->add_option("--threads", vo.threads, "Worker threads (0 = all cores)")
      ->check(kThreads);
  view->add_option("--backend", vo.backend, "Where the step runs: auto, cpu, cuda, cuda-emulation (overrides solver.backend)");
  auto* frames_opt = view->add_option("--frames", view_frames, "Show this many frames (one output frame of the scene each), then exit")
                         ->check(whole_number(1, kIntMax, "a number of frames"));
  view->add_option("--screenshot", view_screenshot, "With --frames: write the last frame as PNG")->needs(frames_opt);
  view->add_option("--script", view_script, "Timed shots: lines 'TIME X Y' (simulated s; aim as shares of the window)");
  view->add_flag("-q,--quiet", vo.quiet, "No summary at the end");

  std::vector<std::string> bench_names;
  bool bench_json = false;
  int bench_threads = 0, bench_repeats = 5, bench_steps = 50;
  auto* bench = app.add_subcommand("bench", "Benchmarks: automaton-steps per second on named scenes");
  bench->add_option("names", bench_names,
                    fmt::format("Benchmarks to run: {} (default: {})", fmt::join(mca::app::bench_names(), ", "),
                                fmt::join(mca::app::bench_names(true), ", ")));
  bench->add_flag("--json", bench_json, "Machine-readable output");
  bench->add_option("--threads", bench_threads, "Worker threads (0 = all cores)")
      ->check(kThreads);
  auto* bench_repeats_opt = bench->add_option("--repeats", bench_repeats, "Timed runs per benchmark (the median is reported)")
                                 ->check(whole_number(1, kIntMax, "a number of timed runs"));
  auto* bench_steps_opt = bench->add_option("--steps", bench_steps, "Steps per timed run (with --render: per frame, default 1)")
                               ->check(whole_number(1, kIntMax, "a number of steps"));
  std::optional<std::string> bench_backend;
  bench->add_option("--backend", bench_backend, "Backend to measure: auto, cpu, cuda, cuda-emulation");
  bool bench_render = false;
  int bench_frames = 10;
  auto* bench_render_opt = bench->add_flag("--render", bench_render,
                  "Frames per second of the renderer (1280x720 offscreen, --steps per frame, 1 by default): wall_3k, walls_12k, "
                  "wall_357k, wall_357k_spheres, bunny_cubes, bunny_surface, cow_cubes, cow_surface, armadillo_cubes, "
                  "armadillo_surface");
  // (Each of --repeats and --frames belongs to one kind of benchmark: given to the other, it was ignored.)
  bench->add_option("--frames", bench_frames, "Frames timed per render benchmark (the median is reported)")
      ->check(whole_number(1, kIntMax, "a number of frames"))
      ->needs(bench_render_opt);
  bench_repeats_opt->excludes(bench_render_opt);

  // A command line that does not parse is a user error like any other: exit code 2 (CLI11's own codes
  // are 100 and up), 0 for --help and --version.
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (run->parsed()) {
      if (!scene_path.empty()) ro.scene = scene_path;
      if (out_opt->count()) ro.out = out_dir;  // given but empty is an error, not the default
      if (dur_opt->count()) ro.duration = duration;
      if (steps_opt->count()) ro.steps = steps;
      // (Given empty, it was taken as not given, while an empty --render-colour was refused.)
      if (run->get_option("--render-draw")->count() > 0 && ro.render_draw.empty())
        throw mca::Error(fmt::format("--render-draw is empty; give one of: {}", mca::render::draw_mode_names()));
      if (seed_opt->count()) {
        // Digits only and within 64 bits: "1e23" or 2^64 must not become another seed silently.
        std::uint64_t seed = 0;
        const char* end = seed_text.data() + seed_text.size();
        const auto [ptr, ec] = std::from_chars(seed_text.data(), end, seed);
        if (seed_text.empty() || ec != std::errc() || ptr != end)
          throw mca::Error(fmt::format("--seed {} is not a whole number from 0 to 18446744073709551615", seed_text));
        ro.seed = seed;
      }
      if (ck_opt->count()) ro.checkpoint_every = checkpoint_every;
      if (no_vtk) ro.vtk = false;
      return mca::app::run(ro);
    }
    if (view->parsed()) {
      if (!view_scene.empty()) vo.scene = view_scene;
      std::tie(vo.width, vo.height) = mca::app::parse_render_size(view_size, "--size");
      if (frames_opt->count()) vo.frames = view_frames;
      // (Given empty, it wrote nothing without a word.)
      if (view->get_option("--screenshot")->count() > 0) {
        if (view_screenshot.empty()) throw mca::Error("--screenshot is empty; give a file name ending in .png");
        if (mca::text::lower(std::filesystem::path(view_screenshot).extension().string()) != ".png")
          throw mca::Error(fmt::format("--screenshot {}: the screenshot is written as PNG; give a name ending in .png",
                                       view_screenshot));
        vo.screenshot = view_screenshot;
      }
      if (!view_script.empty()) vo.script = view_script;
      return mca::app::view(vo);
    }
    if (resume->parsed())
      return mca::app::resume(resume_dir, resume_threads, resume_quiet, resume_no_render, resume_backend);
    if (info->parsed())
      return mca::app::info(info_scene.empty() ? std::nullopt : std::optional<std::string>(info_scene), info_json,
                            info_backend);
    if (bench->parsed() && bench_render)
      return mca::app::bench_render(bench_names, bench_json, bench_threads, bench_frames,
                                    bench_steps_opt->count() ? std::optional<int>(bench_steps) : std::nullopt, bench_backend);
    if (bench->parsed())
      return mca::app::bench(bench_names, bench_json, bench_threads, bench_repeats, bench_steps, bench_backend);
  } catch (const mca::Error& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {
    // The last resort: every allocation sized by the input is checked first (solver.max_memory_gb, the
    // machine's memory, the sizes of mesh files), so one that fails here escaped those checks.
    fmt::print(stderr, "error: mca ran out of memory (std::bad_alloc): this scene or a file it reads needs more "
                       "memory than the machine has, or than the process may use (ulimit -v), and no check caught it "
                       "first; increase solver.spacing or use smaller meshes, and please report the scene\n");
    return 1;
  } catch (const std::exception& e) {
    fmt::print(stderr, "error: {}\n", e.what());
    return 1;
  }
  return 0;
}
