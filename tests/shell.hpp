#pragma once
// Runs shell command lines and the mca program from tests (stdout and stderr together, and the exit code).
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace mca::test {

struct Result {
  int code = -1;
  std::string output;  // stdout and stderr
};

inline Result shell(const std::string& command) {
  const std::string cmd = "(" + command + ") 2>&1";
  Result r;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  std::size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) r.output.append(buf.data(), n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

inline Result run_mca(const std::string& args) { return shell(std::string(MCA_BINARY) + " " + args); }

// mca with a file-system fault at one file (the preloaded tests/fault/file_faults.cpp): `fault` is
// MCA_TEST_FULL_AT (the disk is full when it comes to write the file whose path ends in `at`) or
// MCA_TEST_PINNED_AT (that file cannot be removed or renamed). (ASan, where the build has it, asks to be
// loaded first; the preload is.)
inline Result run_mca_with_fault(const std::string& fault, const std::string& at, const std::string& args) {
  return shell("LD_PRELOAD=" + std::string(MCA_FILE_FAULTS) + " " + fault + "=" + at +
               " ASAN_OPTIONS=verify_asan_link_order=0 " + std::string(MCA_BINARY) + " " + args);
}

inline Result run_mca_full_at(const std::string& at, const std::string& args) {
  return run_mca_with_fault("MCA_TEST_FULL_AT", at, args);
}

}  // namespace mca::test
