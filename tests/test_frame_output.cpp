// What a run writes per frame (app/frame_output): stats.csv grows by one appended row per frame
// instead of being rewritten (which made a run quadratic in its frame count).
#include "app/frame_output.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <csignal>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "mca/error.hpp"
#include "support.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

ino_t inode(const fs::path& p) {
  struct stat st {};
  EXPECT_EQ(::stat(p.c_str(), &st), 0) << p;
  return st.st_ino;
}

// An empty folder of this test process.
fs::path fresh_folder(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// What a run writes without VTK frames: stats.csv (and the end's files).
OutputDef stats_only() {
  OutputDef o;
  o.vtk = false;
  return o;
}

TEST(FrameOutput, StatsGetOneAppendedRowPerFrame) {
  const fs::path dir = fresh_folder("mca_test_frame_output");
  Engine sim(test::block_scene(2, 2, 2));
  {
    app::FrameWriter w(dir, sim.model(), stats_only());
    w.start_stats({"0,a", "1,b"});  // a resume starts with the rows up to its checkpoint
    const fs::path csv = dir / "stats.csv";
    const ino_t first = inode(csv);
    std::string expected;
    const auto header = app::FrameWriter::stats_header(sim.model());
    for (std::size_t k = 0; k < header.size(); ++k) expected += (k ? "," : "") + header[k];
    expected += "\n0,a\n1,b\n";
    EXPECT_EQ(slurp(csv), expected);
    for (int f = 2; f < 2000; ++f) {
      w.append_stats(std::to_string(f) + ",row");
      expected += std::to_string(f) + ",row\n";
    }
    // Appended in place: the same file, not a new one renamed over it each frame.
    EXPECT_EQ(inode(csv), first);
    EXPECT_EQ(slurp(csv), expected);
    // Starting again (a new run, or a resume) replaces the file with the rows given.
    w.start_stats({"0,z"});
    w.append_stats("1,y");
    EXPECT_EQ(slurp(csv).substr(slurp(csv).find('\n') + 1), "0,z\n1,y\n");
  }
  fs::remove_all(dir);
}

// A row the disk takes only part of (the disk fills in the middle of it) is cut off again: stats.csv holds
// whole rows only. Before, a full disk left "30,0.030" under a header of 17 fields (the hostile review of
// 2026-12-06). The disk filling is played by the process's file size limit, which lets a write take what fits
// and fails the next one (EFBIG; SIGXFSZ ignored).
TEST(FrameOutput, ARowTheDiskTakesOnlyPartOfIsCutOffAgain) {
  const fs::path dir = fresh_folder("mca_test_frame_output_full");
  Engine sim(test::block_scene(2, 2, 2));
  app::FrameWriter w(dir, sim.model(), stats_only());
  w.start_stats({"0,a"});
  const fs::path csv = dir / "stats.csv";
  const std::string before = slurp(csv);
  const std::string row(200, '7');
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  rlimit small = old;
  small.rlim_cur = before.size() + 50;  // room for 50 of the row's 201 bytes
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  try {
    w.append_stats(row);
  } catch (const Error& e) {
    message = e.what();
  }
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &old), 0);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find("could not write '" + csv.string() + "'"), std::string::npos) << message;
  EXPECT_NE(message.find("size limit"), std::string::npos) << message;
  EXPECT_EQ(slurp(csv), before);
  // The file goes on from there once there is room.
  w.append_stats("1,b");
  EXPECT_EQ(slurp(csv), before + "1,b\n");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace mca
