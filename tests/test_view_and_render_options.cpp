// Options of the pictures and the viewer: the automatic camera at any picture shape, MCA_FFMPEG_TIMEOUT,
// `mca view --script` files and shots at a frame's time.
#include <gtest/gtest.h>

#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <string>

#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "render/camera.hpp"
#include "render/image.hpp"
#include "shell.hpp"
#include "sim/engine.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
namespace {

namespace fs = std::filesystem;
using test::Result;
using test::run_mca;
using test::shell;
using test::TempDir;

// --render-size 16x512 refused the automatic camera as a speck "of the [camera]" nobody wrote: the objects
// fill the width of a tall picture and a small share of its height. Every shape the sizes allow frames them.
TEST(RenderOptions, AutomaticCameraFramesEveryPictureShape) {
  const SceneDef scene = test::cubic_wall_scene();
  const Engine sim(scene);
  const auto f = render::objects_box(sim.model(), sim.state());
  for (const auto& [w, h] : {std::pair{16, 512}, {16, 8192}, {512, 16}, {8192, 16}, {16, 16}, {1280, 720}}) {
    SCOPED_TRACE(fmt::format("{}x{}", w, h));
    EXPECT_NO_THROW(render::make_camera(scene.camera, sim.model(), f, static_cast<float>(w) / h, scene.source));
  }
  // A speck is still one, and the message names the [camera] that was written.
  SceneDef far = scene;
  far.camera.position = Vec3d{0.0, -300.0, 1.0};
  const std::string e = test::error_of(
      [&] { render::make_camera(far.camera, sim.model(), f, 16.0f / 9, far.source); });
  EXPECT_NE(e.find("the [camera] at"), std::string::npos) << e;
  EXPECT_NE(e.find("speck"), std::string::npos) << e;
}

// MCA_FFMPEG_TIMEOUT set to anything but whole seconds 1..86400 was ignored (120 s used without a word):
// refused like a bad MCA_SIMD, before the output folder is made.
TEST(RenderOptions, BadFfmpegTimeoutIsRefusedBeforeAnythingIsWritten) {
  for (const char* bad : {"abc", "-1", "0", "86401", "5s", "+5", " 5", "1e3"}) {
    SCOPED_TRACE(bad);
    {
      test::ForceEnv env("MCA_FFMPEG_TIMEOUT", bad);
      const std::string e = test::error_of([] { render::VideoEncoder::time_limit(); });
      EXPECT_NE(e.find("MCA_FFMPEG_TIMEOUT = " + std::string(bad) + ":"), std::string::npos) << e;
      EXPECT_NE(e.find("1 to 86400"), std::string::npos) << e;
    }
    TempDir t;
    const fs::path out = t.path() / "out";
    const Result r = shell("MCA_FFMPEG_TIMEOUT='" + std::string(bad) + "' " + std::string(MCA_BINARY) +
                           " run --steps 1 -q --render --out " + out.string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("MCA_FFMPEG_TIMEOUT"), std::string::npos) << r.output;
    EXPECT_FALSE(fs::exists(out)) << "an output folder was made";
  }
  test::ForceEnv env("MCA_FFMPEG_TIMEOUT", "300");
  EXPECT_EQ(render::VideoEncoder::time_limit(), 300);
}

// A folder given as --script was read as a script of no shots.
TEST(ViewScript, AFolderOrAMissingFileIsRefused) {
  TempDir t;
  for (const fs::path& p : {t.path(), t.path() / "none.txt"}) {
    const Result r = shell("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(MCA_BINARY) + " view --frames 1 --script " +
                           p.string());
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find("--script " + p.string()), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("'TIME X Y'"), std::string::npos) << r.output;
  }
}

// A screenshot that cannot be written is refused before any frame is shown (it was found after them all,
// naming a temporary file), and one given empty is refused (it wrote nothing without a word).
TEST(ViewScript, AScreenshotThatCannotBeWrittenIsRefusedAtTheStart) {
  TempDir t;
  for (const auto& [name, words] : std::vector<std::pair<std::string, std::string>>{
           {(t.path() / "none" / "x.png").string(), "does not exist"},
           {(t.path() / "a.png").string(), "is a folder"},
           {"''", "--screenshot is empty"}}) {
    if (words == "is a folder") fs::create_directories(t.path() / "a.png");
    const Result r = shell("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(MCA_BINARY) +
                           " view --frames 1 --screenshot " + name);
    EXPECT_EQ(r.code, 2) << r.output;
    EXPECT_NE(r.output.find(words), std::string::npos) << r.output;
  }
}

Result view_under_xvfb(const std::string& args) {
  return shell("timeout 120 xvfb-run -a -s '-screen 0 1280x720x24' " + std::string(MCA_BINARY) + " view " + args);
}

// A shot at exactly a frame's time fires with that frame: the frame's time is whole steps of a float step
// (it may come out a hair short of the decimal written for it), and such a shot waited for the next frame, or, at the last one, was
// reported as not fired "at 4.00 ms, before 4.00 ms". A shot due at the last frame shown is said to be in no
// frame; the counts are those of the last frame shown.
TEST(ViewScript, AShotAtAFramesTimeFiresWithIt) {
  if (shell("command -v xvfb-run").code != 0) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh)";
  // The default scene at a frame rate with a frame whose time, as the simulation counts it, falls short of
  // the decimal time written for it.
  SceneDef scene = test::cubic_wall_scene();
  int k = 0;
  std::string when;
  for (double rate : {500.0, 1000.0, 1500.0, 700.0, 3000.0, 900.0, 1100.0, 1300.0}) {
    scene.output.frame_rate = rate;
    const Engine sim(scene);
    for (int c = 1; c < 40 && k == 0; ++c) {
      const double frame_time = static_cast<double>(c) * sim.steps_per_frame() * static_cast<double>(sim.model().dt);
      const std::string text = fmt::format("{:.6g}", c / rate);
      if (std::stod(text) > frame_time) {
        k = c;
        when = text;
      }
    }
    if (k > 0) break;
  }
  ASSERT_GT(k, 0) << "no frame time falls short of its decimal";
  TempDir t;
  const fs::path scene_file = t.path() / "scene.toml", script = t.path() / "shots.txt";
  std::ofstream(scene_file) << io::scene_to_toml(scene);
  std::ofstream(script) << when << " 0.5 0.5\n";
  // Frames 0..k+1: the shot fires with frame k and is in frame k + 1.
  Result r = view_under_xvfb(fmt::format("{} --size 64x64 --frames {} --script {}", scene_file.string(), k + 2,
                                         script.string()));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("1 shot fired, 2 projectiles"), std::string::npos) << when << ": " << r.output;
  EXPECT_EQ(r.output.find("not fired"), std::string::npos) << r.output;
  // Frames 0..k: due at the last frame shown, in none.
  r = view_under_xvfb(fmt::format("{} --size 64x64 --frames {} --script {}", scene_file.string(), k + 1,
                                  script.string()));
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_EQ(r.output.find("not fired"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("1 shot due at the last frame shown"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0 shots fired, 1 projectile,"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace mca
