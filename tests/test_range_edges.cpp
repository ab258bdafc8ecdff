// Values at the extremes get messages with the right numbers and a fix (no inf, nan or a step of 0 s), and
// each documented range of docs/scene-format.md holds at its edges: the edge works, past it is refused.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include <mca/error.hpp>
#include <mca/scene.hpp>

#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "mesh_fixtures.hpp"
#include "physics/contact_law.hpp"
#include "sim/engine.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

using test::error_of;

#define EXPECT_HAS(message, part) EXPECT_NE((message).find(part), std::string::npos) << "message: " << (message)

// Numbers gone wrong in a message: infinities, NaNs, a spacing or step printed as 0.
void expect_sane(const std::string& m) {
  for (const char* bad : {"inf", "nan", " 0 m", " 0 s"}) EXPECT_EQ(m.find(bad), std::string::npos) << bad << " in: " << m;
}

// A 0.3 m concrete cube at spacing 0.05 (216 automata), 0.05 s at 500 frames a second, as `extra` changes.
SceneDef cube(const std::string& extra = "") {
  return io::parse_scene(extra + "\n[[object]]\nsize = [0.3, 0.3, 0.3]\nposition = [0, 0, 0.5]\n", "edge.toml");
}

std::string scene_error(const std::string& extra) {
  return error_of([&] { cube(extra); });
}

std::string engine_error(const std::string& extra) {
  return error_of([&] { Engine e(cube(extra)); });
}

// Item 4: spacing = 1e-300 was rounded to a float spacing of 0: "inf GB for at least inf automata at
// spacing 0 m ... a spacing of about -nan m fits".
TEST(RangeEdges, ExtremeSpacingsAreRefusedWithTheirValue) {
  for (const char* v : {"1e-300", "1e300", "9.99e-10", "1.01e9"}) {
    const std::string m = scene_error(std::string("[solver]\nspacing = ") + v);
    EXPECT_HAS(m, "solver.spacing = ");
    EXPECT_HAS(m, "is out of range: must be in [1e-9, 1e9] [m]");
    EXPECT_HAS(m, "e.g. 0.05");
    expect_sane(m);
  }
  // The edges are read; a build at them is refused for its size, with finite figures.
  std::string m = engine_error("[solver]\nspacing = 1e-9");
  EXPECT_HAS(m, "at spacing 1e-09 m, over solver.max_memory_gb = 16");
  expect_sane(m);
  const std::size_t at = m.find("a spacing of about ");
  ASSERT_NE(at, std::string::npos) << m;
  EXPECT_NEAR(std::stod(m.substr(at + 19)), 1.13e-3, 0.01e-3) << m;
  m = engine_error("[solver]\nspacing = 1e9");
  EXPECT_HAS(m, "less than half the spacing 1e+09 m");
  expect_sane(m);
}

// Item 4: frame_rate = 1e300 made a step of 0 s in float32: "output.duration = 0.05 s is inf steps of 0 s".
TEST(RangeEdges, AnExtremeFrameRateIsRefusedWithItsValue) {
  std::string m = scene_error("[output]\nframe_rate = 1e300");
  EXPECT_HAS(m, "output.frame_rate = 1e300 is out of range: must be in (0, 1e12] [1/s]");
  expect_sane(m);
  // At the edge each frame is one step of 1e-12 s: a long run is refused for its step count, in figures.
  m = engine_error("[output]\nframe_rate = 1e12\nduration = 1e4");
  EXPECT_HAS(m, "output.duration = 10000 s is 1e+16 steps of 1e-12 s");
  EXPECT_HAS(m, "each frame of output.frame_rate = 1e+12 takes a step at least");
  EXPECT_HAS(m, "or a lower output.frame_rate");
  expect_sane(m);
}

// Item 4: max_memory_gb = 0.04 was "less than the 0.04 GB the program takes".
TEST(RangeEdges, AMemoryLimitThatLeavesNothingSaysSo) {
  std::string m = engine_error("[solver]\nmax_memory_gb = 0.04");
  EXPECT_HAS(m, "solver.max_memory_gb = 0.04 leaves nothing for a model: the program takes 0.04 GB without one");
  EXPECT_HAS(m, "raise solver.max_memory_gb above it");
  EXPECT_EQ(m.find("less than"), std::string::npos) << m;
  // Just above: refused for the model, with a spacing that fits.
  m = engine_error("[solver]\nmax_memory_gb = 0.0401");
  EXPECT_HAS(m, "over solver.max_memory_gb = 0.0401");
  expect_sane(m);
  const std::size_t at = m.find("a spacing of about ");
  ASSERT_NE(at, std::string::npos) << m;
  const double d = std::stod(m.substr(at + 19));
  EXPECT_EQ(engine_error("[solver]\nmax_memory_gb = 0.0401\nspacing = " + std::to_string(d)), "");
}

}  // namespace
}  // namespace mca
