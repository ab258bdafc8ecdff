// `mca resume` cuts stats.csv back to the checkpoint's rows, whatever the stopped run left past them or
// cut short, so that the resumed run's stats.csv is an uninterrupted run's. A torn row used to be kept
// as a row of its own. Frames removed before the checkpoint are left out of what lists them.
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "shell.hpp"
#include "small_scene.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using mca::test::read;
using mca::test::Result;
using mca::test::run_mca;
using mca::test::small_scene;

// The rows of a stats.csv, the header first, without their line breaks.
std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::size_t at = 0;
  while (at < text.size()) {
    const std::size_t end = text.find('\n', at);
    out.push_back(text.substr(at, end == std::string::npos ? std::string::npos : end - at));
    if (end == std::string::npos) break;
    at = end + 1;
  }
  return out;
}

TEST(ResumeStats, RowsPastTheCheckpointAndTornRowsAreCutBack) {
  mca::test::TempDir t;
  const fs::path scene = small_scene(t.path());
  const fs::path whole = t.path() / "whole";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + whole.string() + " -q --no-vtk").code, 0);
  const std::string expected = read(whole / "stats.csv");
  const std::vector<std::string> rows = lines(expected);  // header, frames 0..4
  ASSERT_EQ(rows.size(), 6u) << expected;

  // A run with checkpoints at frames 2 and 4; the newest is dropped, so it resumes from frame 2 and
  // stats.csv must end up as header + frames 0..2, then 3 and 4 written again.
  const fs::path base = t.path() / "base";
  ASSERT_EQ(run_mca("run " + scene.string() + " --out " + base.string() + " -q --no-vtk --checkpoint-every 2").code, 0);
  std::vector<fs::path> cks;
  for (const auto& e : fs::directory_iterator(base / "checkpoints")) cks.push_back(e.path());
  std::sort(cks.begin(), cks.end());
  ASSERT_EQ(cks.size(), 2u);
  fs::remove(cks.back());

  auto join = [&](std::size_t upto) {  // header and the rows of frames 0..upto-1, each with its line break
    std::string s;
    for (std::size_t k = 0; k <= upto; ++k) s += rows[k] + "\n";
    return s;
  };
  const std::string row2 = rows[3];
  const struct {
    const char* what;
    std::string stats;
  } cases[] = {
      {"rows past the checkpoint and a torn last row", join(5) + "5,0.0040"},
      {"rows past the checkpoint, then garbage", join(4) + "3,1,2\nnot a row\n"},
      {"the checkpoint's own row torn", join(2) + row2.substr(0, row2.size() / 2)},
      {"the checkpoint's own row lost", join(2)},
      {"the checkpoint's own row with a cell cut", join(2) + row2.substr(0, row2.rfind(',')) + "\n" + rows[4] + "\n"},
      {"a row of another frame in its place", join(2) + rows[4] + "\n" + rows[5] + "\n"},
      {"CR LF line ends (saved by an editor that writes them; every row was dropped)", [&] {
         std::string s;
         for (std::size_t k = 0; k <= 2; ++k) s += rows[k] + "\r\n";
         return s;
       }()},
      {"NUL bytes where the rows were (a crash before the data reached the disk)",
       join(2) + std::string(row2.size() + 1, '\0')},
  };
  int k = 0;
  for (const auto& c : cases) {
    SCOPED_TRACE(c.what);
    const fs::path out = t.path() / ("case" + std::to_string(k++));
    fs::copy(base, out, fs::copy_options::recursive);
    std::ofstream(out / "stats.csv", std::ios::binary | std::ios::trunc) << c.stats;
    const Result r = run_mca("resume " + out.string() + " -q");
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
    EXPECT_EQ(read(out / "stats.csv"), expected);
  }

  // A row lost before the checkpoint's own cannot be made again: the resume says which are missing, and
  // keeps only whole rows.
  const fs::path out = t.path() / "lost";
  fs::copy(base, out, fs::copy_options::recursive);
  std::ofstream(out / "stats.csv", std::ios::binary | std::ios::trunc) << join(1) + rows[2].substr(0, 5);
  const Result r = run_mca("resume " + out.string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("has 1 of the 3 rows up to the checkpoint"), std::string::npos) << r.output;
  const std::vector<std::string> got = lines(read(out / "stats.csv"));
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[0], rows[0]);
  EXPECT_EQ(got[1], rows[1]);
  EXPECT_EQ(got[2], rows[4]);
  EXPECT_EQ(got[3], rows[5]);
}

// Every file under dir with its size and time of writing, for "left as it was".
std::map<std::string, std::pair<std::uintmax_t, fs::file_time_type>> listing(const fs::path& dir) {
  std::map<std::string, std::pair<std::uintmax_t, fs::file_time_type>> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file()) out[fs::relative(e.path(), dir).string()] = {e.file_size(), e.last_write_time()};
  return out;
}

