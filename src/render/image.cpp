#include "render/image.hpp"

#include <array>
#include <charconv>
#include <fstream>
#include <string_view>

#include <cerrno>
#include <csignal>
#include <chrono>
#include <cstdlib>
#include <cstdio>
#include <cstring>

#include <fcntl.h>
#include <png.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <poll.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

#include "mca/error.hpp"

extern char** environ;

namespace mca::render {
namespace {

void png_error_fn(png_structp, png_const_charp message) { throw Error(fmt::format("libpng: {}", message)); }
void png_warning_fn(png_structp, png_const_charp) {}

}  // namespace

std::vector<std::uint8_t> encode_png(const Image& im) {
  std::vector<std::uint8_t> out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, png_error_fn, png_warning_fn);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    throw Error("libpng: out of memory");
  }
  try {
    png_set_write_fn(
        png, &out,
        [](png_structp p, png_bytep data, png_size_t n) {
          auto* v = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(p));
          v->insert(v->end(), data, data + n);
        },
        nullptr);
    png_set_compression_level(png, 1);
    png_set_IHDR(png, info, static_cast<png_uint_32>(im.width), static_cast<png_uint_32>(im.height), 8,
                 PNG_COLOR_TYPE_RGB_ALPHA, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    for (int y = 0; y < im.height; ++y)
      png_write_row(png, const_cast<png_bytep>(im.rgba.data() + 4 * static_cast<std::size_t>(im.width) * y));
    png_write_end(png, nullptr);
  } catch (...) {
    png_destroy_write_struct(&png, &info);
    throw;
  }
  png_destroy_write_struct(&png, &info);
  return out;
}

Image read_png(const std::filesystem::path& path) {
  png_image img{};
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&img, path.c_str()))
    throw Error(fmt::format("cannot read '{}' as PNG: {}", path.string(), img.message));
  img.format = PNG_FORMAT_RGBA;
  Image out;
  out.width = static_cast<int>(img.width);
  out.height = static_cast<int>(img.height);
  out.rgba.resize(PNG_IMAGE_SIZE(img));
  if (!png_image_finish_read(&img, nullptr, out.rgba.data(), 0, nullptr)) {
    const std::string why = img.message;
    png_image_free(&img);
    throw Error(fmt::format("cannot read '{}' as PNG: {}", path.string(), why));
  }
  return out;
}

Image shrink(const Image& im, int f) {
  Image out;
  out.width = im.width / f;
  out.height = im.height / f;
  out.rgba.resize(4 * static_cast<std::size_t>(out.width) * out.height);
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x)
      for (int c = 0; c < 4; ++c) {
        unsigned sum = 0;
        for (int dy = 0; dy < f; ++dy)
          for (int dx = 0; dx < f; ++dx)
            sum += im.rgba[4 * (static_cast<std::size_t>(y * f + dy) * im.width + x * f + dx) + c];
        out.rgba[4 * (static_cast<std::size_t>(y) * out.width + x) + c] = static_cast<std::uint8_t>(sum / (f * f));
      }
  return out;
}

Image tile(const std::vector<Image>& tiles, int columns, int gap) {
  Image out;
  if (tiles.empty()) return out;
  const int w = tiles[0].width, h = tiles[0].height;
  const int n = static_cast<int>(tiles.size()), rows = (n + columns - 1) / columns;
  const int cols = std::min(n, columns);
  out.width = cols * w + (cols + 1) * gap;
  out.height = rows * h + (rows + 1) * gap;
  out.rgba.assign(4 * static_cast<std::size_t>(out.width) * out.height, 255);
  for (std::size_t p = 0; p < out.rgba.size(); p += 4) {
    out.rgba[p] = 20;
    out.rgba[p + 1] = 22;
    out.rgba[p + 2] = 26;
  }
  for (int k = 0; k < n; ++k) {
    const int x0 = gap + (k % columns) * (w + gap), y0 = gap + (k / columns) * (h + gap);
    for (int y = 0; y < h; ++y)
      std::memcpy(out.rgba.data() + 4 * (static_cast<std::size_t>(y0 + y) * out.width + x0),
                  tiles[k].rgba.data() + 4 * static_cast<std::size_t>(y) * w, 4 * static_cast<std::size_t>(w));
  }
  return out;
}

