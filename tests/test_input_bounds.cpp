// Input that could exhaust the stack or the memory is refused up front with a message naming the file:
// scene keys nested too deep, mesh files whose headers or sizes do not add up, models whose arrays
// would outgrow solver.max_memory_gb; and the smaller consistency rules of the scene checks.
#include <chrono>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <mca/error.hpp>
#include <mca/scene.hpp>

#include "core/text.hpp"
#include "io/scene_io.hpp"
#include "mesh_fixtures.hpp"
#include "lattice/lattice.hpp"
#include "mesh/mesh.hpp"
#include "shell.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace {

using mca::test::error_of;

#define EXPECT_HAS(message, part) EXPECT_NE((message).find(part), std::string::npos) << "message: " << (message)

const std::string kWall = R"(name = "t"
[[object]]
name = "wall"
size = [1, 0.2, 1]
material = "concrete"
)";

std::string parse_error(const std::string& text) {
  return error_of([&] { mca::io::parse_scene(text, "deep.toml"); });
}

// Item 11: toml++ recurses once per dotted part of a key; 50,000 parts overflowed the stack (exit 139).
TEST(InputBounds, DeepDottedKeyIsRefusedWithItsLine) {
  std::string key = "a";
  for (int i = 0; i < 50000; ++i) key += ".a";
  const std::string m = parse_error(kWall + "\n" + key + " = 1\n");
  EXPECT_HAS(m, "deep.toml:7:");
  EXPECT_HAS(m, "dotted parts");
}

TEST(InputBounds, DeepTableHeaderIsRefusedWithItsLine) {
  std::string key = "t";
  for (int i = 0; i < 60000; ++i) key += ".t";
  const std::string m = parse_error("name = \"x\"\n[" + key + "]\nv = 1\n");
  EXPECT_HAS(m, "deep.toml:2:");
  EXPECT_HAS(m, "dotted parts");
}

TEST(InputBounds, DotsInStringsAndNumbersAreNotKeyParts) {
  // Dots inside strings, comments and numbers do not count; a long dotted value string is fine.
  std::string dots(100000, '.');
  const std::string text = kWall + "# " + dots + "\n[[object.region]]\nshape = \"box\"\ncenter = [0.5, 0.25, 0.125]\n"
                           "size = [0.1, 0.1, 0.1]\nmaterial = \"glass\"\n[[projectile]]\nname = \"" + dots +
                           "\"\nposition = [3.5, 0.0, 0.0]\n";
  EXPECT_EQ(parse_error(text), "");
}

TEST(InputBounds, LongKeyIsRefused) {
  const std::string m = parse_error(kWall + std::string(5000, 'k') + " = 1\n");
  EXPECT_HAS(m, "deep.toml:6:");
  EXPECT_HAS(m, "5000 characters");
}

// One copy of the number and name formatting serves the reader and validate_scene.
TEST(InputBounds, ValidationFormatsNumbersAndNamesAsTheReader) {
  EXPECT_EQ(mca::text::num(1.5e-4), "1.5e-4");
  EXPECT_EQ(mca::text::num(3e10), "3e10");
  std::string m = parse_error(kWall + "[[material]]\nname = \"m\"\nfracture_strain = -1.5e-4\n");
  EXPECT_HAS(m, "= -1.5e-4 ");
  mca::SceneDef s = mca::io::parse_scene(kWall, "s.toml");
  mca::GripDef g;
  g.name = "a\fb";
  g.min = {-1, -1, -1};
  g.max = {1, 1, 1};
  s.grips.push_back(g);
  m = error_of([&] { mca::validate_scene(s); });
  EXPECT_HAS(m, "\"a\\fb\"");
}

// Documented: positions within 1e6 m of the origin, a distance, not each component.
TEST(InputBounds, PositionsAreCheckedByDistanceFromTheOrigin) {
  mca::SceneDef s = mca::io::parse_scene(kWall, "s.toml");
  s.objects[0].position = {0.8e6, 0.8e6, 0};  // each component within 1e6, 1.13e6 m out
  EXPECT_HAS(error_of([&] { mca::validate_scene(s); }), "more than 1e6 m from the origin");
  s.objects[0].position = {0.5e6, 0.5e6, 0.5e6};  // 0.87e6 m out
  EXPECT_EQ(error_of([&] { mca::validate_scene(s); }), "");
}

// A box or sphere region that holds no automaton is refused, as a mesh region is.
TEST(InputBounds, EmptyBoxAndSphereRegionsAreRefused) {
  mca::SceneDef s = mca::io::parse_scene(kWall + R"([solver]
spacing = 0.1
[[object.region]]
shape = "box"
center = [5, 0, 0]
size = [0.5, 0.5, 0.5]
material = "glass"
)",
                                         "r.toml");
  std::string m = error_of([&] { mca::lattice::build_model(s); });
  EXPECT_HAS(m, "r.toml: object[0] 'wall': region[0]");
  EXPECT_HAS(m, "holds no automaton");
  s.objects[0].regions[0].shape = mca::Shape::sphere;
  s.objects[0].regions[0].radius = 0.2;
  m = error_of([&] { mca::lattice::build_model(s); });
  EXPECT_HAS(m, "region[0]");
  EXPECT_HAS(m, "holds no automaton");
  s.objects[0].regions[0].center = {0.3, 0, 0};
  EXPECT_EQ(error_of([&] { mca::lattice::build_model(s); }), "");
}

// The memory message asks for a coarser lattice (a larger spacing than the one refused) or a higher
// limit: 7,623 automata at 0.03 m need 45.6 MB, over 45 MB, where the old hint named the spacing of
// 10,000 automata (0.027 m, finer).
TEST(InputBounds, MemoryRefusalSuggestsALargerSpacing) {
  mca::SceneDef s = mca::io::parse_scene(kWall + "[solver]\nspacing = 0.03\nmax_memory_gb = 0.045\n", "m.toml");
  const std::string m = error_of([&] { mca::lattice::build_model(s); });
  EXPECT_HAS(m, "solver.max_memory_gb");
  EXPECT_HAS(m, "increase solver.spacing");
  const std::size_t at = m.find("spacing of about ");
  ASSERT_NE(at, std::string::npos) << m;
  const double suggested = std::stod(m.substr(at + 17));
  EXPECT_GT(suggested, 0.03) << m;
  s.solver.spacing = suggested;
  EXPECT_EQ(error_of([&] { mca::lattice::build_model(s); }), "");
}

}  // namespace