// The small wall run to its end into `out`, drawn (--render, small pictures) and checkpointed every two
// frames (frames 2 and 4, the last).
void rendered_run(const fs::path& dir, const fs::path& out) {
  const Result r = run_mca("run " + small_scene(dir).string() + " --out " + out.string() +
                           " -q --no-vtk --checkpoint-every 2 --render --render-size 160x90");
  ASSERT_EQ(r.code, 0) << r.output;
}

// A stats.csv that is not a regular file (a FIFO blocked the resume for ever, a link to /dev/zero read
// without end, a folder) is refused as the run's other inputs are, naming it and the fix, before any file
// is touched: a rendered run's video, contact sheet and pictures used to go first (and with --no-render,
// render.json).
TEST(ResumeStats, AStatsFileThatIsNotARegularFileIsRefused) {
  mca::test::TempDir t;
  const fs::path base = t.path() / "base";
  ASSERT_NO_FATAL_FAILURE(rendered_run(t.path(), base));
  ASSERT_TRUE(fs::exists(base / "render" / "contact_sheet.png"));
  ASSERT_TRUE(fs::remove(base / "checkpoints" / "frame_000004.mcack"));  // (frames are left to run)
  int k = 0;
  for (const char* kind : {"fifo", "zero", "folder", "folder, --no-render"}) {
    SCOPED_TRACE(kind);
    const fs::path out = t.path() / ("case" + std::to_string(k++));
    fs::copy(base, out, fs::copy_options::recursive);
    fs::remove(out / "stats.csv");
    if (std::string(kind) == "fifo") ASSERT_EQ(mca::test::shell("mkfifo " + (out / "stats.csv").string()).code, 0);
    else if (std::string(kind) == "zero") fs::create_symlink("/dev/zero", out / "stats.csv");
    else fs::create_directory(out / "stats.csv");
    const auto before = listing(out);
    const bool no_render = std::string(kind).find("no-render") != std::string::npos;
    const Result r = mca::test::shell("timeout 20 " + std::string(MCA_BINARY) + " resume " + out.string() + " -q" +
                                      (no_render ? " --no-render" : ""));
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("stats.csv"), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("remove it"), std::string::npos) << r.output;
    EXPECT_EQ(listing(out), before) << "the folder changed";
  }
}

// A resume removes what the earlier session wrote at its end (summary, fragments.csv, fragment meshes and,
// unless it draws them again, the plots) before it steps, so that one stopped by an error leaves none that
// would say "finished"; a run with no step left keeps its plots, and with --no-render its whole rendering.
TEST(ResumeStats, AResumeRemovesTheEarlierEndAndAFinishedRunKeepsItsPlots) {
  mca::test::TempDir t;
  const fs::path base = t.path() / "base";
  ASSERT_NO_FATAL_FAILURE(rendered_run(t.path(), base));
  const std::vector<std::string> plots = {"energies.png", "broken_links.png", "fragment_masses.png"};
  if (!fs::exists(base / "render" / "energies.png")) GTEST_SKIP() << "no plots here (python3-matplotlib)";
  // Finished: nothing to run, every output stays (the summary is written again).
  const fs::path finished = t.path() / "finished";
  fs::copy(base, finished, fs::copy_options::recursive);
  const auto drawn = listing(finished / "render");
  const Result f = run_mca("resume " + finished.string() + " --no-render");
  ASSERT_EQ(f.code, 0) << f.output;
  EXPECT_EQ(f.output.find("warning: --no-render"), std::string::npos) << f.output;
  EXPECT_EQ(listing(finished / "render"), drawn);
  for (const char* kept : {"summary.json", "fragments.csv"}) EXPECT_TRUE(fs::exists(finished / kept)) << kept;
  // Frames left, not drawn: the plots of the earlier end go, saying so (a resume stopped by a full GPU:
  // CudaEmulation.AFullGpuStopsARunWhichResumesOnTheCpuWithTheSameBits).
  const fs::path left = t.path() / "left";
  fs::copy(base, left, fs::copy_options::recursive);
  ASSERT_TRUE(fs::remove(left / "checkpoints" / "frame_000004.mcack"));
  const Result l = run_mca("resume " + left.string() + " --no-render");
  ASSERT_EQ(l.code, 0) << l.output;
  EXPECT_NE(l.output.find("the plots in " + (left / "render").string() + " showed the run up to frame 2 and are removed"),
            std::string::npos)
      << l.output;
  for (const auto& p : plots) EXPECT_FALSE(fs::exists(left / "render" / p)) << p;
  EXPECT_TRUE(fs::exists(left / "render" / "video.mp4"));  // (the frames drawn so far stay, as the warning says)
  EXPECT_NE(read(left / "summary.json").find("\"status\": \"finished\""), std::string::npos);
}

