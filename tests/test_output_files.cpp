#include "io/output_files.hpp"

#include <gtest/gtest.h>

#include "temp_dir.hpp"

#include <atomic>
#include <cctype>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "mca/error.hpp"

namespace fs = std::filesystem;
using mca::io::prepare_output_dir;
using mca::io::write_file_atomic;

using mca::test::slurp;
using mca::test::TempDir;

namespace {


}  // namespace

TEST(OutputFiles, AtomicWriteProducesTheFile) {
  TempDir dir;
  const fs::path file = dir.path() / "a.bin";
  write_file_atomic(file, [](std::ostream& out) { out << "hello" << '\0' << "world"; });
  EXPECT_EQ(slurp(file), std::string("hello\0world", 11));
  EXPECT_FALSE(fs::exists(dir.path() / "a.bin.tmp"));

  // A second write replaces the content.
  write_file_atomic(file, [](std::ostream& out) { out << "again"; }, false);
  EXPECT_EQ(slurp(file), "again");
  EXPECT_FALSE(fs::exists(dir.path() / "a.bin.tmp"));
}

TEST(OutputFiles, ThrowingWriterLeavesNoFile) {
  TempDir dir;
  const fs::path file = dir.path() / "b.vtu";
  try {
    write_file_atomic(file, [](std::ostream& out) {
      out << "half of it";
      throw std::runtime_error("simulated failure");
    });
    FAIL() << "expected mca::Error";
  } catch (const mca::Error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("simulated failure"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(file));
  EXPECT_FALSE(fs::exists(dir.path() / "b.vtu.tmp"));
}

TEST(OutputFiles, ThrowingWriterKeepsThePreviousFile) {
  TempDir dir;
  const fs::path file = dir.path() / "c.txt";
  write_file_atomic(file, [](std::ostream& out) { out << "complete"; });
  EXPECT_THROW(write_file_atomic(file,
                                 [](std::ostream& out) {
                                   out << "partial";
                                   throw std::runtime_error("interrupted");
                                 }),
               mca::Error);
  EXPECT_EQ(slurp(file), "complete");
  EXPECT_FALSE(fs::exists(dir.path() / "c.txt.tmp"));
}

TEST(OutputFiles, WriteIntoMissingFolderThrowsNamingThePath) {
  TempDir dir;
  const fs::path file = dir.path() / "missing" / "d.txt";
  try {
    write_file_atomic(file, [](std::ostream& out) { out << "x"; });
    FAIL() << "expected mca::Error";
  } catch (const mca::Error& e) {
    EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
  }
}

TEST(OutputFiles, PrepareCreatesNestedFolder) {
  TempDir dir;
  const fs::path out = dir.path() / "run" / "frames";
  prepare_output_dir(out);
  EXPECT_TRUE(fs::is_directory(out));
  EXPECT_TRUE(fs::is_empty(out));  // the probe file is gone
  prepare_output_dir(out);         // an existing folder is fine
}

TEST(OutputFiles, PrepareUnderARegularFileThrows) {
  // A path below a regular file cannot be created even by root, unlike a permissions test.
  TempDir dir;
  const fs::path file = dir.path() / "plain_file";
  std::ofstream(file) << "x";
  const fs::path out = file / "out";
  try {
    prepare_output_dir(out);
    FAIL() << "expected mca::Error";
  } catch (const mca::Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(out.string()), std::string::npos) << what;
    EXPECT_NE(what.find("--out"), std::string::npos) << what;
  }
}

TEST(OutputFiles, PrepareOnARegularFileThrows) {
  TempDir dir;
  const fs::path file = dir.path() / "plain_file";
  std::ofstream(file) << "x";
  EXPECT_THROW(prepare_output_dir(file), mca::Error);
}

