// The estimate of what a run writes (app/frame_output.hpp): it matches the files of a run, `mca info` shows
// it, and a run that would not fit the free disk is refused before it writes anything.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "app/frame_output.hpp"
#include "io/scene_io.hpp"
#include "shell.hpp"
#include "sim/engine.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;
using test::Result;
using test::run_mca;
using test::TempDir;

std::uintmax_t folder_bytes(const fs::path& dir) {
  std::uintmax_t sum = 0;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) sum += e.file_size();
  return sum;
}

// The default wall with a ball, at a frame rate of `rate`.
fs::path wall_scene(const fs::path& dir, const std::string& rate, const std::string& extra = "") {
  const fs::path p = dir / "wall.toml";
  std::ofstream(p) << "name = \"wall\"\n[solver]\nspacing = 0.05\n[output]\nduration = 0.004\nframe_rate = " << rate
                   << "\n" << extra << R"(
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
)";
  return p;
}

TEST(OutputEstimate, MatchesTheFilesOfARun) {
  TempDir t;
  const fs::path scene = wall_scene(t.path(), "1000", "checkpoint_every = 1\nlinks = true");
  const SceneDef def = io::load_scene_file(scene);
  const Engine sim(def);
  const app::OutputEstimate e = app::estimate_output(sim.model(), def.output, sim.frame_count() + 1);
  const fs::path out = t.path() / "out";
  const Result r = run_mca("run " + scene.string() + " --out " + out.string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  // Frame 0's VTK files to a per cent (all links intact then).
  const double frame0 = static_cast<double>(fs::file_size(out / "frames" / "automata_000000.vtu") +
                                            fs::file_size(out / "frames" / "projectiles_000000.vtu"));
  EXPECT_NEAR(e.vtk_frame / frame0, 1.0, 0.01) << e.vtk_frame << " for " << frame0;
  // The whole folder within a third (links break, so later frames are smaller; checkpoints are estimated).
  const double all = static_cast<double>(folder_bytes(out));
  EXPECT_GT(e.total(), 0.9 * all) << e.total() << " for " << all;
  EXPECT_LT(e.total(), 1.5 * all) << e.total() << " for " << all;
  // mca info shows it.
  const Result info = run_mca("info --json " + scene.string());
  ASSERT_EQ(info.code, 0) << info.output;
  const auto j = nlohmann::json::parse(info.output);
  EXPECT_DOUBLE_EQ(j["output_bytes"].get<double>(), e.total());
  EXPECT_GT(j["output_bytes_with_render"].get<double>(), e.total());
  const Result text = run_mca("info " + scene.string());
  EXPECT_NE(text.output.find("output estimate  " + app::human_bytes(e.total())), std::string::npos) << text.output;
}

// frame_rate = 1e9 planned 4,000,001 frames, about 140 GB here, without a word: refused before any
// folder is made, with the size and the fix.
TEST(OutputEstimate, ARunThatWouldFillTheDiskIsRefused) {
  TempDir t;
  const fs::path scene = wall_scene(t.path(), "1e9");
  const SceneDef def = io::load_scene_file(scene);
  const Engine sim(def);
  const app::OutputEstimate e = app::estimate_output(sim.model(), def.output, sim.frame_count() + 1);
  EXPECT_EQ(e.frames, 4'000'001);
  if (e.total() < static_cast<double>(fs::space(t.path()).available))
    GTEST_SKIP() << "this disk has more than " << app::human_bytes(e.total()) << " free";
  const fs::path out = t.path() / "out";
  const Result r = run_mca("run " + scene.string() + " --out " + out.string() + " -q");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("would write about " + app::human_bytes(e.total()) + " into " + out.string()),
            std::string::npos) << r.output;
  EXPECT_NE(r.output.find("4000001 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("output.frame_rate"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("free there"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(out)) << "an output folder was made";
  // Without the VTK frames it fits.
  const app::OutputEstimate small = [&] {
    OutputDef o = def.output;
    o.vtk = false;
    return app::estimate_output(sim.model(), o, sim.frame_count() + 1);
  }();
  EXPECT_LT(small.total(), 0.02 * e.total());
}

TEST(OutputEstimate, BytesAreShownInThreeFigures) {
  EXPECT_EQ(app::human_bytes(512), "512 bytes");
  EXPECT_EQ(app::human_bytes(430'000), "430 KB");
  EXPECT_EQ(app::human_bytes(1.72e12), "1.72 TB");
  EXPECT_EQ(app::human_bytes(999'600), "1 MB");
}

}  // namespace
}  // namespace mca

namespace mca {
namespace {

// `mca info`'s memory estimate counted the arrays only: the bunny (scenes/bunny.toml: a mesh object, its
// surface written each frame, fragment meshes at the end) was estimated at 52 MB and peaked at 76 to
// 108 MB, and 201 to 275 MB with --render. Its estimate must hold the peak of a short run, with and
// without the renderer.
TEST(MemoryEstimate, CountsMeshesSurfaceFragmentMeshesAndRendering) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine triple the resident size";
#endif
  const fs::path bunny = fs::path(MCA_SOURCE_DIR) / "scenes" / "bunny.toml";
  const Result info = run_mca("info --json " + bunny.string());
  if (info.code != 0 && info.output.find("get_models.sh") != std::string::npos)
    GTEST_SKIP() << "the paper's models are not installed (scripts/get_models.sh): " << info.output;
  ASSERT_EQ(info.code, 0) << info.output;
  const auto j = nlohmann::json::parse(info.output);
  TempDir t;
  for (const bool render : {false, true}) {
    SCOPED_TRACE(render ? "--render" : "no --render");
    const fs::path out = t.path() / (render ? "rendered" : "plain");
    // Ten steps: one frame of the bound surface, and the whole bunny as one fragment mesh at the end.
    // The peak of the whole process (summary.json's is taken before the fragment meshes and the video):
    // the largest child's maximum resident size, as /usr/bin/time -v gives it.
    const Result r = test::shell(
        "python3 -c 'import resource, subprocess, sys; c = subprocess.run(sys.argv[1:]).returncode; "
        "print(\"peak_kb\", resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss); sys.exit(c)' " +
        std::string(MCA_BINARY) + " run " + bunny.string() + " --out " + out.string() + " -q --steps 10" +
        (render ? " --render --render-size 1280x720" : ""));
    ASSERT_EQ(r.code, 0) << r.output;
    const auto at = r.output.find("peak_kb ");
    ASSERT_NE(at, std::string::npos) << r.output;
    const double peak = 1024.0 * std::stod(r.output.substr(at + 8));
    const double estimate = j[render ? "memory_bytes_with_render" : "memory_bytes"].get<double>();
    std::printf("bunny%s: estimate %.1f MB, peak resident %.1f MB\n", render ? " --render" : "", estimate / 1e6,
                peak / 1e6);
    EXPECT_GT(estimate, 0.9 * peak);
    EXPECT_LT(estimate, 1.4 * peak);
  }
}

}  // namespace
}  // namespace mca
