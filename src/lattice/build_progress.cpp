// BuildProgress (lattice.hpp): a watcher thread prints the stage of a build that has run for 2 s.
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <exception>
#include <mutex>
#include <thread>
#include <unistd.h>

#include <fmt/format.h>

#include "lattice/lattice.hpp"

namespace mca::lattice {
namespace {

thread_local BuildProgress* g_progress = nullptr;

// A build shorter than this shows nothing.
constexpr double kQuietSeconds = 2.0;

}  // namespace

struct BuildProgress::Shared {
  std::mutex mutex;
  std::condition_variable wake;
  std::string stage = "starting";
  bool done = false, failed = false;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  std::thread watcher;

  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  void watch() {
    const bool tty = isatty(STDERR_FILENO);
    // On a terminal the line is rewritten every 0.2 s; into a file or a pipe, a line every 10 s.
    const auto period = tty ? std::chrono::milliseconds(200) : std::chrono::milliseconds(10000);
    std::unique_lock<std::mutex> lock(mutex);
    if (wake.wait_for(lock, std::chrono::duration<double>(kQuietSeconds), [&] { return done; })) return;
    for (;;) {
      fmt::print(stderr, "{}mca: building the model ({:.0f} s): {}{}", tty ? "\r" : "", elapsed(), stage,
                 tty ? "\033[K" : "\n");
      std::fflush(stderr);
      if (wake.wait_for(lock, period, [&] { return done; })) break;
    }
    fmt::print(stderr, "{}mca: {} after {:.1f} s{}\n", tty ? "\r" : "", failed ? "the build stopped" : "model built",
               elapsed(), tty ? "\033[K" : "");
  }
};

BuildProgress::BuildProgress() : shared_(std::make_unique<Shared>()), outer_(g_progress) {
  g_progress = this;
  shared_->watcher = std::thread([s = shared_.get()] { s->watch(); });
}

BuildProgress::~BuildProgress() {
  g_progress = outer_;
  {
    std::lock_guard<std::mutex> lock(shared_->mutex);
    shared_->done = true;
    shared_->failed = std::uncaught_exceptions() > 0;
  }
  shared_->wake.notify_all();
  shared_->watcher.join();
}

void BuildProgress::stage(const std::string& what) {
  if (!g_progress) return;
  std::lock_guard<std::mutex> lock(g_progress->shared_->mutex);
  g_progress->shared_->stage = what;
}

}  // namespace mca::lattice