// The default output folder is out/<folder name of the scene name>; a scene file from anywhere must not
// pick where the run writes or deletes files.
TEST(OutputFiles, SceneNameGivesADirectChildOfOut) {
  using mca::io::scene_folder_name;
  EXPECT_EQ(scene_folder_name("wall_ball"), "wall_ball");
  EXPECT_EQ(scene_folder_name("wall-ball.v2"), "wall-ball.v2");
  const std::vector<std::string> hostile = {
      "../escaped", "/tmp/abs", "..", ".", "a/b", "", "my scene", "b\xC3\xA9ton \xE6\x97\xA5\xE6\x9C\xAC",
      "a\\b", "x/../../y", "...", ".hidden", "-rf", std::string(1000, 'a'), std::string("nul\0byte", 8),
      "tab\there", "/", "./"};
  for (const auto& name : hostile) {
    const std::string f = scene_folder_name(name);
    SCOPED_TRACE(name);
    ASSERT_FALSE(f.empty());
    EXPECT_LE(f.size(), 100u);
    EXPECT_NE(f, ".");
    EXPECT_NE(f, "..");
    EXPECT_NE(f.front(), '.');  // no hidden folders, and neither "." nor ".."
    EXPECT_NE(f.front(), '-');  // not mistaken for an option in a shell command
    for (const char c : f)
      EXPECT_TRUE(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-') << f;
    const fs::path p = fs::path("out") / f;
    EXPECT_EQ(p.parent_path(), fs::path("out"));
    EXPECT_EQ(p.filename().string(), f);
  }
  EXPECT_EQ(scene_folder_name("a/b"), "a_b");
  EXPECT_EQ(scene_folder_name("my scene"), "my_scene");
  EXPECT_EQ(scene_folder_name(""), "scene");
  // One '_' per character, not per UTF-8 byte.
  EXPECT_EQ(scene_folder_name("b\xC3\xA9ton"), "b_ton");
  // Distinct hostile names still give stable, readable folders.
  EXPECT_EQ(scene_folder_name("../escaped"), "___escaped");
  EXPECT_EQ(scene_folder_name(".."), "__");
  EXPECT_EQ(scene_folder_name("-rf"), "_rf");
}

// Two writers of one file (two runs into one folder, or two threads) must not share a temporary file:
// one would truncate or rename the other's half-written file.
TEST(OutputFiles, WritersOfOneFileUseTheirOwnTemporaryFiles) {
  TempDir dir;
  const fs::path file = dir.path() / "stats.csv";
  write_file_atomic(file, [&](std::ostream& out) {
    out << "outer";
    // Another writer of the same file finishes while this one is open.
    write_file_atomic(file, [](std::ostream& o) { o << "inner"; });
    EXPECT_EQ(slurp(file), "inner");
    // This writer's temporary file names the process, so other processes cannot pick the same name.
    bool own = false;
    for (const auto& e : fs::directory_iterator(dir.path())) {
      const std::string name = e.path().filename().string();
      own = own || (name.rfind("stats.csv.", 0) == 0 && name.find("." + std::to_string(::getpid()) + ".") !=
                                                              std::string::npos &&
                    e.path().extension() == ".tmp");
    }
    EXPECT_TRUE(own);
  });
  EXPECT_EQ(slurp(file), "outer");
  for (const auto& e : fs::directory_iterator(dir.path())) EXPECT_EQ(e.path(), file) << "left behind";
}

TEST(OutputFiles, ConcurrentWritersOfOneFileDoNotCollide) {
  TempDir dir;
  const fs::path file = dir.path() / "summary.json";
  std::atomic<int> failures{0};
  auto writer = [&](char c) {
    for (int k = 0; k < 200; ++k) {
      try {
        write_file_atomic(file, [&](std::ostream& out) { out << std::string(4096, c); });
      } catch (const mca::Error&) {
        ++failures;
      }
    }
  };
  std::thread a(writer, 'a'), b(writer, 'b');
  a.join();
  b.join();
  EXPECT_EQ(failures, 0);
  const std::string last = slurp(file);
  EXPECT_TRUE(last == std::string(4096, 'a') || last == std::string(4096, 'b'));
  for (const auto& e : fs::directory_iterator(dir.path())) EXPECT_EQ(e.path(), file) << "left behind";
}

// Checkpoints are flushed to the disk (fsync of the file and its folder): the write still gives the file.
TEST(OutputFiles, SyncedWriteProducesTheFile) {
  TempDir dir;
  const fs::path file = dir.path() / "frame_000001.mcack";
  write_file_atomic(file, [](std::ostream& out) { out << "state"; }, true, mca::io::Durability::synced);
  EXPECT_EQ(slurp(file), "state");
}

// Temporary files of a process that died (a killed run) are removed at the start of the next run; those
// of a live process (a run writing there now) and files that are not ours stay.
TEST(OutputFiles, StaleTemporaryFilesOfDeadProcessesAreRemoved) {
  TempDir dir;
  const fs::path dead = dir.path() / "automata.pvd.999999999.3.tmp";  // above any pid Linux gives
  const fs::path live = dir.path() / ("automata.pvd." + std::to_string(::getpid()) + ".0.tmp");
  const fs::path user = dir.path() / "notes.tmp";
  const fs::path other = dir.path() / "a.b.c.tmp";
  const fs::path dated = dir.path() / "notes.2024.01.tmp";  // looks like ours, but not a run's output
  for (const auto& p : {dead, live, user, other, dated}) std::ofstream(p) << "x";
  mca::io::remove_stale_temporaries(dir.path());
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(live));
  EXPECT_TRUE(fs::exists(user));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_TRUE(fs::exists(dated));
  mca::io::remove_stale_temporaries(dir.path() / "missing");  // no folder: nothing to do
}
