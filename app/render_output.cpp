#include "app/render_output.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <csignal>
#include <thread>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <fstream>
#include <nlohmann/json.hpp>
#include <spawn.h>
#include <sys/wait.h>

#include "analysis/fragments.hpp"
#include "backend/backend.hpp"
#include "core/files.hpp"
#include "core/text.hpp"
#include "io/json_text.hpp"
#include "io/output_files.hpp"
#include "mca/error.hpp"
#include "render/egl_context.hpp"
#include "render/renderer.hpp"

extern char** environ;

namespace mca::app {
namespace {

constexpr int kSheetTiles = 6, kSheetColumns = 3;

void write_bytes(const std::filesystem::path& path, const std::vector<std::uint8_t>& bytes) {
  io::write_file_atomic(path, [&](std::ostream& os) {
    os.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  });
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

void check_render_size(int width, int height, const std::string& option) {
  if (width < 16 || height < 16 || width > 8192 || height > 8192)
    throw Error(fmt::format("{} {}x{} is out of range: each side must be 16 to 8192 pixels; give e.g. {} 1280x720",
                            option, width, height, option));
}

std::pair<int, int> parse_render_size(const std::string& text, const std::string& option) {
  const auto x = text.find_first_of("xX");
  int w = -1, h = -1;
  bool ok = x != std::string::npos;
  if (ok) {
    const char* b = text.data();
    const auto r1 = std::from_chars(b, b + x, w);
    const auto r2 = std::from_chars(b + x + 1, b + text.size(), h);
    ok = r1.ec == std::errc() && r1.ptr == b + x && r2.ec == std::errc() && r2.ptr == b + text.size();
  }
  if (!ok)
    throw Error(fmt::format("{} '{}' is not WIDTHxHEIGHT in pixels; give e.g. {} 1280x720", option, text, option));
  check_render_size(w, h, option);
  return {w, h};
}

std::string RenderOutput::frame_name(std::int64_t frame) { return fmt::format("frame_{:06d}.png", frame); }

void RenderOutput::remove_frames_from(const std::filesystem::path& render_dir, std::int64_t first_frame,
                                      io::StagedRemoval& removal) {
  // (Only names of the run's own form: a user's render/frame_cover.png stays.)
  std::vector<std::filesystem::path> doomed;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(render_dir, ec)) {
    const std::string name = e.path().filename().string();
    const auto number = io::numbered(name, "frame_", ".png");
    if (e.is_regular_file() && number && !(*number < first_frame && name == frame_name(*number))) doomed.push_back(e.path());
  }
  for (const auto& p : doomed) removal.stage(p);
}

void save_render_options(const std::filesystem::path& out_dir, const RenderOptions& o) {
  const nlohmann::json j = {{"width", o.width}, {"height", o.height}, {"colour", render::name(o.colour)},
                            {"draw", render::name(o.draw)}, {"fps", o.fps}};
  io::write_file_atomic(out_dir / "render" / "render.json", [&](std::ostream& os) { os << io::json_text(j) << "\n"; });
}

std::optional<RenderOptions> load_render_options(const std::filesystem::path& out_dir) {
  const std::filesystem::path file = out_dir / "render" / "render.json";
  std::error_code ec;
  if (!std::filesystem::exists(std::filesystem::symlink_status(file, ec))) return std::nullopt;
  const auto fail = [&](const std::string& what) {
    return Error(fmt::format("{}: {}; the file is damaged or was edited: remove it to resume without rendering, or "
                             "restore it",
                             file.string(), what));
  };
  if (const std::string kind = files::non_regular_kind(file); !kind.empty())
    throw fail(fmt::format("it is {}, not the file of the run's rendering options", kind));
  RenderOptions o;
  try {
    std::ifstream in(file);
    const nlohmann::json j = nlohmann::json::parse(in);
    // (Read as numbers first: a width of 1e300 is no int, and get<int> would wrap it.)
    const auto pixels = [&](const char* key) {
      const double v = j.at(key).get<double>();
      if (!(v >= 16 && v <= 8192 && v == std::floor(v)))
        throw fail(fmt::format("{} {} is not a whole number of pixels from 16 to 8192", key, text::num(v)));
      return static_cast<int>(v);
    };
    o.width = pixels("width");
    o.height = pixels("height");
    const auto colour = render::parse_colour_mode(j.at("colour").get<std::string>());
    const auto draw = render::parse_draw_mode(j.at("draw").get<std::string>());
    if (!colour || !draw) throw fail("an unknown colour or draw mode");
    o.colour = *colour;
    o.draw = *draw;
    o.fps = j.at("fps").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw fail(e.what());
  }
  if (!(o.fps >= 0 && o.fps <= 240)) throw fail(fmt::format("fps {} is outside 0..240", o.fps));
  try {
    check_render_size(o.width, o.height);
  } catch (const Error& e) {
    throw fail(e.what());
  }
  return o;
}

RenderOutput::RenderOutput(const std::filesystem::path& dir, const Engine& sim, const RenderOptions& options,
                           std::int64_t frames, bool quiet, std::int64_t first_frame, const std::atomic<int>* stop,
                           io::StagedRemoval& removal)
    : dir_(dir / "render"), sim_(sim), options_(options), quiet_(quiet), stop_(stop), frames_(frames) {
  check_render_size(options.width, options.height);
  render::VideoEncoder::time_limit();  // a bad MCA_FFMPEG_TIMEOUT is refused before anything is written
  const Model& m = sim.model();
  if (options.draw == render::DrawMode::surface && m.surface.faces() == 0)
    throw Error(fmt::format("--render-draw surface needs an object of shape \"mesh\" (its triangles are drawn); scene "
                            "'{}' has none: use --render-draw cubes, spheres or links",
                            sim.scene().source));
  // Everything that can fail comes before the folder is touched: the context, the shaders, the camera.
  context_ = std::make_unique<render::EglContext>();
  renderer_ = std::make_unique<render::Renderer>();
  target_ = std::make_unique<render::OffscreenTarget>(options.width, options.height);
  framing_ = render::objects_box(m, initial_state(m));
  camera_ = render::make_camera(sim.scene().camera, m, framing_,
                                static_cast<float>(options.width) / static_cast<float>(options.height),
                                sim.scene().source);
  if (!camera_.note.empty() && !quiet) fmt::print(stderr, "note: {}\n", camera_.note);
  // Continuous colours on one scale for the whole run: speeds up to the fastest initial speed, stresses
  // up to the strongest tensile strength (where the stress criterion breaks links of full-strength class).
  if (options.colour == render::ColourMode::speed) {
    for (const auto& p : m.projectiles) scale_max_ = std::max<double>(scale_max_, length(p.velocity));
    for (const DVec3& v : m.velocity0) scale_max_ = std::max<double>(scale_max_, length(v));
    if (scale_max_ <= 0) scale_max_ = 1;
  } else if (options.colour == render::ColourMode::stress) {
    std::vector<std::uint8_t> used(m.groups.size());
    for (auto g : m.group) used[g] = 1;
    for (std::size_t g = 0; g < m.groups.size(); ++g)
      if (used[g]) scale_max_ = std::max<double>(scale_max_, m.groups[g].tensile_strength);
  }
  fps_ = options.fps > 0 ? options.fps : std::clamp(std::round(static_cast<double>(frames + 1) / 4.0), 10.0, 30.0);

  io::prepare_output_dir(dir_);
  io::remove_stale_temporaries(dir_);
  remove_frames_from(dir_, first_frame, removal);
  // (A resumed run's video and sheet go below, where it can make them again.)
  if (first_frame == 0) {
    for (const char* old : {"video.mp4", "contact_sheet.png"}) removal.stage(dir_ / old);
    removal.will_write(dir_ / "render.json");
    save_render_options(dir, options);
  }
  if (const auto ffmpeg = render::find_ffmpeg()) {
    try {
      video_ = std::make_unique<render::VideoEncoder>(*ffmpeg, dir_ / "video.mp4",
                                                      io::temporary_path(dir_ / "video.mp4"), options.width,
                                                      options.height, fps_, stop_);
    } catch (const Error& e) {
      drop_video(e.what());
    }
  } else {
    fmt::print(stderr,
               "warning: ffmpeg is not installed: render/video.mp4 will not be written (the PNG frames are). Install "
               "it with `apt-get install ffmpeg` (scripts/setup.sh does), then make the video from the frames with: "
               "{}\n",
               video_command());
  }
  // A resumed run: the frames written before go into the video and the contact sheet from their PNGs.
  // The checkpoint's own frame is drawn again where its PNG is gone or cannot be taken (draw_checkpoint_frame);
  // an earlier one cannot be (no state of it is left), and then there is no whole video to make.
  std::vector<std::int64_t> lost;
  std::string why;
  for (std::int64_t f = 0; f < first_frame; ++f) {
    const std::filesystem::path png = dir_ / frame_name(f);
    render::Image im;
    try {
      im = render::read_png(png);
      if (im.width != options.width || im.height != options.height)
        throw Error(fmt::format("{} is {}x{}, not the run's {}x{}", png.string(), im.width, im.height, options.width,
                                options.height));
    } catch (const Error& e) {
      if (f == first_frame - 1) {  // (drawn by draw_checkpoint_frame, once the earlier end is removed)
        checkpoint_frame_ = f;
        continue;
      }
      if (lost.empty()) why = e.what();
      lost.push_back(f);
      continue;
    }
    add_to_video(im);
    keep_for_sheet(f, im);
  }
  if (!lost.empty()) {
    // No whole video or sheet can be made again; an earlier session's, where it made them, are of the whole
    // run (a resume continues it bit for bit): kept (a finished run's complete video was removed).
    const bool video_kept = std::filesystem::is_regular_file(dir_ / "video.mp4");
    sheet_kept_ = std::filesystem::is_regular_file(dir_ / "contact_sheet.png");
    const char* them = lost.size() > 1 ? "them" : "it";
    fmt::print(stderr, "warning: {} frame{} drawn before the checkpoint cannot be read (frame{} {}; {}), and a resume "
               "cannot draw {} again: {}{}\n",
               lost.size(), lost.size() > 1 ? "s" : "", lost.size() > 1 ? "s" : "", text::number_runs(lost), why, them,
               video_kept ? "render/video.mp4 of the run's earlier session is kept, "
                          : (video_ ? "render/video.mp4 will not be written, " : ""),
               sheet_kept_ ? "as is its contact_sheet.png" : fmt::format("the contact sheet leaves {} out", them));
    video_.reset();
    lost_ = static_cast<std::int64_t>(lost.size());
  } else if (first_frame > 0) {
    for (const char* old : {"video.mp4", "contact_sheet.png"}) removal.stage(dir_ / old);  // (made again)
  }
  if (!quiet_)
    fmt::print(stderr, "mca: rendering {}x{} ({}, colour by {}) with {} ({}) into {}{}\n", options.width,
               options.height, render::name(options.draw), render::name(options.colour),
               render::Renderer::gl_description(), context_->source(), dir_.string(),
               first_frame > 0 ? fmt::format(" (from frame {}; frames 0..{} are kept)", first_frame, first_frame - 1)
                               : std::string());
}

std::string RenderOutput::video_command() const {
  // As the run's own encoder makes it (render::VideoEncoder): even sizes for yuv420p, its quality and layout,
  // the file replaced; a relative path behind "./", as the encoder gives it (render::ffmpeg_file).
  // The frames' pattern is ffmpeg's: a % in the folder's name is given as %%.
  std::string frames;
  for (const char c : render::ffmpeg_file(dir_)) frames += c == '%' ? std::string("%%") : std::string(1, c);
  return fmt::format("ffmpeg -y -framerate {:g} -i {} -vf 'crop=trunc(iw/2)*2:trunc(ih/2)*2' -c:v libx264 -preset "
                     "veryfast -crf 20 -pix_fmt yuv420p -movflags +faststart {}",
                     fps_, text::shell_word(frames + "/frame_%06d.png"),
                     text::shell_word(render::ffmpeg_file(dir_ / "video.mp4")));
}

void RenderOutput::add_to_video(const render::Image& im) {
  if (!video_) return;
  try {
    video_->add_frame(im);
  } catch (const Error& e) {
    if (stopping()) video_.reset();  // (the run stops at this frame's end; its resume makes the video)
    else drop_video(e.what());
  }
}

void RenderOutput::drop_video(const std::string& why) {
  video_.reset();  // stops ffmpeg, removes its temporary file
  fmt::print(stderr,
             "warning: {}; render/video.mp4 will not be written, the run goes on (the PNG frames and every other "
             "output are written). Make the video from the frames with an ffmpeg that has libx264: {}\n",
             why, video_command());
}

std::vector<std::int64_t> RenderOutput::sheet_frames(std::int64_t frames) {
  std::vector<std::int64_t> picks;
  constexpr std::int64_t n = kSheetTiles - 1;
  for (std::int64_t k = 0; k <= n; ++k) {
    const std::int64_t f = (2 * frames * k + n) / (2 * n);  // k F / n, rounded half up
    if (picks.empty() || picks.back() != f) picks.push_back(f);
  }
  return picks;
}

void RenderOutput::keep_for_sheet(std::int64_t frame, const render::Image& im) {
  // The contact sheet's frames, each at half size.
  const auto picks = sheet_frames(frames_);
  if (std::binary_search(picks.begin(), picks.end(), frame)) sheet_[frame] = render::shrink(im, 2);
}

RenderOutput::~RenderOutput() = default;

void RenderOutput::draw_checkpoint_frame(const State& state) {
  if (checkpoint_frame_ < 0) return;
  write_frame(checkpoint_frame_, state, analysis::label_model_fragments(sim_.model(), state.intact.data()));
  checkpoint_frame_ = -1;
}

void RenderOutput::write_frame(std::int64_t frame, const State& state, const analysis::Fragments& fragments) {
  const auto t0 = std::chrono::steady_clock::now();
  render::SnapshotOptions so;
  so.draw = options_.draw;
  so.colour = options_.colour;
  so.scale_max = scale_max_;
  const render::Snapshot snap = render::make_snapshot(sim_.model(), state, fragments, so, framing_.origin);
  target_->bind();
  render::Overlay overlay;
  overlay.time_resolution = sim_.frame_interval();
  renderer_->draw(snap, options_.draw, camera_, options_.width, options_.height, overlay);
  render::Image im;
  im.width = options_.width;
  im.height = options_.height;
  target_->read_rgba(im.rgba);
  write_bytes(dir_ / frame_name(frame), render::encode_png(im));
  add_to_video(im);
  keep_for_sheet(frame, im);
  seconds_ += seconds_since(t0);
}

void RenderOutput::finish() {
  const auto t0 = std::chrono::steady_clock::now();
  if (video_) {
    try {
      video_->finish(!quiet_);
      video_.reset();
    } catch (const Error& e) {
      if (stopping()) {
        video_.reset();
        video_stopped_ = true;
        fmt::print(stderr, "mca: {}/video.mp4 is not written: {}. Make it from the frames with: {}\n", dir_.string(),
                   e.what(), video_command());
      } else {
        drop_video(e.what());
      }
    }
  }
  std::vector<render::Image> tiles;
  for (auto& [frame, im] : sheet_) tiles.push_back(std::move(im));
  sheet_.clear();
  // The sheet is made of frames on the disk: one that cannot be written is a warning naming them, as a
  // video that cannot be made is (the run and its frames are whole).
  bool sheet = !tiles.empty() && !sheet_kept_;
  if (sheet) {
    try {
      write_bytes(dir_ / "contact_sheet.png", render::encode_png(render::tile(tiles, kSheetColumns, 4)));
    } catch (const Error& e) {
      sheet = false;
      std::vector<std::string> names;
      for (const std::int64_t f : sheet_frames(frames_)) names.push_back(frame_name(f));
      fmt::print(stderr, "warning: {}; the contact sheet is not written: it shows {} in {} (at half size, {} a row)\n",
                 e.what(), fmt::join(names, ", "), dir_.string(), kSheetColumns);
    }
  }
  seconds_ += seconds_since(t0);
  if (!quiet_) {
    fmt::print(stderr, "render: {} frames (frame_NNNNNN.png){} in {}{} ({:.1f} s of drawing and writing)\n",
               frames_ + 1 - lost_, sheet || sheet_kept_ ? " and contact_sheet.png" : "", dir_.string(),
               lost_ ? fmt::format(", {} lost before a resume", lost_) : "", seconds_);
    if (std::filesystem::exists(dir_ / "video.mp4"))
      fmt::print(stderr, "video: {} ({} frames at {:g} frames/s: {:.3g} s)\n", (dir_ / "video.mp4").string(),
                 frames_ + 1, fps_, static_cast<double>(frames_ + 1) / fps_);  // (3 frames at 240/s read "0.0 s")
  }
}

std::filesystem::path plot_script() { return std::filesystem::path(MCA_TOOLS_DIR) / "plot_run.py"; }

bool run_plot_script(const std::filesystem::path& dir, bool quiet, const std::atomic<int>& stop) {
  const std::filesystem::path script = plot_script();
  const std::string shown = fmt::format("python3 {} {}", script.string(), dir.string());
  if (!std::filesystem::exists(script)) {
    fmt::print(stderr, "warning: no plots: {} is missing (it comes with the source tree)\n", script.string());
    return false;
  }
  // Debian's python3 first: python3-matplotlib installs for it, and a python3 earlier on PATH (a virtual
  // environment, pyenv) may lack it.
  const std::string python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  std::vector<std::string> args = {python, script.string(), dir.string()};
  if (quiet) args.push_back("--quiet");
  args.push_back(fmt::format("--parent={}", ::getpid()));  // it ends with this process, even one killed
  // (A group of its own: a terminal's Ctrl-C reaches this program only, which stops the script.)
  pid_t pid = 0;
  const int rc = render::spawn_own_group(pid, args, nullptr, true);
  if (rc != 0) {
    fmt::print(stderr, "warning: no plots: python3 cannot be started ({}); install it with `apt-get install python3 "
                       "python3-matplotlib` (scripts/setup.sh does), then run: {}\n",
               std::strerror(rc), shown);
    return false;
  }
  // A script that hangs (a stuck matplotlib backend, a locked font cache) must not hang the run: after
  // kPlotTimeout it is killed and the run ends without the plots.
  constexpr double kPlotTimeout = 120;
  const auto t0 = std::chrono::steady_clock::now();
  int status = 0;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid || (done < 0 && errno != EINTR)) break;
    if (stop.load() != 0) {
      ::kill(-pid, SIGTERM);
      while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
      io::remove_stale_temporaries(dir / "render");  // (a plot it was writing)
      return false;
    }
    if (seconds_since(t0) > kPlotTimeout) {
      ::kill(pid, SIGKILL);
      while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
      }
      fmt::print(stderr, "warning: the plots were not made: {} ran over {:g} s and was stopped; the run's other "
                         "outputs are complete; to make them: {}\n",
                 script.filename().string(), kPlotTimeout, shown);
      return false;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0)) {
    fmt::print(stderr, "warning: the plots were not made ({} exited with {}); the run's other outputs are complete\n",
               script.filename().string(), WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    return false;
  }
  return true;
}

}  // namespace mca::app
