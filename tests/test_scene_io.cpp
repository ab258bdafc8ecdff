// Scene files: every example parses, scene_to_toml round-trips, and each kind of user error gives a
// message naming the key, the value and (for parse errors) the line.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <mca/error.hpp>
#include <mca/scene.hpp>

#include "io/scene_io.hpp"
#include "support.hpp"

namespace {

using mca::io::parse_scene;

// The error message of parsing `text`, or "" if it parsed.
std::string parse_error(const std::string& text, const std::string& source = "scene.toml") {
  try {
    parse_scene(text, source);
  } catch (const mca::Error& e) {
    return e.what();
  }
  return "";
}

// A valid minimal scene to break in one place.
const std::string kMinimal = R"(name = "t"
[[object]]
name = "wall"
size = [1, 0.2, 1]
material = "concrete"
)";

#define EXPECT_HAS(message, part) EXPECT_NE((message).find(part), std::string::npos) << "message: " << (message)

TEST(SceneIo, EveryExampleSceneParses) {
  const std::filesystem::path dir = std::filesystem::path(MCA_SOURCE_DIR) / "scenes";
  int count = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() != ".toml") continue;
    SCOPED_TRACE(entry.path().string());
    mca::SceneDef scene;
    ASSERT_NO_THROW(scene = mca::io::load_scene_file(entry.path()));
    EXPECT_EQ(scene.name, entry.path().stem().string());
    EXPECT_FALSE(scene.objects.empty());
    ++count;
  }
  EXPECT_GE(count, 6);
}

TEST(SceneIo, DefaultSceneIsTheWallAndBall) {
  const mca::SceneDef s = mca::io::load_default_scene();
  EXPECT_EQ(s.name, "wall_ball");
  ASSERT_EQ(s.objects.size(), 1u);
  EXPECT_EQ(s.objects[0].size, (mca::Vec3d{2.0, 0.2, 1.5}));
  EXPECT_DOUBLE_EQ(s.objects[0].position[2] - s.objects[0].size[2] / 2, 0.0);  // on the ground
  EXPECT_EQ(s.heterogeneity.preset, "medium");
  EXPECT_EQ(s.heterogeneity.shares, (std::array<double, 4>{0.0, 0.15, 0.20, 0.65}));
  ASSERT_EQ(s.projectiles.size(), 1u);
  EXPECT_EQ(s.projectiles[0].material, "steel");
  EXPECT_DOUBLE_EQ(s.projectiles[0].velocity[1], 30.0);
  EXPECT_DOUBLE_EQ(s.heterogeneity.grain_size, 0.2);
  EXPECT_TRUE(s.ground.enabled);
  // The random lattice (the default for every scene), its concrete softening with its links' own strengths,
  // run until the pieces have parted.
  EXPECT_EQ(s.solver.lattice, mca::SolverDef::Lattice::random);
  EXPECT_EQ(mca::SolverDef{}.lattice, mca::SolverDef::Lattice::random);
  const mca::MaterialDef& concrete = mca::resolve_material(s, s.objects[0].material, "object[0].material");
  EXPECT_EQ(concrete.fracture_energy, 100.0);
  EXPECT_EQ(concrete.weibull_modulus, 6.0);
  EXPECT_DOUBLE_EQ(s.output.duration, 0.15);
  // scenes/wall_ball_cubic.toml is the same wall and ball on the paper's lattice with the paper's break.
  const mca::SceneDef c = mca::test::cubic_wall_scene();
  EXPECT_EQ(c.solver.lattice, mca::SolverDef::Lattice::cubic);
  EXPECT_TRUE(c.materials.empty());
  EXPECT_EQ(c.objects[0].size, s.objects[0].size);
  EXPECT_EQ(c.projectiles[0].velocity, s.projectiles[0].velocity);
}

TEST(SceneIo, TensionBarGripsTakeOneLayerEach) {
  const auto s = mca::io::load_scene_file(std::filesystem::path(MCA_SOURCE_DIR) / "scenes/tension_bar.toml");
  ASSERT_EQ(s.grips.size(), 2u);
  const double d = s.solver.spacing;
  const double x0 = s.objects[0].position[0] - s.objects[0].size[0] / 2;
  const double x1 = s.objects[0].position[0] + s.objects[0].size[0] / 2;
  EXPECT_LT(s.grips[0].max[0], x0 + 1.5 * d);
  EXPECT_GT(s.grips[0].max[0], x0 + 0.5 * d);
  EXPECT_GT(s.grips[1].min[0], x1 - 1.5 * d);
  EXPECT_LT(s.grips[1].min[0], x1 - 0.5 * d);
  EXPECT_EQ(s.solver.gravity, (mca::Vec3d{0, 0, 0}));
  EXPECT_FALSE(s.ground.enabled);
}

TEST(SceneIo, IntegersAreAcceptedAsFloatsAndDefaultsFillTheRest) {
  const mca::SceneDef s = parse_scene(kMinimal + "[solver]\nspacing = 1\n", "dir/my_scene.toml");
  EXPECT_EQ(s.solver.spacing, 1.0);
  EXPECT_EQ(s.name, "t");
  EXPECT_EQ(s.source, "dir/my_scene.toml");
  EXPECT_EQ(parse_scene("[[object]]\n", "dir/my_scene.toml").name, "my_scene");  // the file stem
}