std::optional<std::filesystem::path> find_ffmpeg() {
  const char* path = std::getenv("PATH");
  if (!path) return std::nullopt;
  std::string list = path;
  for (std::size_t start = 0; start <= list.size();) {
    const std::size_t end = std::min(list.find(':', start), list.size());
    const std::filesystem::path dir = end > start ? list.substr(start, end - start) : std::string(".");
    const auto candidate = dir / "ffmpeg";
    std::error_code ec;
    if (std::filesystem::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0) return candidate;
    start = end + 1;
  }
  return std::nullopt;
}

int spawn_own_group(pid_t& pid, const std::vector<std::string>& args, const posix_spawn_file_actions_t* actions,
                    bool search_path) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  // The signals mca ignores for itself (a file at the size limit, a pipe whose reader is gone) are the
  // child's as by default: an ffmpeg that ignored SIGXFSZ kept a video cut at the limit and ended with 0.
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGXFSZ);
  sigaddset(&defaults, SIGPIPE);
  posix_spawnattr_setsigdefault(&attr, &defaults);
  posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF);
  posix_spawnattr_setpgroup(&attr, 0);
  const int rc = search_path ? posix_spawnp(&pid, argv[0], actions, &attr, argv.data(), environ)
                             : posix_spawn(&pid, argv[0], actions, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  return rc;
}

std::string ffmpeg_file(const std::filesystem::path& p) {
  return p.is_relative() ? "./" + p.string() : p.string();
}

VideoEncoder::VideoEncoder(const std::filesystem::path& ffmpeg, const std::filesystem::path& path,
                           const std::filesystem::path& temporary, int width, int height, double fps,
                           const std::atomic<int>* interrupt)
    : path_(path), temporary_(temporary), width_(width), height_(height), interrupt_(interrupt) {
  // ffmpeg's messages go to an anonymous in-memory file, read back when it fails.
  log_fd_ = ::memfd_create("ffmpeg-messages", MFD_CLOEXEC);
  if (log_fd_ < 0) throw Error(fmt::format("cannot make a file for ffmpeg's messages: {}", std::strerror(errno)));
  const std::vector<std::string> args = {
      ffmpeg.string(), "-hide_banner", "-loglevel", "error", "-nostdin", "-y", "-f", "rawvideo", "-pix_fmt", "rgba",
      "-s", fmt::format("{}x{}", width, height), "-framerate", fmt::format("{:g}", fps), "-i", "-",
      // yuv420p halves the colour resolution: odd sizes are rounded down to even ones.
      "-vf", "crop=trunc(iw/2)*2:trunc(ih/2)*2", "-c:v", "libx264", "-preset", "veryfast", "-crf", "20",
      "-pix_fmt", "yuv420p", "-movflags", "+faststart", "-f", "mp4", ffmpeg_file(temporary_)};
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw Error(fmt::format("cannot make a pipe to ffmpeg: {}", std::strerror(errno)));
  // Writes that never block: a frame is larger than the pipe (3.7 MB at 1280x720, the pipe 64 KB), and a write
  // of it to an ffmpeg that takes nothing blocked for ever, past the time limit add_frame keeps by polling. (The
  // read end, ffmpeg's input, is a description of its own and stays blocking.)
  if (const int flags = ::fcntl(fds[1], F_GETFL); flags < 0 || ::fcntl(fds[1], F_SETFL, flags | O_NONBLOCK) < 0) {
    const int e = errno;
    ::close(fds[0]);
    ::close(fds[1]);
    throw Error(fmt::format("cannot make the pipe to ffmpeg non-blocking: {}", std::strerror(e)));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[0], 0);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, log_fd_, 2);
  // (A group of its own: a terminal's Ctrl-C is the run's to answer, which stops at a frame's end and ends
  // the encoder itself; killed by it, the video of a run that had finished was lost.)
  pid_t pid = 0;
  const int rc = spawn_own_group(pid, args, &actions, false);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[0]);
  if (rc != 0) {
    ::close(fds[1]);
    throw Error(fmt::format("cannot start {}: {}", ffmpeg.string(), std::strerror(rc)));
  }
  pid_ = pid;
  pipe_ = fds[1];
  // A dead ffmpeg must give a write error (EPIPE), not kill the run with SIGPIPE.
  std::signal(SIGPIPE, SIG_IGN);
}

