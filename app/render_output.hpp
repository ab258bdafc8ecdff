#pragma once
// What `mca run --render` writes into <out>/render/: frame_NNNNNN.png per output frame, video.mp4 (through
// ffmpeg) and contact_sheet.png, then the plots of tools/plot_run.py. Only reads the state.
#include <chrono>
#include <cstdint>
#include <atomic>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <vector>
#include <string>

#include "analysis/fragments.hpp"
#include "io/output_files.hpp"
#include "render/camera.hpp"
#include "render/image.hpp"
#include "render/snapshot.hpp"
#include "sim/engine.hpp"

namespace mca::render {
class EglContext;
class Renderer;
class OffscreenTarget;
}  // namespace mca::render

namespace mca::app {

struct RenderOptions {
  int width = 1280, height = 720;
  render::ColourMode colour = render::ColourMode::fragment;
  render::DrawMode draw = render::DrawMode::cubes;
  double fps = 0;  // of the video; 0: the frames / 4, in [10, 30] (the default scene's video lasts 3 s)
  bool plots = true;
};

// The options of a rendered run, kept as render/render.json so that `mca resume` renders the frames it
// adds as the run began. load_render_options returns nothing when the run was not rendered, and throws
// mca::Error naming the file when it is damaged.
void save_render_options(const std::filesystem::path& out_dir, const RenderOptions& options);
std::optional<RenderOptions> load_render_options(const std::filesystem::path& out_dir);

// "1280x720" -> width, height; throws mca::Error for anything else (zero, negative, huge, not WxH).
// `option` names the option in messages (mca view's is --size).
std::pair<int, int> parse_render_size(const std::string& text, const std::string& option = "--render-size");

// Checks a render size (each side 16 to 8192 pixels). Throws mca::Error naming the option and the fix.
void check_render_size(int width, int height, const std::string& option = "--render-size");

// The offscreen renderer of a run: the camera of the scene's [camera] (or framed automatically) fixed at
// frame 0 of `sim`.
class RenderOutput {
 public:
  // Makes the OpenGL context, the camera and the render/ folder (emptied of an earlier run's frames and
  // video); throws mca::Error before anything is written when any of them fails. `frames`: the output
  // frames the run will write after frame 0 (for the contact sheet and the video's frame rate). The camera
  // is framed on the model's starting state. A resumed run passes `first_frame`, the frames already
  // written: those PNGs are kept and go into the video and the contact sheet again (the later ones are
  // removed, as the run writes them again). `stop`, where given, is the run's stop signal (catch_stop_signals):
  // once it is set, ffmpeg is not waited for (the video of a stopped run is made by its resume).
  // The pictures of an earlier session it replaces (its frames from first_frame on, its video and sheet) are
  // set aside in `removal`, which the session commits once it is under way.
  RenderOutput(const std::filesystem::path& dir, const Engine& sim, const RenderOptions& options, std::int64_t frames,
               bool quiet, std::int64_t first_frame, const std::atomic<int>* stop, io::StagedRemoval& removal);
  ~RenderOutput();
  RenderOutput(const RenderOutput&) = delete;
  RenderOutput& operator=(const RenderOutput&) = delete;

  // A resumed run whose checkpoint's own PNG was gone or unreadable: draws it again from the checkpoint's
  // state, into the video after the frames before it (before any later frame); else nothing.
  void draw_checkpoint_frame(const State& state);
  // Renders frame `frame` (0 = the initial state) to render/frame_NNNNNN.png and the video.
  void write_frame(std::int64_t frame, const State& state, const analysis::Fragments& fragments);
  // Finishes the video and writes the contact sheet and the plots (after summary.json and fragments.csv).
  void finish();
  // Whether finish() stopped ffmpeg on the stop signal (the video is not written).
  bool video_stopped() const { return video_stopped_; }
  // Wall time spent rendering and writing pictures so far [s].
  double seconds() const { return seconds_; }
  const render::Camera& camera() const { return camera_; }

  static std::string frame_name(std::int64_t frame);
  // The frames of the contact sheet of a run of frames 0..`frames`: 0, F/5, 2F/5, ..., F, each the nearest
  // frame (7 frames give 0, 1, 2, 4, 5, 6), ascending, none twice.
  static std::vector<std::int64_t> sheet_frames(std::int64_t frames);
  // Sets aside in `removal` the frames a run drew, those from `first_frame` on (an earlier run's, or those an
  // interrupted run drew past the checkpoint a resume starts from).
  static void remove_frames_from(const std::filesystem::path& render_dir, std::int64_t first_frame,
                                 io::StagedRemoval& removal);

 private:
  void keep_for_sheet(std::int64_t frame, const render::Image& im);
  // A failing ffmpeg (no libx264, killed, writes nothing) costs the video only: a warning with its message
  // and the command that makes the video from the PNGs, and the run goes on.
  void add_to_video(const render::Image& im);
  void drop_video(const std::string& why);
  std::string video_command() const;
  bool stopping() const { return stop_ && stop_->load() != 0; }
  std::filesystem::path dir_;
  const Engine& sim_;
  RenderOptions options_;
  bool quiet_;
  const std::atomic<int>* stop_;
  bool video_stopped_ = false;
  std::int64_t frames_;
  std::int64_t lost_ = 0;     // frames drawn before a resume whose PNG is gone or unreadable
  bool sheet_kept_ = false;  // then an earlier session's contact sheet, which finish() leaves as it is
  std::int64_t checkpoint_frame_ = -1;  // the checkpoint's own frame where its PNG is to be drawn again
  std::unique_ptr<render::EglContext> context_;
  std::unique_ptr<render::Renderer> renderer_;
  std::unique_ptr<render::OffscreenTarget> target_;
  std::unique_ptr<render::VideoEncoder> video_;
  render::Framing framing_;
  render::Camera camera_;
  double scale_max_ = 0;
  double fps_ = 10;
  std::map<std::int64_t, render::Image> sheet_;  // the contact sheet's frames, shrunk
  double seconds_ = 0;
};

// tools/plot_run.py of the source tree this program was built from.
std::filesystem::path plot_script();
// Runs tools/plot_run.py on a run's folder (energies, broken links, fragment masses as PNG in render/).
// Prints a message and returns false when python3, matplotlib or the script is missing or it fails.
// `stop`: a stop signal (Ctrl-C) the caller's handler records; the script runs in a process group of its
// own (a terminal's Ctrl-C is not its), and is stopped when the caller's comes: false, and no message
// (the caller says it was interrupted).
bool run_plot_script(const std::filesystem::path& dir, bool quiet, const std::atomic<int>& stop);

}  // namespace mca::app