TEST(SceneIo, MaterialBaseCopiesThenOverrides) {
  const mca::SceneDef s = parse_scene(kMinimal + R"(
[[material]]
name = "weak"
base = "granite"
tensile_strength = 5e6
)",
                                      "m.toml");
  ASSERT_EQ(s.materials.size(), 1u);
  EXPECT_EQ(s.materials[0].name, "weak");
  EXPECT_EQ(s.materials[0].youngs_modulus, 50e9);
  EXPECT_EQ(s.materials[0].tensile_strength, 5e6);
}

void expect_same(const mca::HeterogeneityDef& a, const mca::HeterogeneityDef& b) {
  EXPECT_EQ(a.shares, b.shares);
  EXPECT_EQ(a.preset, b.preset);
  EXPECT_EQ(a.class_factors, b.class_factors);
  EXPECT_EQ(a.grain_size, b.grain_size);
}

// Every member, compared exactly (doubles bit for bit through ==).
void expect_same(const mca::SceneDef& a, const mca::SceneDef& b) {
  EXPECT_EQ(a.name, b.name);
  EXPECT_EQ(a.source, b.source);
  ASSERT_EQ(a.materials.size(), b.materials.size());
  for (std::size_t i = 0; i < a.materials.size(); ++i) {
    const auto &x = a.materials[i], &y = b.materials[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.youngs_modulus, y.youngs_modulus);
    EXPECT_EQ(x.poisson_ratio, y.poisson_ratio);
    EXPECT_EQ(x.density, y.density);
    EXPECT_EQ(x.tensile_strength, y.tensile_strength);
    EXPECT_EQ(x.compressive_strength, y.compressive_strength);
    EXPECT_EQ(x.fracture_strain, y.fracture_strain);
    EXPECT_EQ(x.friction, y.friction);
    EXPECT_EQ(x.restitution, y.restitution);
    EXPECT_EQ(x.rolling_friction, y.rolling_friction);
    EXPECT_EQ(x.twisting_friction, y.twisting_friction);
    EXPECT_EQ(x.damping_time, y.damping_time);
    EXPECT_EQ(x.strengthening, y.strengthening);
    EXPECT_EQ(x.strengthening_alpha, y.strengthening_alpha);
  }
  expect_same(a.heterogeneity, b.heterogeneity);
  ASSERT_EQ(a.objects.size(), b.objects.size());
  for (std::size_t i = 0; i < a.objects.size(); ++i) {
    const auto &x = a.objects[i], &y = b.objects[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.shape, y.shape);
    EXPECT_EQ(x.size, y.size);
    EXPECT_EQ(x.radius, y.radius);
    EXPECT_EQ(x.height, y.height);
    EXPECT_EQ(x.position, y.position);
    EXPECT_EQ(x.rotation, y.rotation);
    EXPECT_EQ(x.velocity, y.velocity);
    EXPECT_EQ(x.material, y.material);
    ASSERT_EQ(x.heterogeneity.has_value(), y.heterogeneity.has_value());
    if (x.heterogeneity) expect_same(*x.heterogeneity, *y.heterogeneity);
    ASSERT_EQ(x.regions.size(), y.regions.size());
    for (std::size_t r = 0; r < x.regions.size(); ++r) {
      EXPECT_EQ(x.regions[r].shape, y.regions[r].shape);
      EXPECT_EQ(x.regions[r].center, y.regions[r].center);
      EXPECT_EQ(x.regions[r].size, y.regions[r].size);
      EXPECT_EQ(x.regions[r].radius, y.regions[r].radius);
      EXPECT_EQ(x.regions[r].material, y.regions[r].material);
    }
  }
  ASSERT_EQ(a.projectiles.size(), b.projectiles.size());
  for (std::size_t i = 0; i < a.projectiles.size(); ++i) {
    const auto &x = a.projectiles[i], &y = b.projectiles[i];
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.radius, y.radius);
    EXPECT_EQ(x.material, y.material);
    EXPECT_EQ(x.density, y.density);
    EXPECT_EQ(x.position, y.position);
    EXPECT_EQ(x.velocity, y.velocity);
    EXPECT_EQ(x.angular_velocity, y.angular_velocity);
    EXPECT_EQ(x.kinematic, y.kinematic);
    EXPECT_EQ(x.rolling_friction, y.rolling_friction);
    EXPECT_EQ(x.twisting_friction, y.twisting_friction);
  }
  ASSERT_EQ(a.grips.size(), b.grips.size());
  for (std::size_t i = 0; i < a.grips.size(); ++i) {
    EXPECT_EQ(a.grips[i].name, b.grips[i].name);
    EXPECT_EQ(a.grips[i].min, b.grips[i].min);
    EXPECT_EQ(a.grips[i].max, b.grips[i].max);
    EXPECT_EQ(a.grips[i].velocity, b.grips[i].velocity);
  }
  ASSERT_EQ(a.loads.size(), b.loads.size());
  for (std::size_t i = 0; i < a.loads.size(); ++i) {
    EXPECT_EQ(a.loads[i].name, b.loads[i].name);
    EXPECT_EQ(a.loads[i].min, b.loads[i].min);
    EXPECT_EQ(a.loads[i].max, b.loads[i].max);
    EXPECT_EQ(a.loads[i].force, b.loads[i].force);
  }
  EXPECT_EQ(a.ground.enabled, b.ground.enabled);
  EXPECT_EQ(a.ground.height, b.ground.height);
  EXPECT_EQ(a.ground.friction, b.ground.friction);
  EXPECT_EQ(a.ground.restitution, b.ground.restitution);
  EXPECT_EQ(a.ground.rolling_friction, b.ground.rolling_friction);
  EXPECT_EQ(a.ground.twisting_friction, b.ground.twisting_friction);
  EXPECT_EQ(a.solver.spacing, b.solver.spacing);
  EXPECT_EQ(a.solver.target_automata, b.solver.target_automata);
  EXPECT_EQ(a.solver.safety, b.solver.safety);
  EXPECT_EQ(a.solver.time_step, b.solver.time_step);
  EXPECT_EQ(a.solver.mass_scaling, b.solver.mass_scaling);
  EXPECT_EQ(a.solver.gravity, b.solver.gravity);
  EXPECT_EQ(a.solver.link_damping, b.solver.link_damping);
  EXPECT_EQ(a.solver.local_damping, b.solver.local_damping);
  EXPECT_EQ(a.solver.stress_coefficient, b.solver.stress_coefficient);
  EXPECT_EQ(a.solver.link_bending, b.solver.link_bending);
  EXPECT_EQ(a.solver.skin, b.solver.skin);
  EXPECT_EQ(a.solver.seed, b.solver.seed);
  EXPECT_EQ(a.solver.max_memory_gb, b.solver.max_memory_gb);
  EXPECT_EQ(a.output.duration, b.output.duration);
  EXPECT_EQ(a.output.frame_rate, b.output.frame_rate);
  EXPECT_EQ(a.output.links, b.output.links);
  EXPECT_EQ(a.output.vtk, b.output.vtk);
  EXPECT_EQ(a.output.checkpoint_every, b.output.checkpoint_every);
}

