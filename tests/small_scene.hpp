#pragma once
// The command-line tests' small scene and file reader (test_cli.cpp, test_run_folder.cpp).
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace mca::test {

// The whole file at p ("" when it cannot be opened).
inline std::string read(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The default wall made small (360 automata, 5 frames), written to dir / (name + ".toml"), with `extra`
// appended (more keys or tables).
inline std::filesystem::path small_scene(const std::filesystem::path& dir, const std::string& extra = "",
                                         const std::string& name = "small") {
  std::filesystem::create_directories(dir);
  const std::filesystem::path p = dir / (name + ".toml");
  std::ofstream(p) << "name = \"" << name << R"("
[solver]
spacing = 0.05
[output]
duration = 0.004
frame_rate = 1000
[heterogeneity]
preset = "medium"
[ground]
enabled = true
[[object]]
name = "wall"
size = [0.6, 0.15, 0.5]
position = [0, 0, 0.25]
[[projectile]]
radius = 0.08
position = [0, -0.17, 0.25]
velocity = [0, 60, 0]
)" << extra;
  return p;
}

// small_scene with more keys in its [output] table (each line "key = value\n").
inline std::filesystem::path small_scene_with_output(const std::filesystem::path& dir, const std::string& keys,
                                                     const std::string& name = "small") {
  const std::filesystem::path p = small_scene(dir, "", name);
  std::string text = read(p);
  text.replace(text.find("[output]\n"), 9, "[output]\n" + keys);
  std::ofstream(p) << text;
  return p;
}

}  // namespace mca::test
