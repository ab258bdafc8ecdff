// Files named by the user that are not regular files: a FIFO blocked the scene reader until something
// wrote to it (forever), /dev/zero was read up to the size limit. Every reader refuses them alike, before
// opening them, naming the path, what it is and the fix.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <mca/error.hpp>

#include "core/files.hpp"
#include "io/checkpoint.hpp"
#include "io/scene_io.hpp"
#include "mesh/mesh.hpp"
#include "shell.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using mca::test::Result;
using mca::test::shell;

#define EXPECT_HAS(message, part) EXPECT_NE((message).find(part), std::string::npos) << "message: " << (message)

// f's mca::Error message, got in a child process so that a reader that blocks (on a FIFO) fails the test
// instead of hanging it: "timed out" after 10 s, "no error" when f returns.
template <class F>
std::string error_in_child(F&& f) {
  int fds[2];
  if (pipe(fds) != 0) return "pipe failed";
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    std::string m = "no error";
    try {
      f();
    } catch (const mca::Error& e) {
      m = e.what();
    }
    [[maybe_unused]] const ssize_t n = write(fds[1], m.data(), m.size());
    _exit(0);
  }
  close(fds[1]);
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() > until) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      close(fds[0]);
      return "timed out";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  std::string m;
  char buf[4096];
  for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) > 0;) m.append(buf, static_cast<std::size_t>(n));
  close(fds[0]);
  return m;
}

