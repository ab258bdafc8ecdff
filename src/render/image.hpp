#pragma once
// Images and video of rendered frames: PNG encoding (libpng), a contact sheet of a few frames, and the
// MP4 made by piping raw RGBA frames into ffmpeg.
#include <atomic>
#include <cstdint>
#include <spawn.h>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace mca::render {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  // top row first
};

// PNG bytes of an RGBA image (compression level 1: about 30 ms for 1280x720, files a third larger
// than at level 9). Throws mca::Error when libpng fails.
std::vector<std::uint8_t> encode_png(const Image& image);
// Reads a PNG (any colour type) as RGBA; for tests and the viewer's screenshot checks. Throws mca::Error.
Image read_png(const std::filesystem::path& path);

// The image shrunk by a whole factor (the mean of each factor x factor block).
Image shrink(const Image& image, int factor);

// Tiles of equal size in a grid, row by row, with a gap of background between them.
Image tile(const std::vector<Image>& tiles, int columns, int gap);

// The full path of ffmpeg from PATH, or nothing.
std::optional<std::filesystem::path> find_ffmpeg();

// A file's path as ffmpeg is to read it: a relative one behind "./", so that ffmpeg takes it for neither an
// option ("-odd/...") nor a protocol ("run:1/...", an ISO time "2026-12-06T23:15:00/...", "tcp:...").
std::string ffmpeg_file(const std::filesystem::path& p);

// Starts the program args[0] (looked up on PATH where `search_path`) with `actions` (may be null), in a
// process group of its own: a terminal's Ctrl-C then reaches this program only, which answers it (ends
// the child's work itself or stops it). Returns posix_spawn's error, 0 when it started, and sets `pid`.
int spawn_own_group(pid_t& pid, const std::vector<std::string>& args, const posix_spawn_file_actions_t* actions,
                    bool search_path);

// An H.264 MP4 (yuv420p, plays in browsers) written by ffmpeg from frames piped to it as raw RGBA. The
// file goes to `temporary` and is renamed onto `path` by finish(), so an interrupted run leaves no half
// video under the final name.
class VideoEncoder {
 public:
  // How long ffmpeg may go without taking any of a frame, or without writing to the file while it finishes
  // it after the last frame, before it is stopped [s]: 120, or MCA_FFMPEG_TIMEOUT (whole seconds, 1 to
  // 86400; anything else set there throws mca::Error naming it and the fix, so a command can refuse it
  // before it writes anything).
  static int time_limit();
  // Starts ffmpeg. Throws mca::Error when it cannot be started. Where `interrupt` is given, a wait for
  // ffmpeg (a frame it does not take, the file it finishes) gives up within 0.1 s of *interrupt becoming
  // non-zero (a stop signal): ffmpeg is stopped and mca::Error thrown, as at its time limit.
  VideoEncoder(const std::filesystem::path& ffmpeg, const std::filesystem::path& path,
               const std::filesystem::path& temporary, int width, int height, double fps,
               const std::atomic<int>* interrupt = nullptr);
  ~VideoEncoder();  // without finish(): stops ffmpeg and removes the temporary file
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;
  // Throws mca::Error when ffmpeg has stopped taking frames (its messages are in the error).
  void add_frame(const Image& frame);
  // Closes the pipe, waits for ffmpeg and renames the file into place. Throws mca::Error on failure. With
  // `say_when_slow`, a wait of more than 2 s is said on stderr once (a run showed nothing after its last
  // frame while a slow ffmpeg finished a large video).
  void finish(bool say_when_slow = false);
  int frames() const { return frames_; }

 private:
  void stop(bool say_when_slow = false);
  bool interrupted() const { return interrupt_ && interrupt_->load() != 0; }
  std::filesystem::path path_, temporary_;
  int log_fd_ = -1;  // ffmpeg's messages
  bool finished_ = false;
  int width_, height_;
  int pipe_ = -1;
  int pid_ = -1;
  int frames_ = 0;
  const std::atomic<int>* interrupt_;
};

}  // namespace mca::render