TEST(SceneIo, RoundTripOfEveryMember) {
  mca::SceneDef s;
  s.name = "round \"trip\"\\ scene";
  s.source = "rt.toml";
  mca::MaterialDef m = *mca::find_builtin_material("glass");
  m.name = "odd";
  m.youngs_modulus = 1.0 / 3.0 * 1e11;
  m.poisson_ratio = 0.1 + 0.2;
  m.fracture_strain = 1.234567890123456789e-7;
  m.strengthening = mca::StrengtheningLaw::quadratic;
  m.strengthening_alpha = 12345.678901234;
  m.rolling_friction = 0.0;
  m.twisting_friction = 0.123456789;
  m.damping_time = 1.0 / 3.0 * 1e-5;
  s.materials.push_back(m);
  m.name = "exp";
  m.strengthening = mca::StrengtheningLaw::exponential;
  m.density = 7000.000000000001;  // needs 16 significant digits
  s.materials.push_back(m);
  s.heterogeneity.shares = {0.1, 0.2, 0.3, 0.4};
  s.heterogeneity.preset = "custom";
  s.heterogeneity.class_factors = {0.1, 0.1, 0.7, 1.0 / 3.0 + 1.0};
  s.heterogeneity.grain_size = 0.07;

  mca::ObjectDef o;
  o.name = "wall";
  o.size = {2.0, 0.2, 1.5};
  o.position = {-0.0, 1e-20, 0.75};
  o.rotation = {10, 20.5, -30};
  o.velocity = {0.1, 0.2, 0.3};
  o.material = "odd";
  mca::RegionDef r;
  r.shape = mca::Shape::sphere;
  r.center = {0.1, 0.2, 0.3};
  r.radius = 0.15;
  r.material = "exp";
  o.regions.push_back(r);
  r.shape = mca::Shape::box;
  r.material = "steel";
  o.regions.push_back(r);
  s.objects.push_back(o);
  o.name = "pillar";
  o.shape = mca::Shape::cylinder;
  o.radius = 0.3;
  o.height = 2.0;
  o.regions.clear();
  mca::HeterogeneityDef h;
  mca::heterogeneity_preset("high", h.shares);
  h.preset = "high";
  h.grain_size = 0.2;
  o.heterogeneity = h;
  s.objects.push_back(o);
  o.name = "rock";
  o.shape = mca::Shape::sphere;
  h.preset = "custom";  // shares equal to a preset's, but declared custom: must stay custom
  o.heterogeneity = h;
  s.objects.push_back(o);

  mca::ProjectileDef p;
  p.radius = 0.12;
  p.position = {0, -0.5, 0.75};
  p.velocity = {0, 40, 0};
  p.angular_velocity = {1, 2, 3};
  s.projectiles.push_back(p);
  p.name = "other";
  p.kinematic = true;
  p.density = 1234.5;
  p.material = "odd";
  p.rolling_friction = 0.25;
  p.twisting_friction = 1.0 / 3.0;
  s.projectiles.push_back(p);

  mca::GripDef g;
  g.min = {-1, -1, -1};
  g.max = {0.011, 1, 1};
  s.grips.push_back(g);
  g.name = "pull";
  g.velocity = {0.02, 0, 0};
  s.grips.push_back(g);

  mca::LoadDef l;
  l.min = {0.5, -1, 1.4};
  l.max = {1.0, 1, 1.6};
  l.force = {0, 0, -1.0 / 3.0 * 1e3};
  s.loads.push_back(l);
  l.name = "shear";
  l.force = {1e-9, 2.5e7, -0.0};
  s.loads.push_back(l);

  s.ground.enabled = true;
  s.ground.height = -0.25;
  s.ground.friction = 0.0;
  s.ground.restitution = 1.0;
  s.ground.rolling_friction = 0.0;
  s.ground.twisting_friction = 0.7;
  s.solver.spacing = 0.0123;
  s.solver.target_automata = 123456789;
  s.solver.safety = 0.15;
  s.solver.time_step = 1.1e-7;
  s.solver.gravity = {0, -9.80665, 0};
  s.solver.link_damping = 0.02;
  s.solver.local_damping = 0.2;
  s.solver.stress_coefficient = 1.1;
  s.solver.link_bending = 0.37;
  s.solver.skin = 0.3;
  s.solver.seed = 0xFEDCBA9876543210ull;  // above 2^63: written as a negative TOML integer
  s.solver.max_memory_gb = 3.5;
  s.output.duration = 0.1;
  s.output.frame_rate = 333.3;
  s.output.links = true;
  s.output.vtk = false;
  s.output.checkpoint_every = 7;
  ASSERT_NO_THROW(mca::validate_scene(s));

  const std::string text = mca::io::scene_to_toml(s);
  mca::SceneDef back;
  ASSERT_NO_THROW(back = parse_scene(text, s.source)) << text;
  expect_same(s, back);
  EXPECT_EQ(mca::io::scene_to_toml(back), text);

  // The example scenes round-trip too.
  for (const char* name : {"wall_ball", "four_walls", "tension_bar", "heterogeneity_high"}) {
    const auto file = std::filesystem::path(MCA_SOURCE_DIR) / "scenes" / (std::string(name) + ".toml");
    const mca::SceneDef a = mca::io::load_scene_file(file);
    expect_same(a, parse_scene(mca::io::scene_to_toml(a), a.source));
  }
}

