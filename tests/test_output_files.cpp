#include "io/output_files.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <unistd.h>

#include "mca/error.hpp"

namespace fs = std::filesystem;
using mca::io::prepare_output_dir;
using mca::io::write_file_atomic;

namespace {

class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = fs::temp_directory_path() /
            (std::string("mca_test_") + info->test_suite_name() + "_" + info->name() + "_" +
             std::to_string(::getpid()));
    fs::remove_all(path_);
    fs::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

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
