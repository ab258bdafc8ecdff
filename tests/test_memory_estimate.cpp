// `mca info`'s memory estimate is the peak of the whole run, the build included: a volume-filled mesh
// holds arrays over its whole box of cells while its lattice is built, which for a mesh of parts far
// apart is far more than the run's arrays. The estimate left it out and was below the measured peak.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "mesh_fixtures.hpp"
#include "shell.hpp"
#include "small_scene.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
using mca::test::read;
using mca::test::Result;
using mca::test::run_mca;

TEST(MemoryEstimate, TheBuildOfAMeshOfPartsFarApartIsCounted) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine triple the resident size";
#endif
  mca::test::TempDir t;
  // Two 0.2 m cubes 50 m apart in one mesh, at 5 mm: 128,000 automata (about 94 MB of the run's arrays)
  // in a box of 10,040 x 40 x 40 cells (about 177 MB while the lattice is built). On the cubic lattice,
  // whose run holds less than its build (the random lattice's run holds 392 MB, its build less).
  mca::mesh::TriMesh m = mca::test::cube_mesh(0.1);
  const mca::mesh::TriMesh far = mca::test::cube_mesh(0.1, {50, 0, 0});
  for (const auto& f : far.faces)
    m.faces.push_back({f[0] + 8, f[1] + 8, f[2] + 8});
  m.vertices.insert(m.vertices.end(), far.vertices.begin(), far.vertices.end());
  mca::test::write_mesh_file(t.path() / "two.off", m);
  const fs::path scene = t.path() / "far.toml";
  std::ofstream(scene) << R"(name = "far"
[solver]
spacing = 0.005
lattice = "cubic"
gravity = [0, 0, 0]
[output]
frame_rate = 1e6
duration = 2e-6
vtk = false
[[object]]
shape = "mesh"
mesh = "two.off"
)";
  const Result info = run_mca("info " + scene.string() + " --json");
  ASSERT_EQ(info.code, 0) << info.output;
  const auto j = nlohmann::json::parse(info.output);
  EXPECT_EQ(j["automata"], 2 * 40 * 40 * 40);
  const double estimate = j["memory_bytes"].get<double>();
  EXPECT_GT(j["memory"]["build"].get<double>(), 1.3 * j["memory"]["arrays"].get<double>());
  EXPECT_EQ(estimate, j["memory"]["build"].get<double>());
  const Result text = run_mca("info " + scene.string());
  EXPECT_NE(text.output.find("at the peak of the build"), std::string::npos) << text.output;
  EXPECT_NE(text.output.find("give each part its own object"), std::string::npos) << text.output;

  const Result r = run_mca("run " + scene.string() + " --out " + (t.path() / "out").string() + " -q");
  ASSERT_EQ(r.code, 0) << r.output;
  const double peak = nlohmann::json::parse(read(t.path() / "out" / "summary.json"))["peak_memory_bytes"].get<double>();
  std::printf("two cubes 50 m apart: estimate %.1f MB, peak resident %.1f MB\n", estimate / 1e6, peak / 1e6);
  EXPECT_GT(estimate, 0.95 * peak);
  EXPECT_LT(estimate, 1.5 * peak);
}

}  // namespace