TEST(SceneIo, RoundTripOfRandomDoubles) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> mantissa(-1.0, 1.0);
  std::uniform_int_distribution<int> exponent(-300, 300);
  mca::SceneDef s;
  s.objects.emplace_back();
  // A load's force takes any finite value: the full exponent range.
  mca::LoadDef load;
  load.min = {-1, -1, -1};
  load.max = {1, 1, 1};
  s.loads.push_back(load);
  for (int i = 0; i < 2000; ++i) {
    for (double& f : s.loads[0].force) f = std::ldexp(mantissa(rng), exponent(rng) / (i % 2 ? 1 : 30));
    s.objects[0].position = {mantissa(rng), mantissa(rng) * 1e5, mantissa(rng) * 1e-4};
    const mca::SceneDef back = parse_scene(mca::io::scene_to_toml(s), s.source);
    ASSERT_EQ(back.loads[0].force, s.loads[0].force) << mca::io::scene_to_toml(s);
    ASSERT_EQ(back.objects[0].position, s.objects[0].position);
  }
}

TEST(SceneIo, UnknownKeyGivesLineAndSuggestion) {
  const std::string text = kMinimal + "\n[[material]]\nname = \"weak\"\nyoungs_modulos = 1e9\n";
  const std::string msg = parse_error(text);
  EXPECT_HAS(msg, "scene.toml:9:1:");
  EXPECT_HAS(msg, "unknown key 'youngs_modulos' in [[material]]");
  EXPECT_HAS(msg, "did you mean 'youngs_modulus'?");

  const std::string top = parse_error("materials = 1\n" + kMinimal);
  EXPECT_HAS(top, "scene.toml:1:1:");
  EXPECT_HAS(top, "did you mean 'material'?");

  const std::string section = parse_error(kMinimal + "[solvr]\nspacing = 0.1\n");
  EXPECT_HAS(section, "unknown key 'solvr'");
  EXPECT_HAS(section, "did you mean 'solver'?");
}

