// What a run writes per frame (app/frame_output): stats.csv grows by one appended row per frame
// instead of being rewritten (which made a run quadratic in its frame count).
#include "app/frame_output.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/stat.h>
#include <unistd.h>

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

TEST(FrameOutput, StatsGetOneAppendedRowPerFrame) {
  const fs::path dir = fs::temp_directory_path() / ("mca_test_frame_output_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  Engine sim(test::block_scene(2, 2, 2));
  {
    OutputDef no_frames;
    no_frames.vtk = false;
    app::FrameWriter w(dir, sim.model(), no_frames);
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

}  // namespace
}  // namespace mca
