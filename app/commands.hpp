#pragma once
// The `mca` subcommands, as functions the CLI (main.cpp) and the end-to-end tests call.
#include <atomic>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace mca::app {

struct RunOptions {
  std::optional<std::string> scene;    // path; none = the built-in default scene
  std::optional<std::string> out;      // default out/<scene name>
  int threads = 0;                     // 0 = all cores
  std::optional<double> duration;      // overrides output.duration
  std::optional<std::int64_t> steps;   // run exactly this many steps instead of a duration
  std::optional<std::uint64_t> seed;   // overrides solver.seed
  std::optional<std::string> backend;  // overrides solver.backend (auto, cpu, cuda, cuda-emulation)
  std::optional<int> checkpoint_every; // overrides output.checkpoint_every
  std::optional<bool> vtk;             // overrides output.vtk
  bool quiet = false;                  // no progress bar
  // --render: pictures and video into <out>/render/ (app/render_output.hpp).
  bool render = false;
  std::string render_size = "1280x720";
  std::string render_colour = "fragment";
  std::string render_draw;  // empty: surface when the scene has a mesh object, else cubes
  double render_fps = 0;               // 0: automatic
};

int run(const RunOptions& options);

struct ViewOptions {
  std::optional<std::string> scene;       // none = the built-in default scene
  int width = 1280, height = 720;
  int threads = 0;
  std::optional<int> frames;              // show this many frames, then exit; the simulation then advances one
                                          // output frame per shown frame (reproducible scripted runs)
  std::optional<std::string> screenshot;  // PNG of the last frame shown (with --frames)
  std::optional<std::string> script;      // timed shots: lines "TIME X Y"
  std::optional<std::string> backend;     // overrides solver.backend
  bool quiet = false;
};
// `mca view`: the live viewer (GLFW window). Throws mca::Error when there is no display.
int view(const ViewOptions& options);
// Worker threads for --threads N: all cores for 0, at most the cores there are; negative is an error.
int thread_count(int requested, std::string_view given_as = "--threads ");
// From now on SIGINT (Ctrl-C), SIGTERM and SIGHUP are recorded in the flag returned (0 while none came; one
// that came before a second call stays), for the command to stop at its next check; and a signal's name for
// messages ("SIGINT (Ctrl-C)").
const std::atomic<int>& catch_stop_signals();
std::string_view signal_name(int sig);
// Where a backend's steps run, for the progress lines: "2 threads" (the CPU backend's worker threads), "one
// core" (cuda-emulation steps on one whatever the threads), "the GPU" (cuda).
std::string steps_run_on(const std::string& backend, int threads);
// Renders the frames it adds when the run was rendered (render/render.json), unless no_render.
int resume(const std::string& out_dir, int threads, bool quiet, bool no_render = false,
           const std::optional<std::string>& backend = std::nullopt);
int info(const std::optional<std::string>& scene, bool json, const std::optional<std::string>& backend = std::nullopt);
int bench(const std::vector<std::string>& names, bool json, int threads, int repeats, int steps,
          const std::optional<std::string>& backend = std::nullopt);
// `mca bench --render`: frames per second of the offscreen renderer (1280x720) at one step per frame, on
// the wall benchmarks (cubes, spheres) and the mesh scenes (cubes, the bound surface's triangles).
int bench_render(const std::vector<std::string>& names, bool json, int threads, int frames,
                 const std::optional<int>& steps_per_frame = std::nullopt,
                 const std::optional<std::string>& backend = std::nullopt);
// Names of the built-in benchmark scenes (those run when none is named).
std::vector<std::string> bench_names(bool defaults_only = false);
// A backend's name for `mca info` and `mca bench`: the CPU backend's with why its instruction set is the one
// in use.
std::string backend_text(const std::string& name);

}  // namespace mca::app