TEST(SceneIo, WrongTypeNamesKeyLineAndTypes) {
  const std::string msg = parse_error(kMinimal + "[solver]\nspacing = \"0.05\"\n");
  EXPECT_HAS(msg, "scene.toml:7:11:");
  EXPECT_HAS(msg, "solver.spacing");
  EXPECT_HAS(msg, "is a string");
  EXPECT_HAS(msg, "expected a number");
  EXPECT_HAS(msg, "without quotes");

  const std::string arr = parse_error(kMinimal + "position = [1, 2]\n");
  EXPECT_HAS(arr, "scene.toml:6:12:");
  EXPECT_HAS(arr, "object[0].position has 2 elements, expected an array of 3 numbers");

  const std::string elem = parse_error(kMinimal + "velocity = [1, true, 3]\n");
  EXPECT_HAS(elem, "object[0].velocity[1] is a boolean");

  const std::string integer = parse_error(kMinimal + "[solver]\nseed = 1.5\n");
  EXPECT_HAS(integer, "solver.seed is a float (1.5), expected an integer");
  // 2^64 - 1 is no TOML integer: the message says how a seed above 2^63 - 1 is written.
  const std::string huge = parse_error("[solver]\nseed = 18446744073709551615\n" + kMinimal);
  EXPECT_HAS(huge, "TOML syntax error");
  EXPECT_HAS(huge, "18446744073709551615 is -1");
  EXPECT_HAS(huge, "'18446744073709551615' is not representable in 64 bits");
  // A negative one is quoted with its sign (toml++ drops it).
  EXPECT_HAS(parse_error("[solver]\nseed = -9223372036854775809\n" + kMinimal),
             "'-9223372036854775809' is not representable in 64 bits");
  EXPECT_HAS(parse_error("[solver]\nseed = 0\nspacing = -99999999999999999999 # -1\n" + kMinimal),
             "'-99999999999999999999' is not representable");
  // The sign is the number's own, not one elsewhere on the line (the second review).
  for (const char* line : {"seed = 9223372036854775809  # was -9223372036854775809",
                           "seed = [9223372036854775809, -9223372036854775809]"})
    EXPECT_HAS(parse_error(std::string("[solver]\n") + line + "\n" + kMinimal),
               "'9223372036854775809' is not representable");
  EXPECT_HAS(parse_error("[solver]\nseed = -9_223_372_036_854_775_809\n" + kMinimal), "'-9");

  const std::string table = parse_error("[object]\nname = \"x\"\n");
  EXPECT_HAS(table, "write each block as [[object]], not [object]");

  const std::string shape = parse_error(kMinimal + "shape = \"spher\"\n");
  EXPECT_HAS(shape, "scene.toml:6:9:");
  EXPECT_HAS(shape, "object[0].shape = \"spher\" is not a shape; did you mean 'sphere'?");
}

TEST(SceneIo, SyntaxErrorHasLineAndColumn) {
  const std::string msg = parse_error("name = \"x\"\n[solver\nspacing = 1\n", "bad.toml");
  EXPECT_HAS(msg, "bad.toml:2:");
  EXPECT_HAS(msg, "TOML syntax error");
}

// A scene saved in UTF-16 or UTF-32 (Notepad's "Unicode") read "invalid utf-8 sequence" at 1:1; it is named,
// and the fix given. A UTF-8 byte order mark is read.
TEST(SceneIo, ASceneInUtf16OrUtf32IsNamed) {
  const auto wide = [](const std::string& bom, std::size_t width, bool big) {
    std::string out = bom;
    for (const char c : kMinimal) {
      std::string unit(width, '\0');
      unit[big ? width - 1 : 0] = c;
      out += unit;
    }
    return out;
  };
  const std::pair<std::string, int> cases[] = {{wide("\xFF\xFE", 2, false), 16},
                                               {wide("\xFE\xFF", 2, true), 16},
                                               {wide(std::string("\xFF\xFE\0\0", 4), 4, false), 32},
                                               {wide(std::string("\0\0\xFE\xFF", 4), 4, true), 32}};
  for (const auto& [text, bits] : cases) {
    const std::string msg = parse_error(text, "notepad.toml");
    EXPECT_HAS(msg, fmt::format("notepad.toml: is text in UTF-{} (it starts with its byte order mark)", bits));
    EXPECT_HAS(msg, "save it as UTF-8");
  }
  EXPECT_EQ(parse_error("\xEF\xBB\xBF" + kMinimal), "");
}

TEST(SceneIo, OutOfRangeYoungsModulus) {
  const std::string msg =
      parse_error(kMinimal + "\n[[material]]\nname = \"weak\"\nyoungs_modulus = -3e9\n", "wall.toml");
  EXPECT_HAS(msg, "wall.toml: material[0].youngs_modulus = -3e9");  // as the scene writer shows numbers
  EXPECT_HAS(msg, "\"weak\"");
  EXPECT_HAS(msg, "must be in [1e3, 1e13]");
}

TEST(SceneIo, PoissonRatioOutsideOpenInterval) {
  for (const char* bad : {"0.5", "0.6", "-1"}) {
    const std::string msg =
        parse_error(kMinimal + "\n[[material]]\nname = \"weak\"\npoisson_ratio = " + bad + "\n", "wall.toml");
    EXPECT_HAS(msg, "wall.toml: material[0].poisson_ratio = " + std::string(bad));
    EXPECT_HAS(msg, "must be in (-1, 0.5) (0.5 is incompressible); use e.g. 0.2 for concrete");
  }
  EXPECT_EQ(parse_error(kMinimal + "\n[[material]]\nname = \"ok\"\npoisson_ratio = 0.49\n"), "");
}

TEST(SceneIo, SharesMustSumToOne) {
  const std::string msg = parse_error(kMinimal + "[heterogeneity]\nshares = [0, 15, 20, 65]\n");
  EXPECT_HAS(msg, "scene.toml: heterogeneity.shares = [0, 15, 20, 65] sum to 100");
  EXPECT_HAS(msg, "must sum to 1");

  const std::string negative = parse_error(kMinimal + "[heterogeneity]\nshares = [-0.1, 0.1, 0.2, 0.8]\n");
  EXPECT_HAS(negative, "heterogeneity.shares");
  EXPECT_HAS(negative, "must be >= 0");

  const std::string object = parse_error(kMinimal + "[object.heterogeneity]\nshares = [0.5, 0.5, 0.5, 0.5]\n");
  EXPECT_HAS(object, "object[0].heterogeneity.shares");

  EXPECT_EQ(parse_error(kMinimal + "[heterogeneity]\nshares = [0.1, 0.2, 0.3, 0.4]\n"), "");
}

