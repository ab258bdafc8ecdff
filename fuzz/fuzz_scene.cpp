// libFuzzer target: the scene reader, mca::io::parse_scene (TOML text -> validated SceneDef).
//
// Bad input must end in mca::Error (syntax, unknown key, wrong type, out-of-range value, a mesh file that
// is not there); anything else (another exception, a crash, a hang, a leak, undefined behaviour) is a
// finding. A scene that parses is also written back with scene_to_toml and parsed again: the writer
// promises an exact round trip, so a scene it cannot read back, or reads back different, is a finding too.
//
// Mesh objects name files, which the reader looks up (it does not read them). The text is parsed as if it
// were <folder of this program>/fuzz_scene_files/fuzz.toml, a folder made at start-up holding tetra.off,
// ellipsoid.off and the meshes the example scenes name (bunny00.off, armadillo.off), so seeds can name those; the models cache (XDG_CACHE_HOME) points there too and
// MCA_MESH_PATH is unset, so what is found does not depend on the machine.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>

#include <mca/error.hpp>
#include <mca/scene.hpp>

#include "io/scene_io.hpp"

namespace {

std::string g_source = "fuzz.toml";

[[noreturn]] void die(const char* what, const std::string& detail) {
  std::fprintf(stderr, "fuzz_scene: %s\n%s\n", what, detail.c_str());
  std::abort();
}

void write_file(const std::filesystem::path& p, const char* text) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out << text;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* argc, char*** argv) {
  (void)argc;
  std::error_code ec;
  std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) exe = std::filesystem::absolute((*argv)[0], ec);
  const std::filesystem::path dir = exe.parent_path() / "fuzz_scene_files";
  std::filesystem::create_directories(dir / "cache" / "mca" / "models", ec);
  // A closed tetrahedron and an octahedron (the "ellipsoid" of a region), as OFF.
  const char* tetra = "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  write_file(dir / "tetra.off", tetra);
  // The names the example scenes use (scenes/bunny*.toml, armadillo.toml), so that they parse whole.
  write_file(dir / "bunny00.off", tetra);
  write_file(dir / "armadillo.off", tetra);
  write_file(dir / "ellipsoid.off",
             "OFF\n6 8 0\n0.2 0 0\n-0.2 0 0\n0 0.3 0\n0 -0.3 0\n0 0 0.5\n0 0 -0.5\n"
             "3 0 2 4\n3 2 1 4\n3 1 3 4\n3 3 0 4\n3 2 0 5\n3 1 2 5\n3 3 1 5\n3 0 3 5\n");
  write_file(dir / "cache" / "mca" / "models" / "cached.off", tetra);
  setenv("XDG_CACHE_HOME", (dir / "cache").c_str(), 1);
  unsetenv("MCA_MESH_PATH");
  g_source = (dir / "fuzz.toml").string();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  mca::SceneDef scene;
  try {
    scene = mca::io::parse_scene(text, g_source);
  } catch (const mca::Error&) {
    return 0;  // refused with a message: the expected outcome for bad input
  }
  // The scene was accepted: its TOML form must read back to the same scene.
  const std::string written = mca::io::scene_to_toml(scene);
  mca::SceneDef again;
  try {
    again = mca::io::parse_scene(written, scene.source);
  } catch (const mca::Error& e) {
    die("scene_to_toml wrote a scene that parse_scene refuses", std::string(e.what()) + "\n---\n" + written);
  }
  const std::string rewritten = mca::io::scene_to_toml(again);
  if (rewritten != written) {
    die("scene_to_toml(parse_scene(scene_to_toml(s))) differs from scene_to_toml(s)",
        written + "\n--- read back as ---\n" + rewritten);
  }
  return 0;
}
