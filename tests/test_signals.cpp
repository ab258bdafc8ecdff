// A run stopped by a signal ends alike for SIGINT (Ctrl-C), SIGTERM and SIGHUP (the terminal closed): it
// writes its summary and a checkpoint, and `mca resume` continues it to the uninterrupted run's end.
// SIGHUP used to end the process at once, with no summary and nothing to resume from.
#include <gtest/gtest.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>

#include "shell.hpp"
#include "small_scene.hpp"
#include "temp_dir.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
using mca::test::read;
using mca::test::run_mca;
using mca::test::small_scene;

// Rows of a stats.csv (the header not counted).
int stats_rows(const fs::path& csv) {
  std::ifstream in(csv);
  int n = -1;
  for (std::string line; std::getline(in, line);) ++n;
  return std::max(n, 0);
}

// `mca run SCENE --out OUT` started in the background (its output to OUT.log), sent `sig` once it has
// written two frames; returns its exit status (-1 when it ended before the signal or did not end).
int run_and_signal(const fs::path& scene, const fs::path& out, int sig) {
  const std::string bin = MCA_BINARY, log = out.string() + ".log";
  std::vector<std::string> args = {bin, "run", scene.string(), "--out", out.string(), "--no-vtk", "--threads", "1", "--checkpoint-every", "1"};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, bin.c_str(), &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (spawned != 0) return -1;
  int status = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(120);
  bool sent = false;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (!sent && stats_rows(out / "stats.csv") >= 2) {
      kill(pid, sig);
      sent = true;
    }
    if (std::chrono::steady_clock::now() > until) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!sent) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
}

TEST(Signals, SigtermAndSighupStopARunAsCtrlCDoes) {
  mca::test::TempDir t;
  // 40 frames of the small wall: long enough to be signalled after two.
  const fs::path scene = small_scene(t.path(), "", "long");
  std::string text = read(scene);
  text.replace(text.find("duration = 0.004"), 16, "duration = 0.04");
  std::ofstream(scene) << text;
  const fs::path whole = t.path() / "whole";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + whole.string() + " -q --no-vtk").code, 0);
  const auto expected = nlohmann::json::parse(read(whole / "summary.json"));

  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) {
    SCOPED_TRACE(strsignal(sig));
    const fs::path out = t.path() / ("stopped_" + std::to_string(sig));
    const int code = run_and_signal(scene, out, sig);
    ASSERT_EQ(code, 128 + sig) << read(out.string() + ".log");
    const std::string log = read(out.string() + ".log");
    EXPECT_NE(log.find("interrupted by SIG"), std::string::npos) << log;
    const auto j = nlohmann::json::parse(read(out / "summary.json"));
    EXPECT_EQ(j["status"], "interrupted");
    EXPECT_LT(j["steps"].get<std::int64_t>(), expected["steps"].get<std::int64_t>());
    EXPECT_TRUE(fs::exists(out / "checkpoints")) << log;

    const auto resumed = run_mca("resume " + out.string() + " -q");
    ASSERT_EQ(resumed.code, 0) << resumed.output;
    const auto k = nlohmann::json::parse(read(out / "summary.json"));
    EXPECT_EQ(k["status"], "finished");
    EXPECT_EQ(k["steps"], expected["steps"]);
    EXPECT_EQ(k["state_hash"], expected["state_hash"]);
    EXPECT_EQ(read(out / "stats.csv"), read(whole / "stats.csv"));
  }
}

// A signal while the model is built ends the process at once with a message and 128 + the signal; it
// used to end it without a word (found by the hostile review). A box of about a million automata takes
// seconds to build; the signal comes after one. The folders the run made for its output go again (they
// were left empty), and a folder that was there stays.
TEST(Signals, ASignalDuringTheBuildEndsItWithAMessage) {
  mca::test::TempDir t;
  const fs::path scene = t.path() / "big.toml";
  std::ofstream(scene) << "[solver]\ntarget_automata = 1000000\n[[object]]\nname = \"b\"\n"
                          "size = [2, 0.4, 2]\nposition = [0, 0, 1.1]\n";
  fs::create_directories(t.path() / "there");
  fs::create_directories(t.path() / "E");  // (reached through a folder the run makes: new2/../E)
  // (A trailing slash, "." and ".." name a folder twice on the way: they kept the folders above it.)
  const std::string base = t.path().string();
  for (const fs::path& out : {t.path() / "new" / "deeper" / "out", t.path() / "there", fs::path(base + "/slash/a/"),
                              fs::path(base + "/dot/./a"), fs::path(base + "/up/x/../a"),
                              fs::path(base + "/new2/../E")}) {
    SCOPED_TRACE(out.string());
    const mca::test::Result r = mca::test::shell("( " + std::string(MCA_BINARY) + " run " + scene.string() + " --out " +
                                                 out.string() + " & p=$!; sleep 1; kill -TERM $p; wait $p; echo rc=$? )");
    EXPECT_NE(r.output.find("mca: stopped by a signal while building the model, before the first step; nothing was "
                            "written"),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("rc=143"), std::string::npos) << r.output;
  }
  for (const char* made : {"new", "slash", "dot", "up", "new2"}) EXPECT_FALSE(fs::exists(t.path() / made)) << made;
  EXPECT_TRUE(fs::is_directory(t.path() / "E"));
  EXPECT_TRUE(fs::is_directory(t.path() / "there"));
  EXPECT_TRUE(fs::is_empty(t.path() / "there"));
}

}  // namespace