TEST(SceneIo, ClassFactorsPositiveNonDecreasing) {
  EXPECT_HAS(parse_error(kMinimal + "[heterogeneity]\nclass_factors = [0, 0.5, 0.75, 1]\n"),
             "heterogeneity.class_factors");
  EXPECT_HAS(parse_error(kMinimal + "[heterogeneity]\nclass_factors = [0.5, 0.25, 0.75, 1]\n"), "non-decreasing");
}

TEST(SceneIo, PresetAndSharesBothGiven) {
  const std::string msg = parse_error(kMinimal + "[heterogeneity]\npreset = \"low\"\nshares = [0, 0, 0.1, 0.9]\n");
  EXPECT_HAS(msg, "scene.toml:8:");
  EXPECT_HAS(msg, "heterogeneity.shares and heterogeneity.preset (line 7) are both given");

  const std::string unknown = parse_error(kMinimal + "[heterogeneity]\npreset = \"meduim\"\n");
  EXPECT_HAS(unknown, "heterogeneity.preset = \"meduim\" is not a preset; did you mean 'medium'?");
}

TEST(SceneIo, ZeroSpacing) {
  const std::string msg = parse_error(kMinimal + "[solver]\nspacing = 0\n", "wall.toml");
  EXPECT_HAS(msg, "wall.toml: solver.spacing = 0 is out of range: must be in [1e-9, 1e9] [m]");
}

// solver.link_bending: 0 or a share in [0.01, 1], of the random lattice's links only.
TEST(SceneIo, LinkBendingIsAShareOfTheRandomLatticesOnly) {
  EXPECT_EQ(parse_error(kMinimal + "[solver]\nlink_bending = 0\n"), "");
  EXPECT_EQ(parse_error(kMinimal + "[solver]\nlink_bending = 0.01\n"), "");
  EXPECT_EQ(parse_error(kMinimal + "[solver]\nlink_bending = 1\n"), "");
  EXPECT_HAS(parse_error(kMinimal + "[solver]\nlink_bending = 1.5\n", "wall.toml"),
             "wall.toml: solver.link_bending = 1.5 is out of range: must be 0, or in [0.01, 1]");
  EXPECT_HAS(parse_error(kMinimal + "[solver]\nlink_bending = -0.1\n"), "use 0.1 (the default, calibrated), or 0 for none");
  EXPECT_HAS(parse_error(kMinimal + "[solver]\nlink_bending = 1e-42\n"), "link_bending = 1e-42 is out of range");
  EXPECT_HAS(parse_error(kMinimal + "[solver]\nlink_bending = nan\n"), "link_bending = nan is out of range");
  const std::string cubic = parse_error(kMinimal + "[solver]\nlattice = \"cubic\"\nlink_bending = 0.5\n", "wall.toml");
  EXPECT_HAS(cubic, "wall.toml: solver.link_bending = 0.5 sets the random lattice's bending springs");
  EXPECT_HAS(cubic, "remove link_bending (or set it to 0, or to its default 0.1), or use lattice = \"random\"");
  // The default, as a scene written back with the cubic lattice holds it, is no error, nor is 0 (none).
  EXPECT_EQ(parse_error(kMinimal + "[solver]\nlattice = \"cubic\"\nlink_bending = 0.1\n"), "");
  EXPECT_EQ(parse_error(kMinimal + "[solver]\nlattice = \"cubic\"\nlink_bending = 0\n"), "");
}

TEST(SceneIo, ZeroSizeAndRadius) {
  EXPECT_HAS(parse_error("[[object]]\nsize = [1, 0, 1]\n"), "object[0].size = [1, 0, 1] is out of range");
  EXPECT_HAS(parse_error(kMinimal + "[[projectile]]\nradius = -0.1\n"),
             "projectile[0].radius = -0.1 is out of range: must be > 0");
  // An infinite value is told it must be finite (inf is > 0).
  EXPECT_HAS(parse_error(kMinimal + "[[projectile]]\nradius = inf\n"),
             "projectile[0].radius = inf is out of range: must be a finite number > 0");
  EXPECT_HAS(parse_error("[[material]]\nname = \"x\"\nbase = \"concrete\"\nfracture_strain = inf\n[[object]]\nmaterial = \"x\"\n"),
             "material[0].fracture_strain = inf (material \"x\") is out of range: must be a finite number > 0");
}

// The scene's name titles pictures, windows and a Blender collection: no control characters (a NUL cut the
// collection's name short).
TEST(SceneIo, ASceneNameWithAControlCharacterIsRefused) {
  EXPECT_HAS(parse_error("name = \"a\\nb\"\n[[object]]\n", "wall.toml"),
             "wall.toml: name = \"a\\nb\" has a control character (a line break, tab or NUL)");
  EXPECT_EQ(parse_error("name = \"a b-c_d é\"\n[[object]]\n"), "");
}