VideoEncoder::~VideoEncoder() {
  if (pid_ > 0) {
    // (Its process group, which spawn_own_group made: an ffmpeg run by a wrapper script goes with it.)
    ::kill(-pid_, SIGTERM);
    try {
      stop();
    } catch (const Error&) {  // the run's own error is the one to report
    }
  }
  std::error_code ec;
  if (!finished_) std::filesystem::remove(temporary_, ec);
  if (log_fd_ >= 0) ::close(log_fd_);
}

int VideoEncoder::time_limit() {
  const char* text = std::getenv("MCA_FFMPEG_TIMEOUT");
  if (!text || !*text) return 120;
  // Digits only ("+5", " 5", "5s", "1e3" and "-1" are refused with the rest).
  const std::string_view t(text);
  int v = 0;
  const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.find_first_not_of("0123456789") != std::string_view::npos || ec != std::errc() ||
      ptr != t.data() + t.size() || v < 1 || v > 86400)
    throw Error(fmt::format("MCA_FFMPEG_TIMEOUT = {}: not a whole number of seconds from 1 to 86400 (how long ffmpeg "
                            "may go without taking a frame, or without writing while it finishes the video); give "
                            "e.g. MCA_FFMPEG_TIMEOUT=300, or unset it for 120 s",
                            text));
  return v;
}

void VideoEncoder::stop(bool say_when_slow) {
  if (pipe_ >= 0) ::close(pipe_);
  pipe_ = -1;
  int status = 0;
  bool stuck = false, stopped = false;
  if (pid_ > 0) {
    // ffmpeg ends when its input does, after it has encoded the frames it holds and written the index; one
    // that writes nothing to the file for the limit is stopped (a stuck encoder must not hold the run's end
    // for ever), as is one a stop signal leaves unfinished. (The limit was on the whole finish: a slow ffmpeg
    // still writing a large video was stopped.) What was written is told by the file's size and time.
    const auto written = [this] {
      struct stat st {};
      if (::stat(temporary_.c_str(), &st) != 0) return std::array<long long, 3>{-1, 0, 0};
      return std::array<long long, 3>{static_cast<long long>(st.st_size), static_cast<long long>(st.st_mtim.tv_sec),
                                      static_cast<long long>(st.st_mtim.tv_nsec)};
    };
    auto last = written();
    const auto start = std::chrono::steady_clock::now();
    auto until = start + std::chrono::seconds(time_limit());
    for (bool said = !say_when_slow;;) {
      const pid_t r = ::waitpid(pid_, &status, WNOHANG);
      if (r == pid_ || (r < 0 && errno != EINTR)) break;
      if (const auto now = written(); now != last) {
        last = now;
        until = std::chrono::steady_clock::now() + std::chrono::seconds(time_limit());
      }
      if (!said && std::chrono::steady_clock::now() - start > std::chrono::seconds(2)) {
        said = true;
        fmt::print(stderr, "render: waiting for ffmpeg to finish {} (stopped if it writes nothing for {} s)\n",
                   path_.string(), time_limit());
      }
      stuck = std::chrono::steady_clock::now() > until;
      stopped = interrupted();
      if (stuck || stopped) {
        ::kill(-pid_, SIGKILL);
        while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
        }
        break;
      }
      ::usleep(20000);
    }
  }
  pid_ = -1;
  if (stopped)
    throw Error(fmt::format("a stop signal came before ffmpeg finished '{}', and ffmpeg was stopped", path_.string()));
  if (stuck)
    throw Error(fmt::format("ffmpeg wrote nothing to '{}' for {} s while finishing it and was stopped", path_.string(),
                            time_limit()));
  if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0)) {
    std::string why;
    char buf[4096];
    ssize_t n = 0;
    for (off_t at = 0; (n = ::pread(log_fd_, buf, sizeof buf, at)) > 0 && why.size() < 16384; at += n)
      why.append(buf, static_cast<std::size_t>(n));
    while (!why.empty() && (why.back() == '\n' || why.back() == '\r')) why.pop_back();
    // (Killed by a signal: which, in words: "File size limit exceeded" where the video reached ulimit -f.)
    const std::string how = WIFEXITED(status)     ? fmt::format("exit code {}", WEXITSTATUS(status))
                            : WIFSIGNALED(status) ? fmt::format("killed: {}", ::strsignal(WTERMSIG(status)))
                                                  : std::string("killed");
    throw Error(fmt::format("ffmpeg could not write '{}' ({}): {}", path_.string(), how,
                            why.empty() ? std::string("no message") : why));
  }
}

