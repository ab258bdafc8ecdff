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

}  // namespace