TEST(SceneIo, UnknownMaterialWithSuggestion) {
  const std::string msg = parse_error("[[object]]\nmaterial = \"concret\"\n", "wall.toml");
  EXPECT_HAS(msg, "wall.toml: object[0].material = \"concret\" is not a known material; did you mean 'concrete'?");

  const std::string user =
      parse_error("[[material]]\nname = \"mortar\"\n[[object]]\nmaterial = \"morter\"\n", "wall.toml");
  EXPECT_HAS(user, "did you mean 'mortar'?");

  const std::string base = parse_error(kMinimal + "[[material]]\nname = \"x\"\nbase = \"stell\"\n");
  EXPECT_HAS(base, "scene.toml:8:8:");
  EXPECT_HAS(base, "material[0].base = \"stell\"");
  EXPECT_HAS(base, "did you mean 'steel'?");
  // A scene's own material of a built-in's name is listed once.
  const std::string listed = parse_error(kMinimal + "[[material]]\nname = \"concrete\"\n[[material]]\nname = \"x\"\n"
                                         "base = \"nothing like it\"\n");
  EXPECT_HAS(listed, "; allowed: concrete, glass, ceramic, granite, steel");
}

TEST(SceneIo, DuplicateNames) {
  EXPECT_HAS(parse_error(kMinimal + "[[object]]\nname = \"wall\"\n"),
             "object[1].name = \"wall\" duplicates object[0]");
  EXPECT_HAS(parse_error(kMinimal + "[[material]]\nname = \"a\"\n[[material]]\nname = \"a\"\n"),
             "material[1].name = \"a\" duplicates material[0]");
  // Unnamed objects get distinct default names.
  EXPECT_EQ(parse_error("[[object]]\n[[object]]\n"), "");
}

TEST(SceneIo, SceneWithoutObjects) {
  EXPECT_HAS(parse_error("name = \"empty\"\n"), "the scene has no objects");
}

TEST(SceneIo, OutputAndGripRanges) {
  EXPECT_HAS(parse_error(kMinimal + "[output]\nduration = 0\n"), "output.duration = 0 is out of range");
  EXPECT_HAS(parse_error(kMinimal + "[solver]\nmass_scaling = 1.5\n"), "solver.mass_scaling = 1.5 is out of range");
  EXPECT_HAS(parse_error(kMinimal + "[solver]\nmass_scaling = -0.1\n"), "solver.mass_scaling = -0.1 is out of range");
  EXPECT_HAS(parse_error(kMinimal + "[output]\nframe_rate = -5\n"), "output.frame_rate = -5 is out of range");
  EXPECT_HAS(parse_error(kMinimal + "[output]\ncheckpoint_every = -1\n"), "output.checkpoint_every = -1");
  const std::string grip = parse_error(kMinimal + "[[grip]]\nmin = [0, 0, 0]\nmax = [1, 0, 1]\n");
  EXPECT_HAS(grip, "grip[0]");
  EXPECT_HAS(grip, "on y min = 0 >= max = 0");
}

// Grip names become stats.csv column names ("<name>_force_x"): a comma, quote or line break would
// shift or split the header, and two equal names would give equal columns.
TEST(SceneIo, GripNamesMustFitTheStatsHeader) {
  const auto grip = [](const std::string& name_line) {
    return "[[grip]]\n" + name_line + "min = [-1, -1, -1]\nmax = [1, 1, 0]\n";
  };
  EXPECT_EQ(parse_error(kMinimal + grip("name = \"left end\"\n") + grip("name = \"right_end-2\"\n")), "");
  for (const char* bad : {"name = \"a,b\"\n", "name = \"say \\\"hi\\\"\"\n", "name = \"two\\nlines\"\n",
                                 "name = \"cr\\r\"\n", "name = \"tab\\t\"\n"}) {
    const std::string m = parse_error(kMinimal + grip("name = \"ok\"\n") + grip(bad));
    EXPECT_HAS(m, "scene.toml");
    EXPECT_HAS(m, "grip[1].name");
    EXPECT_HAS(m, "stats.csv");
    EXPECT_HAS(m, "rename");
  }
  const std::string dup = parse_error(kMinimal + grip("name = \"end\"\n") + grip("name = \"end\"\n"));
  EXPECT_HAS(dup, "grip[1].name");
  EXPECT_HAS(dup, "\"end\"");
  EXPECT_HAS(dup, "grip[0]");
  // Default names stay distinct ("grip", "grip1", ...), but a user name can still collide with one.
  EXPECT_EQ(parse_error(kMinimal + grip("") + grip("")), "");
  EXPECT_HAS(parse_error(kMinimal + grip("") + grip("name = \"grip\"\n")), "grip[1].name");
  // C++-built scenes get the same check.
  mca::SceneDef sc = parse_scene(kMinimal + grip("") + grip(""), "built");
  sc.grips[0].name = "x,y";
  EXPECT_THROW(mca::validate_scene(sc), mca::Error);
}