// A listening-less UNIX socket bound at p (removed with the folder).
void make_socket(const fs::path& p) {
  const int s = socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(s, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  ASSERT_LT(p.string().size(), sizeof a.sun_path);
  std::strcpy(a.sun_path, p.c_str());
  ASSERT_EQ(bind(s, reinterpret_cast<sockaddr*>(&a), sizeof a), 0) << std::strerror(errno);
  close(s);
}

// `mca ARGS` under a 20 s limit (a reader that blocks is killed: exit 124).
Result mca_limited(const std::string& args) { return shell("timeout 20 " + std::string(MCA_BINARY) + " " + args); }

struct Odd {
  fs::path path;
  const char* kind;
};

std::vector<Odd> odd_files(const fs::path& dir) {
  fs::create_directories(dir / "folder.toml");
  EXPECT_EQ(mkfifo((dir / "fifo.toml").c_str(), 0600), 0) << std::strerror(errno);
  make_socket(dir / "s.toml");
  return {{dir / "fifo.toml", "a FIFO (named pipe)"},
          {dir / "folder.toml", "a directory"},
          {"/dev/zero", "a character device"},
          {dir / "s.toml", "a socket"}};
}

TEST(InputFiles, ANonRegularSceneFileIsRefused) {
  mca::test::TempDir t;
  for (const Odd& o : odd_files(t.path())) {
    for (const char* command : {"info ", "run -q --out "}) {
      const std::string args = std::string(command) + (command[0] == 'r' ? (t.path() / "out").string() + " " : "");
      const Result r = mca_limited(args + o.path.string());
      EXPECT_EQ(r.code, 2) << o.path << ": " << r.output;
      EXPECT_HAS(r.output, o.path.string() + ": is " + o.kind + ", not a scene file");
      EXPECT_HAS(r.output, "give the path of a .toml file");
      EXPECT_FALSE(fs::exists(t.path() / "out")) << "an output folder was made";
    }
  }
}

TEST(InputFiles, ANonRegularMeshFileIsRefused) {
  mca::test::TempDir t;
  for (const char* name : {"fifo.off", "folder.off"}) {
    if (name[0] == 'f' && name[1] == 'i') ASSERT_EQ(mkfifo((t.path() / name).c_str(), 0600), 0);
    else fs::create_directories(t.path() / name);
    const fs::path mesh = t.path() / name;
    // Named by a scene.
    std::ofstream(t.path() / "m.toml") << "[[object]]\nshape = \"mesh\"\nmesh = \"" << name << "\"\n";
    Result r = mca_limited("info " + (t.path() / "m.toml").string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_HAS(r.output, "object[0].mesh = \"" + std::string(name) + "\"");
    EXPECT_HAS(r.output, mesh.string() + " is a");
    EXPECT_HAS(r.output, "not a mesh file");
    // Read directly, as the library's users and the fuzz target do.
    const std::string m = error_in_child([&] { mca::mesh::read_mesh(mesh.string()); });
    EXPECT_HAS(m, mesh.string() + ": is a");
    EXPECT_HAS(m, "give the path of a mesh file");
  }
  EXPECT_HAS(error_in_child([] { mca::mesh::read_mesh("/dev/zero"); }), "/dev/zero: is a character device");
}

// A path the system cannot follow (a loop of symbolic links, a name longer than the file system allows)
// is reported with the system's reason, not as "not found" nor as a raw filesystem exception.
TEST(InputFiles, APathThatCannotBeFollowedNamesTheReason) {
  mca::test::TempDir t;
  const fs::path a = t.path() / "loop_a", b = t.path() / "loop_b";
  fs::create_symlink(b, a);
  fs::create_symlink(a, b);
  const std::string loop = "Too many levels of symbolic links";
  Result r = mca_limited("info " + a.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, a.string() + ": cannot reach the scene file (" + loop + ")");
  std::ofstream(t.path() / "m.toml") << "[[object]]\nshape = \"mesh\"\nmesh = \"loop_a\"\n";
  r = mca_limited("info " + (t.path() / "m.toml").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, "object[0].mesh = \"loop_a\": " + a.string() + " cannot be reached (" + loop + ")");
  r = mca_limited("run -q --steps 1 --out " + (a / "x").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, "output folder '" + (a / "x").string() + "' is not usable: " + loop);
  r = mca_limited("resume " + a.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, "'" + a.string() + "' cannot be reached (" + loop + ")");
  // A link to a folder not made yet said "File exists ... fix its permissions".
  fs::create_symlink(t.path() / "not_yet", t.path() / "scratch");
  r = mca_limited("run -q --steps 1 --out " + (t.path() / "scratch").string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, "is not usable: it is a symbolic link to '" + (t.path() / "not_yet").string() +
                           "', which does not exist; make that folder first (mkdir -p " + (t.path() / "not_yet").string() + ")");
  r = mca_limited("run -q --steps 1 --out " + a.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, "is not usable: " + loop);
  const fs::path long_name = t.path() / std::string(300, 'a');
  r = mca_limited("run -q --steps 1 --out " + long_name.string());
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_HAS(r.output, "is not usable: File name too long; choose another output folder (--out)");
  EXPECT_EQ(r.output.find("filesystem error"), std::string::npos) << r.output;
}

TEST(InputFiles, ANonRegularCheckpointIsRefused) {
  mca::test::TempDir t;
  for (const Odd& o : odd_files(t.path())) {
    const std::string m = error_in_child([&] { mca::io::read_checkpoint(o.path); });
    EXPECT_HAS(m, o.path.string() + ": is " + o.kind + ", not a checkpoint");
    EXPECT_HAS(m, "--checkpoint-every");
  }
}

TEST(InputFiles, ANonRegularViewScriptIsRefused) {
  mca::test::TempDir t;
  for (const Odd& o : odd_files(t.path())) {
    const Result r = shell("env -u DISPLAY -u WAYLAND_DISPLAY timeout 20 " + std::string(MCA_BINARY) +
                           " view --frames 1 --script " + o.path.string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_HAS(r.output, "--script " + o.path.string() + ": is " + o.kind);
    EXPECT_HAS(r.output, "'TIME X Y'");
  }
}

TEST(InputFiles, TheKindOfAPathIsNamed) {
  mca::test::TempDir t;
  std::ofstream(t.path() / "plain.toml") << "";
  fs::create_symlink(t.path() / "plain.toml", t.path() / "link.toml");
  EXPECT_EQ(mca::files::non_regular_kind(t.path() / "plain.toml"), "");
  EXPECT_EQ(mca::files::non_regular_kind(t.path() / "link.toml"), "") << "a link to a regular file is one";
  EXPECT_EQ(mca::files::non_regular_kind(t.path() / "missing.toml"), "") << "left to the reader's own message";
  for (const Odd& o : odd_files(t.path())) EXPECT_EQ(mca::files::non_regular_kind(o.path), o.kind);
}

}  // namespace