// Frames removed from a run's folder before its checkpoint: the checkpoint's own frame (VTK and PNG) is
// written again from its state, as the run wrote it; an earlier one cannot be, and the resume says so, the
// .pvd collections leave it out (they listed the missing files) and no video is made of a rendering with a
// hole (the earlier session's, of the whole run, is kept). Also when no step is left and no frame is
// written, where the collections used to stay as they were.
TEST(ResumeStats, FramesRemovedBeforeTheCheckpointAreLeftOutAndItsOwnIsWrittenAgain) {
  mca::test::TempDir t;
  const fs::path scene = small_scene(t.path());
  const fs::path base = t.path() / "base";
  const Result b = run_mca("run " + scene.string() + " --out " + base.string() +
                           " -q --checkpoint-every 2 --render --render-size 160x90");
  ASSERT_EQ(b.code, 0) << b.output;
  const std::string pvd = read(base / "automata.pvd");
  ASSERT_NE(pvd.find("automata_000004.vtu"), std::string::npos) << pvd;
  for (const bool finished : {false, true}) {
    SCOPED_TRACE(finished ? "no step left" : "steps left");
    const fs::path out = t.path() / (finished ? "finished" : "left");
    fs::copy(base, out, fs::copy_options::recursive);
    if (!finished) {
      ASSERT_TRUE(fs::remove(out / "checkpoints" / "frame_000004.mcack"));
    }
    const int own = finished ? 4 : 2;
    const std::string own_vtu = fmt::format("frames/automata_{:06d}.vtu", own);
    const std::string own_ball = fmt::format("frames/projectiles_{:06d}.vtu", own);
    const std::string own_png = fmt::format("render/frame_{:06d}.png", own);
    // Frame 1 loses its automata only, the checkpoint's frame its ball (its automata stay: it was listed
    // twice once written again) and its picture, which is made garbage.
    // (With no step left, frame 1's automata are cut short instead, as an interrupted copy leaves a file:
    // it was listed, and ParaView read no points there.)
    std::vector<std::string> gone = {"render/frame_000001.png"};
    if (!finished) gone.push_back(own_ball);  // (with none, the .pvd is written by the frame)
    if (!finished) gone.push_back("frames/automata_000001.vtu");
    for (const auto& g : gone) ASSERT_TRUE(fs::remove(out / g)) << g;
    if (finished) fs::resize_file(out / "frames/automata_000001.vtu", fs::file_size(out / "frames/automata_000001.vtu") / 2);
    if (!finished) std::ofstream(out / own_png, std::ios::trunc) << "not a PNG";
    const Result r = run_mca("resume " + out.string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find(fmt::format("warning: {} lacks whole files (missing, empty or cut short) of 1 of the {} "
                                        "frames before the checkpoint (frame 1)",
                                        out.string(), own)),
              std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("warning: 1 frame drawn before the checkpoint cannot be read (frame 1; "), std::string::npos)
        << r.output;
    EXPECT_NE(r.output.find("render: 4 frames (frame_NNNNNN.png) and contact_sheet.png in " + (out / "render").string() +
                            ", 1 lost before a resume"),
              std::string::npos)
        << r.output;
    // No whole video can be made again: the finished run's, of every frame, is kept, as is its contact sheet
    // (the video was removed).
    EXPECT_NE(r.output.find("render/video.mp4 of the run's earlier session is kept, as is its contact_sheet.png"),
              std::string::npos)
        << r.output;
    for (const char* kept : {"render/video.mp4", "render/contact_sheet.png"})
      EXPECT_EQ(read(out / kept), read(base / kept)) << kept;
    // The checkpoint's own frame is the run's, byte for byte.
    for (const auto& f : {own_vtu, own_ball, own_png}) EXPECT_EQ(read(out / f), read(base / f)) << f;
    // Both collections leave frame 1 out (the ball's file of it is there), and list every other frame once.
    for (const char* collection : {"automata.pvd", "projectiles.pvd"}) {
      std::string expected = read(base / collection);
      const std::size_t at = expected.find("    <DataSet timestep=\"0.001");
      ASSERT_NE(at, std::string::npos) << expected;
      expected.erase(at, expected.find('\n', at) + 1 - at);
      EXPECT_EQ(read(out / collection), expected) << collection;
    }
    EXPECT_EQ(read(out / "stats.csv"), read(base / "stats.csv"));
  }
  // Nothing removed: the collections are the run's.
  const fs::path whole = t.path() / "whole";
  fs::copy(base, whole, fs::copy_options::recursive);
  ASSERT_TRUE(fs::remove(whole / "checkpoints" / "frame_000004.mcack"));
  const Result w = run_mca("resume " + whole.string() + " -q");
  ASSERT_EQ(w.code, 0) << w.output;
  EXPECT_EQ(w.output.find("warning"), std::string::npos) << w.output;
  EXPECT_EQ(read(whole / "automata.pvd"), pvd);
  EXPECT_TRUE(fs::exists(whole / "render" / "video.mp4"));
}

}  // namespace