TEST(SceneIo, LoadsParseWithDefaultNames) {
  const mca::SceneDef s = parse_scene(kMinimal + R"(
[[load]]
min = [-0.5, -0.1, 0.4]
max = [0.5, 0.1, 0.6]
force = [0, 0, -25]

[[load]]
min = [0, 0, 0]
max = [1, 1, 1]

[[load]]
name = "push"
min = [0, 0, 0]
max = [1, 1, 1]
force = [3.5, 0, 0]
)",
                                      "scene.toml");
  ASSERT_EQ(s.loads.size(), 3u);
  EXPECT_EQ(s.loads[0].name, "load");
  EXPECT_EQ(s.loads[0].min, (mca::Vec3d{-0.5, -0.1, 0.4}));
  EXPECT_EQ(s.loads[0].max, (mca::Vec3d{0.5, 0.1, 0.6}));
  EXPECT_EQ(s.loads[0].force, (mca::Vec3d{0, 0, -25}));
  EXPECT_EQ(s.loads[1].name, "load1");
  EXPECT_EQ(s.loads[1].force, (mca::Vec3d{0, 0, 0}));  // the default
  EXPECT_EQ(s.loads[2].name, "push");
  EXPECT_EQ(s.loads[2].force, (mca::Vec3d{3.5, 0, 0}));
  EXPECT_TRUE(s.grips.empty());
}

TEST(SceneIo, LoadErrors) {
  // kMinimal is 5 lines; then a blank line, [[load]], min and max put the misspelt key on line 10.
  const std::string key = parse_error(kMinimal + "\n[[load]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nforse = [0, 0, 1]\n");
  EXPECT_HAS(key, "scene.toml:10:1:");
  EXPECT_HAS(key, "unknown key 'forse' in [[load]]; did you mean 'force'?");

  const std::string missing = parse_error(kMinimal + "[[load]]\nmin = [0, 0, 0]\nforce = [0, 0, 1]\n");
  EXPECT_HAS(missing, "load[0] needs both min = [x, y, z] and max = [x, y, z]");

  const std::string type = parse_error(kMinimal + "[[load]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nforce = 10\n");
  EXPECT_HAS(type, "scene.toml:9:9:");
  EXPECT_HAS(type, "load[0].force is an integer (10), expected an array of 3 numbers");

  const std::string table = parse_error(kMinimal + "[load]\nmin = [0, 0, 0]\n");
  EXPECT_HAS(table, "write each block as [[load]], not [load]");

  const std::string empty = parse_error(kMinimal + "[[load]]\nname = \"top\"\nmin = [0, 0, 1]\nmax = [1, 1, 1]\n");
  EXPECT_HAS(empty, "scene.toml: load[0] \"top\"");
  EXPECT_HAS(empty, "on z min = 1 >= max = 1");

  // TOML has nan and inf; validate_scene must reject them (the parser only checks types).
  const std::string nan = parse_error(kMinimal + "[[load]]\nmin = [0, 0, 0]\nmax = [1, 1, 1]\nforce = [0, nan, 0]\n");
  EXPECT_HAS(nan, "scene.toml: load[0].force = [0, nan, 0] has a non-finite component");
}

TEST(SceneIo, MissingFile) {
  try {
    mca::io::load_scene_file("/nonexistent/dir/no_such_scene.toml");
    FAIL() << "no error for a missing file";
  } catch (const mca::Error& e) {
    const std::string msg = e.what();
    EXPECT_HAS(msg, "/nonexistent/dir/no_such_scene.toml");
    EXPECT_HAS(msg, "not found");
  }
}

TEST(SceneIo, ValidateSceneChecksCppBuiltScenes) {
  mca::SceneDef s;
  s.source = "code";
  s.objects.emplace_back();
  EXPECT_NO_THROW(mca::validate_scene(s));
  s.heterogeneity.preset = "medium";  // shares left at the default: not the preset's
  try {
    mca::validate_scene(s);
    FAIL() << "preset/shares mismatch accepted";
  } catch (const mca::Error& e) {
    EXPECT_HAS(std::string(e.what()), "heterogeneity.preset = \"medium\"");
  }
  EXPECT_TRUE(mca::heterogeneity_preset("medium", s.heterogeneity.shares));
  EXPECT_NO_THROW(mca::validate_scene(s));
  EXPECT_THROW(mca::resolve_material(s, "unobtainium", "object[0].material"), mca::Error);
  EXPECT_EQ(&mca::resolve_material(s, "steel", "k"), mca::find_builtin_material("steel"));
}

TEST(SceneIo, BuiltinMaterialsAreValidAndStressGoverns) {
  mca::SceneDef s;
  s.objects.emplace_back();
  s.materials = mca::builtin_materials();
  ASSERT_EQ(s.materials.size(), 5u);
  s.materials.clear();
  for (mca::MaterialDef m : mca::builtin_materials()) {
    m.name += "_copy";
    s.materials.push_back(m);
    // Brittle materials: the displacement criterion must not pre-empt the stress criterion.
    if (m.compressive_strength > m.tensile_strength) {
      EXPECT_NEAR(m.fracture_strain, 1.5 * m.tensile_strength / m.youngs_modulus, 1e-12) << m.name;
    }
  }
  EXPECT_NO_THROW(mca::validate_scene(s));
  std::array<double, 4> shares{};
  for (const char* p : {"none", "low", "medium", "high"}) {
    ASSERT_TRUE(mca::heterogeneity_preset(p, shares));
    EXPECT_NEAR(shares[0] + shares[1] + shares[2] + shares[3], 1.0, 1e-12);
  }
  EXPECT_FALSE(mca::heterogeneity_preset("extreme", shares));
}

}  // namespace
