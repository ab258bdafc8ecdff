// What a run folder holds across runs and resumes: a resume continues only its own run's checkpoint, a new
// run leaves nothing of an earlier one, the rate of a resumed session is its own.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "io/checkpoint.hpp"
#include "shell.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;
using test::Result;
using test::run_mca;
using test::shell;
using test::TempDir;

std::string read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The default wall made small (360 automata, 5 frames), as test_cli.cpp's; `extra` is appended.
fs::path small_scene(const fs::path& dir, const std::string& name = "small", const std::string& extra = "") {
  fs::create_directories(dir);
  const fs::path p = dir / (name + ".toml");
  std::ofstream(p) << "name = \"" << name << R"("
[solver]
spacing = 0.05
[output]
duration = 0.004
frame_rate = 1000
[heterogeneity]
preset = "medium"
[ground]
enabled = true
[[object]]
name = "wall"
size = [0.6, 0.15, 0.5]
position = [0, 0, 0.25]
[[projectile]]
radius = 0.08
position = [0, -0.17, 0.25]
velocity = [0, 60, 0]
)" << extra;
  return p;
}

std::vector<fs::path> checkpoints(const fs::path& out) {
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(out / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  return cks;
}

// The rate of a resumed run is its own steps over its own wall time: the earlier sessions' wall time (here
// made a million seconds) must not divide it.
TEST(RunFolder, ResumedRateIsTheSessionsOwn) {
  TempDir t;
  const fs::path out = t.path() / "out";
  ASSERT_EQ(run_mca("run " + small_scene(t.path()).string() + " --out " + out.string() +
                    " -q --no-vtk --checkpoint-every 2").code, 0);
  const std::vector<fs::path> cks = checkpoints(out);
  ASSERT_EQ(cks.size(), 2u);
  fs::remove(cks.back());
  io::Checkpoint cp = io::read_checkpoint(cks.front());
  cp.wall_seconds = 1e6;
  io::write_checkpoint(cks.front(), cp);
  const Result r = run_mca("resume " + out.string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  const auto j = nlohmann::json::parse(read(out / "summary.json"));
  EXPECT_GE(j["wall_seconds"].get<double>(), 1e6);
  const double session = j["session_wall_seconds"].get<double>();
  const auto steps = j["session_steps"].get<std::int64_t>();
  EXPECT_EQ(steps, j["steps"].get<std::int64_t>() - cp.state.step);
  ASSERT_GT(session, 0);
  EXPECT_LT(session, 1e3);
  EXPECT_DOUBLE_EQ(j["automaton_steps_per_second"].get<double>(),
                   static_cast<double>(steps) * j["automata"].get<double>() / session);
}

}  // namespace
}  // namespace mca