void VideoEncoder::add_frame(const Image& frame) {
  if (frame.width != width_ || frame.height != height_)
    throw Error(fmt::format("a frame of {}x{} for a video of {}x{}", frame.width, frame.height, width_, height_));
  const std::uint8_t* p = frame.rgba.data();
  std::size_t left = frame.rgba.size();
  while (left > 0) {
    // An ffmpeg that takes nothing for the limit is stuck: stopped, with its messages in the error; so is
    // one still waited for when a stop signal comes.
    pollfd pfd{pipe_, POLLOUT, 0};
    int ready = 0;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(time_limit());
    bool stopped = false;
    while (((ready = ::poll(&pfd, 1, 100)) < 0 && errno == EINTR) || ready == 0) {
      stopped = interrupted();
      if (stopped || std::chrono::steady_clock::now() > until) {
        ready = 0;
        break;
      }
    }
    if (ready == 0) {
      ::kill(-pid_, SIGKILL);
      try {
        stop();
      } catch (const Error&) {  // "killed": the reason is this one
      }
      if (stopped)
        throw Error(fmt::format("a stop signal came while ffmpeg took no frame, and ffmpeg was stopped; '{}' is not "
                                "written",
                                path_.string()));
      throw Error(fmt::format("ffmpeg took no frame for {} s and was stopped; '{}' is not written", time_limit(),
                              path_.string()));
    }
    const ssize_t n = ::write(pipe_, p, left);
    if (n < 0 && (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK)) continue;
    if (n <= 0) {
      stop();  // throws with ffmpeg's message
      throw Error(fmt::format("ffmpeg stopped taking frames for '{}'", path_.string()));
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  ++frames_;
}

void VideoEncoder::finish(bool say_when_slow) {
  stop(say_when_slow);
  // An MP4 file opens with its "ftyp" box (ISO 14496-12, 4.3): a program named ffmpeg that ends well and
  // leaves something else (a wrapper, a stand-in) has made no video.
  // (Only the head is read: a file that opens as an MP4 and is damaged after it is not told.)
  char head[8] = {};
  std::ifstream f(temporary_, std::ios::binary);
  const bool opened = f.is_open();
  if (!opened || !f.read(head, sizeof head) || std::memcmp(head + 4, "ftyp", 4) != 0)
    throw Error(fmt::format("ffmpeg ended without error but wrote no MP4 video to '{}' ({}): is the ffmpeg on the "
                            "PATH the real one?",
                            path_.string(),
                            opened ? "it does not begin with an MP4 file's \"ftyp\" box" : "it wrote no file"));
  std::error_code ec;
  std::filesystem::rename(temporary_, path_, ec);
  if (ec) throw Error(fmt::format("cannot rename '{}' onto '{}': {}", temporary_.string(), path_.string(), ec.message()));
  finished_ = true;
}

}  // namespace mca::render
