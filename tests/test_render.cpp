// The renderer: offscreen pictures of the default scene (background, wall, the break), the files of
// `mca run --render` (frames, video, contact sheet), rendering leaves results unchanged, bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <csignal>
#include <chrono>
#include <atomic>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <iterator>
#include <random>
#include <string>
#include <thread>

#include <glm/mat4x4.hpp>
#include <glm/vec4.hpp>

#include "app/commands.hpp"
#include "app/render_output.hpp"
#include "core/text.hpp"
#include "io/default_scene.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "render/camera.hpp"
#include "render/egl_context.hpp"
#include "render/font.hpp"
#include "render/image.hpp"
#include "render/renderer.hpp"
#include "render/snapshot.hpp"
#include "shell.hpp"
#include "sim/engine.hpp"
#include "support.hpp"
#include "temp_dir.hpp"

namespace mca {
// The runs and views below: the default wall on the paper's cubic lattice (the default scene they were
// written on, before the random lattice became the default).
const std::string& kCubicWall = test::kCubicWallPath;

namespace {

namespace fs = std::filesystem;
using test::Result;
using test::run_mca;
using test::shell;

// A file's text, or "" where it cannot be read.
std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}
using test::TempDir;

// The background the renderer clears to (renderer.cpp kBackground).
constexpr std::uint8_t kBg[3] = {34, 37, 43};

struct Pixel {
  int r, g, b;
};
Pixel at(const render::Image& im, int x, int y) {
  const auto* p = im.rgba.data() + 4 * (static_cast<std::size_t>(y) * im.width + x);
  return {p[0], p[1], p[2]};
}
bool is_background(Pixel p) { return p.r == kBg[0] && p.g == kBg[1] && p.b == kBg[2]; }

// Where a world point lands in the image (pixels, y down).
glm::vec2 project(const render::Camera& cam, const render::Framing& f, const Vec3d& world, int w, int h) {
  const glm::vec4 p(world[0] - f.origin[0], world[1] - f.origin[1], world[2] - f.origin[2], 1.0);
  const glm::vec4 c = cam.projection(static_cast<float>(w) / h) * cam.view() * p;
  return {(c.x / c.w * 0.5f + 0.5f) * w, (0.5f - c.y / c.w * 0.5f) * h};
}

class Offscreen {
 public:
  Offscreen(int w, int h) : w_(w), h_(h), target_(w, h) {}
  render::Image draw(const Engine& sim, const render::Framing& f, const render::Camera& cam,
                     render::ColourMode colour = render::ColourMode::fragment, const render::Overlay& overlay = {}) {
    const auto frags = analysis::label_model_fragments(sim.model(), sim.state().intact.data());
    render::SnapshotOptions o;
    o.colour = colour;
    const auto snap = render::make_snapshot(sim.model(), sim.state(), frags, o, f.origin);
    target_.bind();
    renderer_.draw(snap, render::DrawMode::cubes, cam, w_, h_, overlay);
    render::Image im{w_, h_, {}};
    target_.read_rgba(im.rgba);
    return im;
  }

 private:
  int w_, h_;
  render::EglContext context_;
  render::Renderer renderer_;
  render::OffscreenTarget target_;
};

TEST(Render, DefaultSceneShowsTheWallAndItsBreak) {
  constexpr int W = 320, H = 180;
  Engine sim(test::cubic_wall_scene());
  Offscreen off(W, H);
  const auto framing = render::objects_box(sim.model(), sim.state());
  const auto cam = render::make_camera(sim.scene().camera, sim.model(), framing, float(W) / H, "test");
  const render::Image before = off.draw(sim, framing, cam);
  // The sky at the top corners (the ground fills the bottom ones).
  EXPECT_TRUE(is_background(at(before, 0, 0)));
  EXPECT_TRUE(is_background(at(before, W - 1, 0)));
  // The wall's front face (y = -0.1) near its upper corners and its lower right, away from the ball: in
  // fragment colours concrete grey (fragment 0), in strength-class colours saturated (the classes are
  // blue, yellow, green, red); the ground and the sky are grey in both.
  const render::Image classes = off.draw(sim, framing, cam, render::ColourMode::strength_class);
  for (const Vec3d& p : {Vec3d{0.8, -0.1, 1.35}, Vec3d{-0.8, -0.1, 1.35}, Vec3d{0.7, -0.1, 0.3}}) {
    const glm::vec2 px = project(cam, framing, p, W, H);
    ASSERT_TRUE(px.x > 0 && px.x < W && px.y > 0 && px.y < H) << px.x << " " << px.y;
    const Pixel c = at(before, int(px.x), int(px.y)), k = at(classes, int(px.x), int(px.y));
    EXPECT_FALSE(is_background(c));
    EXPECT_GT(c.r + c.g + c.b, 3 * 60) << "at " << px.x << "," << px.y << ": " << c.r << " " << c.g << " " << c.b;
    EXPECT_LT(std::abs(c.r - c.b), 30);
    EXPECT_GT(std::max({k.r, k.g, k.b}) - std::min({k.r, k.g, k.b}), 60) << k.r << " " << k.g << " " << k.b;
  }
  // Outside the wall's projection (left of it, above the ground's horizon line) the class colours change nothing.
  const glm::vec2 beside = project(cam, framing, {-1.6, -0.1, 1.0}, W, H);
  const Pixel g1 = at(before, int(beside.x), int(beside.y)), g2 = at(classes, int(beside.x), int(beside.y));
  EXPECT_EQ(g1.r, g2.r);
  EXPECT_EQ(g1.g, g2.g);
  EXPECT_EQ(g1.b, g2.b);
  // The ball in front of the wall's centre: red.
  const glm::vec2 ball = project(cam, framing, {0, -0.4, 0.75}, W, H);
  const Pixel b = at(before, int(ball.x), int(ball.y));
  EXPECT_GT(b.r, 2 * b.g);
  EXPECT_GT(b.r, 2 * b.b);

  // After the impact (48 ms): the wall has broken in two halves and debris, in other colours.
  sim.advance(24000);
  ASSERT_GT(sim.state().broken_by[0] + sim.state().broken_by[1], 1000);
  const render::Image after = off.draw(sim, framing, cam);
  std::size_t changed = 0, coloured = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const Pixel p = at(before, x, y), q = at(after, x, y);
      changed += std::abs(p.r - q.r) + std::abs(p.g - q.g) + std::abs(p.b - q.b) > 30;
      coloured += std::max({q.r, q.g, q.b}) - std::min({q.r, q.g, q.b}) > 60;  // a fragment's hue (or the ball)
    }
  EXPECT_GT(changed, static_cast<std::size_t>(W * H / 20));
  EXPECT_GT(coloured, static_cast<std::size_t>(W * H / 20));
  // The camera stays put: the sky is where it was.
  EXPECT_TRUE(is_background(at(after, 0, 0)));
}

TEST(Render, FontHasEveryCharacterTheOverlayWrites) {
  // Every printable ASCII character has a glyph of its own, lower case too (it was drawn as upper case: "t =
  // 0.00 MS" read as megaseconds, "MPA"), lit but for the space; any other byte is drawn as '?'.
  for (int a = 32; a <= 126; ++a) {
    const std::uint8_t* g = render::glyph(static_cast<char>(a));
    int lit = 0;
    for (int r = 0; r < render::kGlyphRows; ++r) lit += g[r] != 0;
    EXPECT_EQ(lit > 0, a != ' ') << "'" << static_cast<char>(a) << "'";
    for (int b = 32; b < a; ++b) {
      EXPECT_FALSE(std::equal(g, g + render::kGlyphRows, render::glyph(static_cast<char>(b))))
          << "'" << static_cast<char>(a) << "' is drawn as '" << static_cast<char>(b) << "'";
    }
  }
  // The x-height: a lower-case letter without an ascender has its top two rows empty.
  for (const char c : std::string_view("acegmnopqrsuvwxyz"))
    EXPECT_EQ(render::glyph(c)[0] | render::glyph(c)[1], 0) << c;
  // Descenders below the line for g, j, p, q and y (raised onto it, g read as 9 and y as 4), none elsewhere.
  for (int a = 32; a <= 126; ++a) {
    const std::uint8_t* g = render::glyph(static_cast<char>(a));
    const bool descends = std::string_view("gjpqy").find(static_cast<char>(a)) != std::string_view::npos;
    EXPECT_EQ(g[render::kGlyphHeight] != 0 && g[render::kGlyphHeight + 1] != 0, descends) << static_cast<char>(a);
    if (!descends) {
      EXPECT_EQ(g[render::kGlyphHeight] | g[render::kGlyphHeight + 1], 0) << static_cast<char>(a);
    }
  }
  // A UTF-8 character is one '?', not one per byte ("\xc3\x84\xc3\xb1\xe6\x97\xa5" is "Äñ日").
  EXPECT_EQ(render::one_glyph_per_character("steel \xc3\x84\xc3\xb1\xe6\x97\xa5 \xf0\x9f\x98\x80!"), "steel ??? ?!");
  EXPECT_EQ(render::one_glyph_per_character("a\x80\xbf b \xe6\x97"), "a?? b ?");  // stray, cut short
  EXPECT_EQ(render::one_glyph_per_character("tab\there"), "tab\there");           // (glyph() shows it as '?')
  EXPECT_EQ(render::glyph('\t'), render::glyph('?'));
  EXPECT_EQ(render::glyph(static_cast<char>(0xc3)), render::glyph('?'));
  EXPECT_EQ(render::text_width("AB"), 2 * render::kGlyphAdvance - 1);
}

// Long lines and legend labels wrap at spaces (a label was cut at the width: "piggy" read "pi" over "ggy",
// and a line after the cut began with a space).
TEST(Render, TextWrapsAtSpaces) {
  using V = std::vector<std::string_view>;
  EXPECT_EQ(render::wrap_text("big piggy bank", 6), (V{"big", "piggy", "bank"}));
  EXPECT_EQ(render::wrap_text("a   b", 2), (V{"a", "b"}));
  EXPECT_EQ(render::wrap_text("abcdefgh ij", 3), (V{"abc", "def", "gh", "ij"}));  // a word longer than a line
  EXPECT_EQ(render::wrap_text("fits", 4), (V{"fits"}));
  EXPECT_EQ(render::wrap_text("", 4), V{});
  EXPECT_EQ(render::wrap_text("ab", 0), (V{"a", "b"}));  // (a width of 0 is taken as 1)
}

// The contact sheet's six frames stand as evenly as whole frames can: each the frame nearest k F / 5.
TEST(Render, TheContactSheetTakesFramesEvenlyApart) {
  using V = std::vector<std::int64_t>;
  EXPECT_EQ(app::RenderOutput::sheet_frames(30), (V{0, 6, 12, 18, 24, 30}));
  EXPECT_EQ(app::RenderOutput::sheet_frames(6), (V{0, 1, 2, 4, 5, 6}));  // (it took 0, 1, 2, 3, 4, 6)
  EXPECT_EQ(app::RenderOutput::sheet_frames(7), (V{0, 1, 3, 4, 6, 7}));
  EXPECT_EQ(app::RenderOutput::sheet_frames(2), (V{0, 1, 2}));
  EXPECT_EQ(app::RenderOutput::sheet_frames(0), (V{0}));
  EXPECT_EQ(app::RenderOutput::sheet_frames(1000000000000), (V{0, 200000000000, 400000000000, 600000000000,
                                                                800000000000, 1000000000000}));
}

// `mca run --render` on a short run: the frames, the video and the contact sheet; the same final state
// as without --render.
TEST(Render, RunWritesFramesVideoAndContactSheetAndChangesNoResult) {
  TempDir d;
  const fs::path with = d.path() / "with", without = d.path() / "without";
  const Result r = run_mca("run " + kCubicWall + " -q --duration 0.004 --render --render-size 320x180 --out " + with.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const Result r2 = run_mca("run " + kCubicWall + " -q --duration 0.004 --out " + without.string());
  ASSERT_EQ(r2.code, 0) << r2.output;
  const auto hash = [](const fs::path& dir) {
    std::ifstream in(dir / "summary.json");
    return nlohmann::json::parse(in)["state_hash"].get<std::string>();
  };
  EXPECT_EQ(hash(with), hash(without));

  // 0.004 s at 500 frames/s: frames 0..2.
  const fs::path rd = with / "render";
  for (int f = 0; f <= 2; ++f) {
    const auto im = render::read_png(rd / app::RenderOutput::frame_name(f));
    EXPECT_EQ(im.width, 320);
    EXPECT_EQ(im.height, 180);
  }
  EXPECT_FALSE(fs::exists(rd / app::RenderOutput::frame_name(3)));
  const auto sheet = render::read_png(rd / "contact_sheet.png");
  EXPECT_GT(sheet.width, 320);
  for (const auto& e : fs::directory_iterator(rd)) EXPECT_NE(e.path().extension(), ".tmp") << e.path();
  if (!render::find_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed: the video is not checked";
  ASSERT_TRUE(fs::exists(rd / "video.mp4"));
  const Result probe = shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries "
                             "stream=nb_read_frames,width,height,pix_fmt,codec_name -of default=nw=1 '" +
                             (rd / "video.mp4").string() + "'");
  ASSERT_EQ(probe.code, 0) << probe.output;
  EXPECT_NE(probe.output.find("codec_name=h264"), std::string::npos) << probe.output;
  EXPECT_NE(probe.output.find("width=320"), std::string::npos) << probe.output;
  EXPECT_NE(probe.output.find("height=180"), std::string::npos) << probe.output;
  EXPECT_NE(probe.output.find("pix_fmt=yuv420p"), std::string::npos) << probe.output;
  EXPECT_NE(probe.output.find("nb_read_frames=3"), std::string::npos) << probe.output;
}

// A rendered run stopped and resumed from an earlier checkpoint: `mca resume` renders the frames it adds
// as the run began (render/render.json), and the video and contact sheet hold every frame again.
TEST(Render, AResumedRunRendersTheFramesItAdds) {
  TempDir d;
  const fs::path dir = d.path() / "run";
  const Result r = run_mca("run " + kCubicWall + " -q --duration 0.012 --render --render-size 320x180 --render-colour damage "
                           "--checkpoint-every 2 --out " + dir.string());
  ASSERT_EQ(r.code, 0) << r.output;
  const fs::path rd = dir / "render";
  const auto last = render::read_png(rd / app::RenderOutput::frame_name(6));  // 0.012 s at 500 frames/s
  const auto hash = [&] {
    std::ifstream in(dir / "summary.json");
    return nlohmann::json::parse(in)["state_hash"].get<std::string>();
  };
  const std::string through = hash();
  // As if stopped after the first checkpoint (frame_000004.mcack: frames 0..4 written): the later
  // checkpoints, frames and the video gone.
  std::vector<fs::path> checkpoints;
  for (const auto& e : fs::directory_iterator(dir / "checkpoints")) checkpoints.push_back(e.path());
  std::sort(checkpoints.begin(), checkpoints.end());
  ASSERT_GE(checkpoints.size(), 2u);
  ASSERT_EQ(checkpoints[0].filename(), "frame_000004.mcack");
  for (std::size_t k = 1; k < checkpoints.size(); ++k) fs::remove(checkpoints[k]);
  for (int f = 5; f <= 6; ++f) fs::remove(rd / app::RenderOutput::frame_name(f));
  fs::remove(rd / "video.mp4");
  fs::remove(rd / "contact_sheet.png");

  const Result again = run_mca("resume -q " + dir.string());
  ASSERT_EQ(again.code, 0) << again.output;
  EXPECT_EQ(hash(), through);
  const auto redrawn = render::read_png(rd / app::RenderOutput::frame_name(6));
  EXPECT_EQ(redrawn.width, 320);
  EXPECT_TRUE(redrawn.rgba == last.rgba) << "the resumed run drew its last frame otherwise (colours, camera)";
  EXPECT_TRUE(fs::exists(rd / "contact_sheet.png"));
  if (!render::find_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed: the video is not checked";
  const Result probe = shell("ffprobe -v error -count_frames -select_streams v:0 -show_entries stream=nb_read_frames "
                             "-of default=nw=1 '" + (rd / "video.mp4").string() + "'");
  ASSERT_EQ(probe.code, 0) << probe.output;
  EXPECT_NE(probe.output.find("nb_read_frames=7"), std::string::npos) << probe.output;

  // With --no-render it goes on without drawing, and keeps the frames drawn up to its checkpoint (frame 4);
  // frame 5, drawn past it by the session it resumes, goes, as the message says (it stayed).
  fs::remove(dir / "checkpoints" / "frame_000006.mcack");
  fs::remove(rd / app::RenderOutput::frame_name(6));
  const Result plain = run_mca("resume -q --no-render " + dir.string());
  ASSERT_EQ(plain.code, 0) << plain.output;
  EXPECT_NE(plain.output.find("keeps the frames drawn so far (0..4)"), std::string::npos) << plain.output;
  EXPECT_EQ(hash(), through);
  EXPECT_FALSE(fs::exists(rd / app::RenderOutput::frame_name(6)));
  EXPECT_FALSE(fs::exists(rd / app::RenderOutput::frame_name(5)));
  EXPECT_TRUE(fs::exists(rd / app::RenderOutput::frame_name(4)));
  // Its frames stopped there: a later resume does not take the folder for a whole rendering.
  EXPECT_FALSE(fs::exists(rd / "render.json"));
  // A later resume says that it does not draw, and why (it went on without a word: the hostile review of
  // 2026-12-06).
  fs::remove(dir / "checkpoints" / "frame_000006.mcack");
  const Result later = run_mca("resume -q " + dir.string());
  ASSERT_EQ(later.code, 0) << later.output;
  EXPECT_NE(later.output.find(fmt::format("warning: {} holds 5 rendered frames but no render.json", rd.string())),
            std::string::npos)
      << later.output;
  EXPECT_NE(later.output.find("the frames this resume adds are not drawn"), std::string::npos) << later.output;
  EXPECT_EQ(hash(), through);
  // A folder where render.json goes is named, with the fix (it was a raw stream error, exit 1).
  fs::remove(dir / "checkpoints" / "frame_000006.mcack");
  fs::create_directory(rd / "render.json");
  const Result folder = run_mca("resume -q " + dir.string());
  EXPECT_EQ(folder.code, 2) << folder.output;
  EXPECT_NE(folder.output.find((rd / "render.json").string() + ": it is a directory"), std::string::npos)
      << folder.output;
  EXPECT_NE(folder.output.find("remove it to resume without rendering"), std::string::npos) << folder.output;
  fs::remove(rd / "render.json");
  // A width past int (1e300) is named as written, not wrapped to -2147483648.
  std::ofstream(rd / "render.json") << R"({"width": 1e300, "height": 180, "colour": "damage", "draw": "cubes", "fps": 10})";
  const Result wide = run_mca("resume -q " + dir.string());
  EXPECT_EQ(wide.code, 2) << wide.output;
  EXPECT_NE(wide.output.find("width 1e300 is not a whole number of pixels from 16 to 8192"), std::string::npos)
      << wide.output;
}

TEST(Render, WithoutFfmpegThePngsAreWrittenAndTheMessageSaysHowToGetTheVideo) {
  TempDir d;
  // A PATH without ffmpeg (the program is called by its full path).
  const Result r = shell("PATH=/nonexistent " + std::string(MCA_BINARY) + " run " + kCubicWall + " -q --steps 10 --render --render-size 64x48 --out " +
                         d.path().string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("apt-get install ffmpeg"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(d.path() / "render" / "frame_000001.png"));
  EXPECT_FALSE(fs::exists(d.path() / "render" / "video.mp4"));
}

// A Ctrl-C while the plots are made stops the plot script (in a process group of its own: a terminal's
// Ctrl-C printed its Python traceback) without a warning; `mca run` then exits 130 (it had exited 0,
// calling the user's Ctrl-C a failed plot: found by the hostile review of 2026-12-05).
TEST(Render, AStopSignalStopsThePlotScript) {
  TempDir d;
  const Result r = run_mca(std::string("run ") + kCubicWall + " -q --steps 10 --render --render-size 64x48 --out " +
                           d.path().string());
  ASSERT_EQ(r.code, 0) << r.output;
  const fs::path plot = d.path() / "render" / "energies.png";
  ASSERT_TRUE(fs::exists(plot));
  fs::remove(plot);
  std::atomic<int> stop{SIGINT};
  testing::internal::CaptureStderr();
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(app::run_plot_script(d.path(), true, stop));
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 10.0);
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
  EXPECT_FALSE(fs::exists(plot));
  stop = 0;
  EXPECT_TRUE(app::run_plot_script(d.path(), true, stop));
  EXPECT_TRUE(fs::exists(plot));
}

// An ffmpeg that fails (no libx264: exits 1 with a message) or writes nothing (exits 0) costs the video
// only: a warning with its message and the command, and the run finishes with every other output.
TEST(Render, AFailingFfmpegDropsTheVideoAndTheRunGoesOn) {
  // The last three are stuck (one takes no frame, one never ends): stopped after MCA_FFMPEG_TIMEOUT seconds,
  // also where a frame is larger than the pipe to ffmpeg (64 KB; 320x180 is 230 KB: its write blocked for ever).
  for (const std::string body : {"cat > /dev/null; echo \"Unknown encoder 'libx264'\" >&2; exit 1",
                                 "echo \"Unknown encoder 'libx264'\" >&2; exit 1", "cat > /dev/null; exit 0",
                                 "exec sleep 1000", "cat > /dev/null; exec sleep 1000", "exec sleep 1001",
                                 "for a; do last=$a; done; cat > /dev/null; printf 'not a video' > \"$last\""}) {
    const std::string size = body == "exec sleep 1001" ? "320x180" : "64x48";
    TempDir d;
    const fs::path bin = d.path() / "bin", out = d.path() / "out";
    fs::create_directories(bin);
    std::ofstream(bin / "ffmpeg") << "#!/bin/sh\n" << body << "\n";
    fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
    // (Under a time limit of its own: the hang was for ever.)
    const Result r = shell("MCA_FFMPEG_TIMEOUT=2 PATH=" + bin.string() + ":/usr/bin:/bin timeout 120 " +
                           std::string(MCA_BINARY) + " run " + kCubicWall + " -q --duration 0.004 --render --render-size " +
                           size + " --out " + out.string());
    ASSERT_EQ(r.code, 0) << body << ": " << r.output;
    if (body.find("sleep") != std::string::npos) {
      EXPECT_NE(r.output.find("was stopped"), std::string::npos) << body << ": " << r.output;
    }
    EXPECT_NE(r.output.find("warning: "), std::string::npos) << r.output;
    EXPECT_NE(r.output.find("frame_%06d.png"), std::string::npos) << r.output;
    if (body.find("exit 1") != std::string::npos) {
      EXPECT_NE(r.output.find("Unknown encoder 'libx264'"), std::string::npos) << r.output;
    }
    if (body.find("exit 0") != std::string::npos || body.find("printf") != std::string::npos) {
      // (Ended well, no video: a file of 11 bytes was kept as the video.)
      EXPECT_NE(r.output.find("ffmpeg ended without error but wrote no MP4 video"), std::string::npos) << r.output;
      EXPECT_NE(r.output.find(body.find("printf") != std::string::npos ? "it does not begin with an MP4 file's" :
                                                                         "(it wrote no file)"),
                std::string::npos)
          << r.output;
    }
    for (const char* f : {"summary.json", "stats.csv", "fragments.csv", "render/frame_000002.png", "render/contact_sheet.png"})
      EXPECT_TRUE(fs::exists(out / f)) << body << ": " << f;
    EXPECT_FALSE(fs::exists(out / "render" / "video.mp4")) << body;
    for (const auto& e : fs::directory_iterator(out / "render")) EXPECT_NE(e.path().extension(), ".tmp") << e.path();
  }
}

// The time limit is on ffmpeg writing nothing, not on all of its finishing: one that takes 3 s to finish the
// file, writing to it every 0.4 s, makes the video under a limit of 1 s (it was stopped, and the video lost),
// and the wait is said; one that writes once and then nothing is stopped.
TEST(Render, AnFfmpegStillWritingAsItFinishesIsWaitedFor) {
  const std::string finish = "for a; do last=$a; done; cat > /dev/null; ";
  for (const bool writing : {true, false}) {
    TempDir d;
    const fs::path bin = d.path() / "bin", out = d.path() / "out";
    fs::create_directories(bin);
    std::ofstream(bin / "ffmpeg") << "#!/bin/sh\n"
                                  << finish
                                  << "printf '\\000\\000\\000\\010ftyp' > \"$last\"; "
                                  << (writing ? "for i in 1 2 3 4 5 6 7 8; do printf x >> \"$last\"; sleep 0.4; done"
                                              : "printf x >> \"$last\"; exec sleep 1000")
                                  << "\n";
    fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
    const Result r = shell("MCA_FFMPEG_TIMEOUT=1 PATH=" + bin.string() + ":/usr/bin:/bin timeout 120 " +
                           std::string(MCA_BINARY) + " run " + kCubicWall + (writing ? "" : " -q") +
                           " --duration 0.004 --render --render-size 64x48 --out " + out.string());
    ASSERT_EQ(r.code, 0) << r.output;
    if (writing) {
      EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
      // (A wait of more than 2 s is said: the run showed nothing after its last frame.)
      EXPECT_NE(r.output.find("render: waiting for ffmpeg to finish " + (out / "render" / "video.mp4").string() +
                              " (stopped if it writes nothing for 1 s)"),
                std::string::npos)
          << r.output;
      ASSERT_TRUE(fs::exists(out / "render" / "video.mp4")) << r.output;
      EXPECT_EQ(fs::file_size(out / "render" / "video.mp4"), 16u);
    } else {
      EXPECT_NE(r.output.find("ffmpeg wrote nothing to '" + (out / "render" / "video.mp4").string() +
                              "' for 1 s while finishing it and was stopped"),
                std::string::npos)
          << r.output;
      EXPECT_FALSE(fs::exists(out / "render" / "video.mp4"));
    }
    for (const auto& e : fs::directory_iterator(out / "render")) EXPECT_NE(e.path().extension(), ".tmp") << e.path();
  }
}

// The command that warning gives makes the video when pasted into a shell, in a folder whose name holds
// spaces, a quote, a dollar sign, a star and a % (each one word of the command, quoted as the shell needs;
// the % doubled in the frames' pattern, where ffmpeg read "50%d" as a number).
TEST(Render, TheVideoCommandOfTheWarningMakesTheVideoInAnOddlyNamedFolder) {
  TempDir d;
  const fs::path bin = d.path() / "bin", out = d.path() / "it's a 50%d run $HOME *";
  fs::create_directories(bin);
  std::ofstream(bin / "ffmpeg") << "#!/bin/sh\ncat > /dev/null; echo \"Unknown encoder 'libx264'\" >&2; exit 1\n";
  fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
  const Result r = shell("PATH=" + bin.string() + ":/usr/bin:/bin " + std::string(MCA_BINARY) + " run " + kCubicWall +
                         " -q --duration 0.004 --render --render-size 64x48 --out " + text::shell_word(out.string()));
  ASSERT_EQ(r.code, 0) << r.output;
  ASSERT_FALSE(fs::exists(out / "render" / "video.mp4"));
  const std::string lead = "an ffmpeg that has libx264: ";
  const auto at = r.output.find(lead);
  ASSERT_NE(at, std::string::npos) << r.output;
  const std::string command = r.output.substr(at + lead.size(), r.output.find('\n', at) - at - lead.size());
  const Result made = shell(command + " -loglevel error");
  ASSERT_EQ(made.code, 0) << command << ": " << made.output;
  ASSERT_TRUE(fs::exists(out / "render" / "video.mp4")) << command;
  EXPECT_GT(fs::file_size(out / "render" / "video.mp4"), 0u);
  EXPECT_EQ(std::distance(fs::directory_iterator(d.path()), fs::directory_iterator{}), 2) << "the command wrote elsewhere";
}

// A contact sheet that cannot be written (a full disk at it) stopped the run with exit 2 after its summary
// said "finished", with no word on how to have it; it is a warning naming the frames it shows, as a video
// that cannot be made is.
TEST(Render, AContactSheetThatCannotBeWrittenIsAWarningNamingItsFrames) {
  TempDir d;
  const fs::path out = d.path() / "out";
  const Result r = test::run_mca_full_at("render/contact_sheet.png", "run " + kCubicWall +
                                                                         " -q --duration 0.004 --render --render-size 64x48 --out " +
                                                                         out.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("No space left on device"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("the contact sheet is not written: it shows frame_000000.png, frame_000001.png, "
                          "frame_000002.png in " + (out / "render").string()),
            std::string::npos)
      << r.output;
  EXPECT_FALSE(fs::exists(out / "render" / "contact_sheet.png"));
  EXPECT_TRUE(fs::exists(out / "render" / "frame_000002.png"));
}

// A relative output folder that ffmpeg read as an option ("-odd") or a protocol ("run:1", an ISO time) left
// the run without its video (a warning, exit 0); "tcp:host:port" had ffmpeg open a connection. The run's
// encoder and the command its warning gives name such a path "./" first.
TEST(Render, AnOutputFolderFfmpegWouldTakeForAnOptionOrAProtocolGetsItsVideo) {
  if (!render::find_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed: no video to check";
  TempDir d;
  for (const std::string out : {"-odd", "2026-12-06T23:15:00", "run:1"}) {
    SCOPED_TRACE(out);
    const Result r = shell("cd " + d.path().string() + " && " + std::string(MCA_BINARY) + " run " + kCubicWall +
                           " -q --duration 0.004 --render --render-size 64x48 --out=" + text::shell_word(out));
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_EQ(r.output.find("warning"), std::string::npos) << r.output;
    EXPECT_TRUE(fs::exists(d.path() / out / "render" / "video.mp4"));
  }
  EXPECT_EQ(render::ffmpeg_file("run:1/render/video.mp4"), "./run:1/render/video.mp4");
  EXPECT_EQ(render::ffmpeg_file("/tmp/run:1/video.mp4"), "/tmp/run:1/video.mp4");
}

// mca ignores SIGXFSZ (a file at ulimit -f is a write error that names it) and SIGPIPE; ffmpeg inherited
// that, and a video at the limit was kept cut short with exit 0. ffmpeg starts with both as by default
// (here a stand-in that tells what it was given, then fails).
TEST(Render, FfmpegStartsWithTheSignalsMcaIgnoresAsByDefault) {
  TempDir d;
  const fs::path bin = d.path() / "bin";
  fs::create_directories(bin);
  std::ofstream(bin / "ffmpeg") << "#!/bin/bash\ncat > /dev/null; echo \"signals [$(trap -p XFSZ PIPE)]\" >&2; exit 1\n";
  fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
  const Result r = shell("PATH=" + bin.string() + ":/usr/bin:/bin " + std::string(MCA_BINARY) + " run " + kCubicWall +
                         " -q --duration 0.004 --render --render-size 64x48 --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("(exit code 1): signals []"), std::string::npos) << r.output;
}

// A stop signal is not held up by ffmpeg (it waited up to MCA_FFMPEG_TIMEOUT, 120 s by default, found by
// the hostile review): one that never finishes the file after the run's last frame is stopped, the run
// says the video is not written and how to make it, and ends with 128 + the signal; one that takes no
// frame is stopped too, and the run ends as any run stopped inside a frame.
TEST(Render, AStopSignalDoesNotWaitForFfmpeg) {
  const struct {
    const char* body;
    const char* size;
    const char* signal_after;  // the file whose writing the signal follows
    std::vector<std::string> said;
  } cases[] = {
      // (A wrapper script whose ffmpeg is its child: the child goes with it, by the process group.)
      {"cat > /dev/null; sleep 1000 & echo $! > \"$0.child\"; wait", "65x49", "summary.json",
       {"is not written: a stop signal came before ffmpeg finished", "Make it from the frames with: ffmpeg",
        "interrupted by SIGTERM after the run's last frame (2): its outputs are complete but for the video (the "
        "command above makes it) and the plots"}},
      // (frames of 1.2 MB: the pipe takes none of them whole; the run waits in frame 0's)
      {"exec sleep 1000", "640x480", "render/frame_000000.png", {"interrupted by SIGTERM inside frame 1"}},
  };
  for (const auto& c : cases) {
    SCOPED_TRACE(c.body);
    TempDir d;
    const fs::path bin = d.path() / "bin", out = d.path() / "out";
    fs::create_directories(bin);
    std::ofstream(bin / "ffmpeg") << "#!/bin/sh\n" << c.body << "\n";
    fs::permissions(bin / "ffmpeg", fs::perms::owner_all);
    // The time from the signal to the end is measured.
    const Result r = shell("MCA_FFMPEG_TIMEOUT=60 PATH=" + bin.string() + ":/usr/bin:/bin " +
                           std::string(MCA_BINARY) + " run " + kCubicWall +
                           " -q --duration 0.004 --render --render-size " + c.size + " --out " + out.string() +
                           " & p=$!; for i in $(seq 400); do [ -f " + (out / c.signal_after).string() +
                           " ] && break; sleep 0.05; done; sleep 0.5; t0=$(date +%s%N); kill -TERM $p; wait $p; "
                           "echo rc=$? ms=$((($(date +%s%N) - t0) / 1000000))");
    EXPECT_NE(r.output.find("rc=143"), std::string::npos) << r.output;
    const auto ms = r.output.find("ms=");
    ASSERT_NE(ms, std::string::npos) << r.output;
    EXPECT_LT(std::stoi(r.output.substr(ms + 3)), 2000) << r.output;  // (ffmpeg goes within 0.1 s; then the end)
    for (const auto& said : c.said) EXPECT_NE(r.output.find(said), std::string::npos) << said << "\n" << r.output;
    if (fs::exists(bin / "ffmpeg.child")) {
      const std::string pid = read_text(bin / "ffmpeg.child");
      ASSERT_FALSE(pid.empty());
      // Gone, or a zombie its new parent has not reaped yet.
      const auto alive = [&] {
        const std::string stat = read_text(fs::path("/proc") / std::to_string(std::stoi(pid)) / "stat");
        const auto paren = stat.rfind(')');
        return paren != std::string::npos && paren + 2 < stat.size() && stat[paren + 2] != 'Z';
      };
      for (int k = 0; k < 40 && alive(); ++k) std::this_thread::sleep_for(std::chrono::milliseconds(50));
      EXPECT_FALSE(alive()) << "the wrapper's child " << pid << " outlived mca";
      if (alive()) shell("kill -9 " + pid);
    }
    EXPECT_FALSE(fs::exists(out / "render" / "video.mp4"));
    for (const auto& e : fs::directory_iterator(out / "render")) EXPECT_NE(e.path().extension(), ".tmp") << e.path();
    // The command it names makes the video (of the odd size too, cropped as the run's encoder does).
    const auto command = r.output.find("Make it from the frames with: ");
    if (command == std::string::npos || !render::find_ffmpeg()) continue;
    const std::string line = r.output.substr(command + 30, r.output.find('\n', command) - command - 30);
    const Result made = shell(line);
    EXPECT_EQ(made.code, 0) << line << "\n" << made.output;
    EXPECT_GT(fs::exists(out / "render" / "video.mp4") ? fs::file_size(out / "render" / "video.mp4") : 0u, 0u) << line;
  }
}

// A folder named ffmpeg earlier on PATH is not the program: the one after it makes the video.
TEST(Render, AFolderNamedFfmpegOnThePathIsPassedOver) {
  if (!render::find_ffmpeg()) GTEST_SKIP() << "ffmpeg is not installed";
  TempDir d;
  fs::create_directories(d.path() / "bin" / "ffmpeg");
  const Result r = shell("PATH=" + (d.path() / "bin").string() + ":/usr/bin:/bin " + std::string(MCA_BINARY) +
                         " run " + kCubicWall + " -q --duration 0.004 --render --render-size 64x48 --out " + (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_TRUE(fs::exists(d.path() / "out" / "render" / "video.mp4")) << r.output;
}

TEST(Render, NoOpenGLStopsBeforeTheRunWithAClearMessage) {
  TempDir d;
  // No EGL vendor library: no display, no context.
  const Result r = shell("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json __EGL_VENDOR_LIBRARY_DIRS=/nonexistent " +
                         std::string(MCA_BINARY) + " run " + kCubicWall + " -q --steps 10 --render --out " + d.path().string());
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("cannot create an offscreen OpenGL"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("without --render"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(d.path() / "render"));
  EXPECT_FALSE(fs::exists(d.path() / "scene.toml"));
  const Result fresh = shell("__EGL_VENDOR_LIBRARY_FILENAMES=/nonexistent.json __EGL_VENDOR_LIBRARY_DIRS=/nonexistent " +
                             std::string(MCA_BINARY) + " run " + kCubicWall + " -q --steps 10 --render --out " + (d.path() / "new").string());
  EXPECT_NE(fresh.code, 0);
  EXPECT_FALSE(fs::exists(d.path() / "new")) << fresh.output;
  EXPECT_FALSE(fs::exists(d.path() / "stats.csv"));
}

TEST(Render, BadOptionsAreRefusedWithTheFix) {
  TempDir d;
  for (const std::string size : {"0x720", "1280x0", "abc", "1280x", "-5x10", "100000x100"}) {
    const Result r = run_mca("run " + kCubicWall + " -q --steps 1 --render --render-size " + size + " --out " + d.path().string());
    EXPECT_EQ(r.code, 2) << size << ": " << r.output;
    EXPECT_NE(r.output.find("--render-size"), std::string::npos) << r.output;
  }
  const Result c = run_mca("run " + kCubicWall + " -q --steps 1 --render --render-colour rainbow --out " + d.path().string());
  EXPECT_EQ(c.code, 2);
  EXPECT_NE(c.output.find("fragment, damage"), std::string::npos) << c.output;
  const Result s = run_mca("run " + kCubicWall + " -q --steps 1 --render --render-draw surface --out " + d.path().string());
  EXPECT_EQ(s.code, 2);
  EXPECT_NE(s.output.find("mesh"), std::string::npos) << s.output;
  for (const std::string fps : {"0.001", "0.5", "241", "-1", "nan"}) {
    const Result f = run_mca("run " + kCubicWall + " -q --steps 1 --render --render-fps " + fps + " --out " + d.path().string());
    EXPECT_EQ(f.code, 2) << fps << ": " << f.output;
    EXPECT_NE(f.output.find("give 1 to 240"), std::string::npos) << f.output;
  }
  // Refused when the renderer is made: the output folder this run would have created is not left behind.
  const fs::path fresh = d.path() / "fresh" / "out";
  const Result e = run_mca("run " + kCubicWall + " -q --steps 1 --render --render-draw surface --out " + fresh.string());
  EXPECT_EQ(e.code, 2) << e.output;
  EXPECT_FALSE(fs::exists(d.path() / "fresh")) << e.output;
  const Result n = run_mca("run " + kCubicWall + " -q --steps 1 --render-size 64x64 --out " + d.path().string());
  EXPECT_NE(n.code, 0);  // --render-size needs --render
  // An output folder that cannot be written.
  const Result w = run_mca("run " + kCubicWall + " -q --steps 1 --render --out /proc/mca_cannot_write");
  EXPECT_EQ(w.code, 2) << w.output;
  EXPECT_NE(w.output.find("/proc/mca_cannot_write"), std::string::npos) << w.output;
}

// Expects `f` to throw mca::Error whose message holds `words` and names the scene file cam.toml.
template <class F>
void expect_error(F&& f, const std::string& what, const std::string& words) {
  try {
    f();
    ADD_FAILURE() << what << " was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cam.toml"), std::string::npos) << e.what();
  }
}

SceneDef scene_with_camera(const std::string& camera) {
  std::string text = io::kDefaultSceneToml;
  return io::parse_scene(text + "\n[camera]\n" + camera + "\n", "cam.toml");
}

TEST(Render, CameraTableIsReadValidatedAndWrittenBack) {
  const SceneDef s = scene_with_camera("position = [3.0, -4.0, 2.0]\ntarget = [0.0, 0.0, 0.5]\nfov = 30");
  ASSERT_TRUE(s.camera.position && s.camera.target);
  EXPECT_EQ((*s.camera.position)[1], -4.0);
  EXPECT_EQ(s.camera.fov, 30.0);
  const SceneDef back = io::parse_scene(io::scene_to_toml(s), "back.toml");
  EXPECT_EQ(back.camera.position, s.camera.position);
  EXPECT_EQ(back.camera.target, s.camera.target);
  EXPECT_EQ(back.camera.fov, 30.0);
  const auto fails = [](const std::string& cam, const std::string& words) {
    expect_error([&] { scene_with_camera(cam); }, cam, words);
  };
  fails("fov = 0", "camera.fov = 0 is out of range");
  fails("fov = 179", "[5, 150]");
  fails("position = [1.0, 1.0, 1.0]\ntarget = [1.0, 1.0, 1.0]", "needs a direction");
  fails("positon = [1.0, 1.0, 1.0]", "did you mean 'position'");
  fails("position = [1.0, 2.0]", "position");
}

TEST(Render, CameraInsideTheObjectsOrLookingAwayIsAnError) {
  const auto check = [](const std::string& cam, const std::string& words) {
    const SceneDef s = scene_with_camera(cam);
    Engine sim(s);
    const auto f = render::objects_box(sim.model(), sim.state());
    expect_error([&] { render::make_camera(s.camera, sim.model(), f, 16.0f / 9, s.source); }, cam, words);
  };
  check("position = [0.2, 0.0, 0.7]", "inside an object's bounding box");
  check("position = [0.0, -5.0, 1.0]\ntarget = [0.0, -10.0, 1.0]", "sees none of the objects");
  // A target alone, far from the objects: the automatic position frames them from afar, a speck.
  check("target = [100.0, 0.0, 0.75]", "sees the objects only as a speck");
  check("position = [0.0, -300.0, 1.0]", "sees the objects only as a speck");
  check("position = [0.0, -5.0, -1.0]", "below the ground");
  // A camera behind the wall looking at it is fine, and so is one given only a field of view.
  for (const std::string ok : {"position = [0.0, 5.0, 1.0]", "fov = 60"}) {
    const SceneDef s = scene_with_camera(ok);
    Engine sim(s);
    const auto f = render::objects_box(sim.model(), sim.state());
    EXPECT_NO_THROW(render::make_camera(s.camera, sim.model(), f, 16.0f / 9, s.source)) << ok;
  }
  // Between two objects, inside the box around both but in neither's: fine.
  SceneDef two = scene_with_camera("position = [5.0, 4.0, 1.2]\ntarget = [0.0, 0.0, 0.75]");
  ObjectDef far = two.objects[0];
  far.name = "far wall";
  far.position = {10, 8, 0.75};
  two.objects.push_back(far);
  Engine sim(two);
  const auto f = render::objects_box(sim.model(), sim.state());
  EXPECT_NO_THROW(render::make_camera(two.camera, sim.model(), f, 16.0f / 9, two.source));
}

// A view straight down the up axis is lit as one a hair off it (the key light's side was the cross product of
// the view and up: NaN, and the picture unlit); a camera under the ground looking straight up is refused (the
// check took the camera's own up, turned off the axis for such a view); the automatic camera frames a ball
// it would be in (a 3 m ball beside the wall held it, and the ball was not drawn) and looks past balls that
// would hide the objects, and a camera placed in a ball is refused (hostile review of the pictures).
TEST(Render, ViewsAlongTheUpAxisAndBallsAroundTheCamera) {
  constexpr int W = 160, H = 90;
  Offscreen off(W, H);
  const auto draw_from = [&](const SceneDef& s, const Vec3d& at_point) {
    Engine sim(s);
    const auto framing = render::objects_box(sim.model(), sim.state());
    const auto cam = render::make_camera(s.camera, sim.model(), framing, float(W) / H, s.source);
    const render::Image im = off.draw(sim, framing, cam);
    const glm::vec2 px = project(cam, framing, at_point, W, H);
    EXPECT_TRUE(px.x > 0 && px.x < W && px.y > 0 && px.y < H) << px.x << " " << px.y;
    return at(im, int(px.x), int(px.y));
  };
  SceneDef s = test::cubic_wall_scene();
  const Vec3d ground{0.9, 0.6, 0.0}, wall_top{0.5, 0.0, 1.5};
  s.camera.target = Vec3d{0, 0, 0.75};
  for (const Vec3d& p : {ground, wall_top}) {
    s.camera.position = Vec3d{0, 0, 10};
    const Pixel down = draw_from(s, p);
    s.camera.position = Vec3d{0, 0.001, 10};
    const Pixel off_axis = draw_from(s, p);
    EXPECT_NEAR(down.r + down.g + down.b, off_axis.r + off_axis.g + off_axis.b, 12)
        << down.r << " " << down.g << " " << down.b << " against " << off_axis.r << " " << off_axis.g << " " << off_axis.b;
  }
  const auto refused = [&](const SceneDef& c, const std::string& words) {
    Engine sim(c);
    const auto framing = render::objects_box(sim.model(), sim.state());
    expect_error([&] { render::make_camera(c.camera, sim.model(), framing, float(W) / H, "cam.toml"); }, words, words);
  };
  s.camera.position = Vec3d{0, 0, -5};
  refused(s, "below the ground");
  s.camera.position = Vec3d{0, -0.4, 0.75};  // the ball's centre
  refused(s, "is inside projectile 'ball' (radius 0.2 m");
  s.camera.position = Vec3d{0.0125, -0.4125, 0.7625};  // the position as written, not to 3 digits
  refused(s, "position = [0.0125, -0.4125, 0.7625] is inside projectile 'ball'");
  s.camera.position = Vec3d{0, 0, 0.75};  // the wall's centre, where it looks by default
  s.camera.target.reset();
  refused(s, "inside an object's bounding box");
  // The automatic camera and a ball of 3 m against the wall's face: outside it, the ball drawn (red).
  SceneDef big = test::cubic_wall_scene();
  big.projectiles[0].radius = 3;
  big.projectiles[0].position = {0, -3.2, 3};
  Engine sim(big);
  const auto framing = render::objects_box(sim.model(), sim.state());
  const auto cam = render::make_camera(big.camera, sim.model(), framing, float(W) / H, big.source);
  const glm::dvec3 eye = glm::dvec3(cam.eye) + glm::dvec3(framing.origin[0], framing.origin[1], framing.origin[2]);
  EXPECT_GT(glm::length(eye - glm::dvec3(0, -3.2, 3)), 3.0);
  const render::Image im = off.draw(sim, framing, cam);
  int red = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const Pixel p = at(im, x, y);
      red += p.r > 2 * p.g + 10 && p.r > 2 * p.b + 10;
    }
  EXPECT_GT(red, W * H / 50);
  // ... and the wall not hidden behind it (the 3/4 view from the ball's side saw the ball alone): the automatic
  // camera looks from where no ball stands before the objects; so for a ball of 1 m on the ground before it.
  SceneDef one = big;
  one.projectiles[0].radius = 1;
  one.projectiles[0].position = {0, -1.2, 1};
  for (const SceneDef* c : {&big, &one})
    for (const Vec3d& p : {Vec3d{0, 0, 0.75}, Vec3d{0.4, 0, 1.4}, Vec3d{-0.4, 0, 0.1}}) {
      const Pixel wall = draw_from(*c, p);
      EXPECT_LT(wall.r, wall.g + 30) << c->projectiles[0].radius << " m ball, at " << p[0] << " " << p[2] << ": "
                                     << wall.r << " " << wall.g << " " << wall.b;
    }
  // A cube of 0.2 m beside a ball of 3 m: every view of the cube stood within 1.5 radii of the ball's centre,
  // the camera drew back to frame the ball, and the scene was refused (the cube "only a speck").
  SceneDef tiny = big;
  tiny.objects[0].size = {0.2, 0.2, 0.2};
  tiny.objects[0].position = {0, 0, 0.1};
  tiny.projectiles[0].position = {0, -3.15, 3.01};
  // ... and under a ball of 2 m just above it (every view of it at 25 degrees or more is in the ball: it is
  // seen from near the horizon).
  SceneDef above = tiny;
  above.projectiles[0].radius = 2;
  above.projectiles[0].position = {0, 0, 2.25};
  for (const SceneDef* c : {&tiny, &above}) {
    const Pixel cube = draw_from(*c, {0, 0, 0.1});
    EXPECT_FALSE(is_background(cube));
    EXPECT_LT(cube.r, cube.g + 30) << c->projectiles[0].position[2] << ": " << cube.r << " " << cube.g << " " << cube.b;
  }
  // A slab of 2 cm 1 cm under a ball of 100 m: every view is in the ball, and the 3/4 view drawn back to frame
  // it sees the slab as a speck: the automatic camera's own choice, taken, not refused.
  SceneDef slab = test::cubic_wall_scene();
  slab.solver.spacing = 0.01;
  slab.objects[0].size = {0.2, 0.2, 0.02};
  slab.objects[0].position = {0, 0, 0.01};
  slab.projectiles[0].radius = 100;
  slab.projectiles[0].position = {0, 0, 100.03};
  Engine under(slab);
  const auto f3 = render::objects_box(under.model(), under.state());
  render::Camera far_back;
  EXPECT_NO_THROW(far_back = render::make_camera(slab.camera, under.model(), f3, float(W) / H, slab.source));
  EXPECT_NE(far_back.note.find("sees object 'wall' as a speck"), std::string::npos) << far_back.note;
  EXPECT_NE(far_back.note.find("every view of the objects is in a ball, and it is drawn back to frame the ball"),
            std::string::npos)
      << far_back.note;
  // Balls before the wall and behind it: their mean, at the wall, gave no side, and the camera looked along
  // the x axis at the wall's edge; it looks at its face from the first ball's side.
  SceneDef both = test::cubic_wall_scene();
  both.projectiles.push_back(both.projectiles[0]);
  both.projectiles[1].name = "behind";
  both.projectiles[1].position = {0, 0.4, 0.75};
  Engine two(both);
  const auto f2 = render::objects_box(two.model(), two.state());
  const glm::vec3 view = render::make_camera(both.camera, two.model(), f2, float(W) / H, both.source).eye;
  EXPECT_LT(view.y, -std::abs(view.x)) << view.x << " " << view.y;  // (the 3/4 view: y = -1.43 x)
}

// The lines at the top stop at half the picture's height (the viewer's five lines, wrapped, covered a window
// of 120x60); the first is drawn however small the picture.
TEST(Render, TheOverlayLeavesTheLowerHalfOfASmallPicture) {
  const SceneDef s = test::cubic_wall_scene();
  Engine sim(s);
  const auto framing = render::objects_box(sim.model(), sim.state());
  render::Overlay text;
  text.legend = false;
  text.lines = {"31 fps   2400 steps/s   paused", "automata 4800   drawn 2800",
                "ball 40 m/s  r 0.10 m  32.0 kg   colour fragment  draw cubes", "a message of the last shot, long"};
  render::Overlay none = text;
  none.counters = false;
  none.lines.clear();
  for (const auto& [W, H] : {std::pair{120, 60}, {160, 90}, {64, 20}}) {
    Offscreen off(W, H);
    const auto cam = render::make_camera(s.camera, sim.model(), framing, float(W) / H, s.source);
    const render::Image with = off.draw(sim, framing, cam, render::ColourMode::fragment, text);
    const render::Image without = off.draw(sim, framing, cam, render::ColourMode::fragment, none);
    int lowest = -1;  // the lowest row the text changed
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        if (std::memcmp(&with.rgba[4 * (std::size_t(y) * W + x)], &without.rgba[4 * (std::size_t(y) * W + x)], 3))
          lowest = y;
    EXPECT_GE(lowest, 8) << W << "x" << H << ": no text";
    EXPECT_LE(lowest, std::max(H / 2, 8 + render::kGlyphHeight)) << W << "x" << H;
  }
}

// A legend keeps to the lower third of the picture: a label takes two lines at most (ending "..."), and
// swatches past a third of the height give way to a line that counts them (a material named with 159
// characters covered a picture of 320x180; 60 long names filled the lower half of 1280x720); the first
// swatch is always shown (at 160x90 the legend named none).
TEST(Render, TheLegendKeepsToTheLowerThirdOfThePicture) {
  const SceneDef s = test::cubic_wall_scene();
  Engine sim(s);
  const auto framing = render::objects_box(sim.model(), sim.state());
  const auto frags = analysis::label_model_fragments(sim.model(), sim.state().intact.data());
  render::SnapshotOptions o;
  o.colour = render::ColourMode::group;
  const std::string word = "concrete of the north wall poured in two lifts ";
  for (const auto& [W, H] : {std::pair{160, 90}, {320, 180}, {640, 360}, {1280, 720}})
    for (const std::size_t swatches : {1, 3, 12, 60}) {
      render::EglContext context;
      render::Renderer renderer;
      render::OffscreenTarget target(W, H);
      const auto cam = render::make_camera(s.camera, sim.model(), framing, float(W) / H, s.source);
      auto snap = render::make_snapshot(sim.model(), sim.state(), frags, o, framing.origin);
      snap.legend.swatches.clear();
      for (std::size_t k = 0; k < swatches; ++k)
        snap.legend.swatches.push_back({word + word + word + std::to_string(k),
                                        render::Rgba{255, static_cast<std::uint8_t>(k), 255, 255}});
      const auto draw = [&](bool legend) {
        render::Overlay overlay;
        overlay.counters = false;
        overlay.legend = legend;
        target.bind();
        renderer.draw(snap, render::DrawMode::cubes, cam, W, H, overlay);
        render::Image im{W, H, {}};
        target.read_rgba(im.rgba);
        return im;
      };
      const render::Image with = draw(true), without = draw(false);
      int highest = H;  // the highest row the legend changed
      for (int y = H; y-- > 0;)
        for (int x = 0; x < W; ++x)
          if (std::memcmp(&with.rgba[4 * (std::size_t(y) * W + x)], &without.rgba[4 * (std::size_t(y) * W + x)], 3))
            highest = y;
      const int scale = std::max(1, static_cast<int>(std::lround(std::min(H / 360.0, W / 640.0))));
      EXPECT_LT(highest, H - 20) << W << "x" << H << ", " << swatches << " swatches: no legend";
      // (Two lines and the title at least: on 160x90, half the picture.)
      const int two_lines = H - (8 + 3 * (render::kGlyphHeight + 4) + 4) * scale;
      EXPECT_GE(highest, std::min(2 * H / 3 - 4 * scale, two_lines)) << W << "x" << H << ", " << swatches << " swatches";
      bool first = false;  // the first swatch's colour
      for (std::size_t p = 0; p + 3 < with.rgba.size(); p += 4)
        first = first || (with.rgba[p] == 255 && with.rgba[p + 1] == 0 && with.rgba[p + 2] == 255);
      EXPECT_TRUE(first) << W << "x" << H << ", " << swatches << " swatches: the first is not shown";
    }
}

// The automatic camera is never refused, and looks at the objects, however balls stand around them: 60
// scenes of one to three boxes (0.2 to 2 m) on the ground and one to four balls (radius 5 cm to 5 m) next to
// them at random, beside, above, over an edge (hostile reviews: a cube under a 2 m ball, beside a 3 m ball,
// were refused as specks).
TEST(Render, TheAutomaticCameraTakesEveryScene) {
  std::mt19937 rng(20261206);
  const auto uniform = [&](double lo, double hi) { return std::uniform_real_distribution<double>(lo, hi)(rng); };
  int built = 0;
  for (int attempt = 0; built < 200 && attempt < 5000; ++attempt) {
    SceneDef s = test::cubic_wall_scene();
    s.solver.spacing = 0.1;
    s.objects.resize(1 + attempt % 3, s.objects[0]);
    for (std::size_t k = 0; k < s.objects.size(); ++k) {
      ObjectDef& o = s.objects[k];
      o.name = "box" + std::to_string(k);
      const auto side = [&] { return std::exp(uniform(std::log(0.2), std::log(2.0))); };
      o.size = {side(), side(), side()};
      o.position = {uniform(-3, 3), uniform(-3, 3), 0.5 * o.size[2]};
    }
    const ProjectileDef ball = s.projectiles[0];
    s.projectiles.clear();
    for (int k = 0; k < 1 + attempt % 4; ++k) {
      // Next to a box, in a random direction: beside it, above it, over its edge.
      ProjectileDef b = ball;
      b.name = "ball" + std::to_string(k);
      b.radius = std::exp(uniform(std::log(0.05), std::log(5.0)));
      const ObjectDef& o = s.objects[static_cast<std::size_t>(k) % s.objects.size()];
      const double phi = uniform(0, 6.2832), up = k % 2 ? uniform(0.7, 1) : uniform(-0.2, 1);
      const double reach = 0.5 * std::sqrt(o.size[0] * o.size[0] + o.size[1] * o.size[1] + o.size[2] * o.size[2]) +
                           b.radius + uniform(0.01, 0.1);
      const double flat = std::sqrt(1 - up * up);
      b.position = {o.position[0] + reach * flat * std::cos(phi), o.position[1] + reach * flat * std::sin(phi),
                    std::max(b.radius + 0.01, o.position[2] + reach * up)};
      s.projectiles.push_back(b);
    }
    std::unique_ptr<Engine> sim;
    try {
      sim = std::make_unique<Engine>(s);
    } catch (const Error&) {
      continue;  // balls overlapping the boxes or each other: another scene
    }
    ++built;
    const auto framing = render::objects_box(sim->model(), sim->state());
    render::Camera cam;
    ASSERT_NO_THROW(cam = render::make_camera(s.camera, sim->model(), framing, 16.0f / 9, s.source)) << attempt;
    ASSERT_TRUE(std::isfinite(cam.eye.x) && std::isfinite(cam.eye.y) && std::isfinite(cam.eye.z)) << attempt;
    // The objects' box lies ahead of the camera, its centre within the field of view.
    const glm::vec3 centre = 0.5f * (framing.box_lo + framing.box_hi);
    const glm::vec3 f = glm::normalize(cam.target - cam.eye), to = glm::normalize(centre - cam.eye);
    EXPECT_GT(glm::dot(f, to), std::cos(0.5f * cam.fov * 3.14159265f / 180)) << attempt;
  }
  EXPECT_EQ(built, 200);
}

// Objects far apart framed together: the automatic camera says which one it shows as a speck (two cubes 100 m
// apart were two dots, without a word); a scene's own camera, and the wall's view, have no note.
TEST(Render, TheAutomaticCameraNamesAnObjectItShowsAsASpeck) {
  SceneDef s = test::cubic_wall_scene();
  s.objects.resize(2, s.objects[0]);
  s.objects[0].size = {0.2, 0.2, 0.2};
  s.objects[0].position = {-50, 0, 0.1};
  s.objects[1].name = "right cube";
  s.objects[1].size = {0.4, 0.4, 0.4};
  s.objects[1].position = {50, 0, 0.2};
  s.projectiles[0].radius = 0.05;
  s.projectiles[0].position = {-50, -0.3, 0.1};
  const auto note = [](const SceneDef& c) {
    Engine sim(c);
    const auto framing = render::objects_box(sim.model(), sim.state());
    return render::make_camera(c.camera, sim.model(), framing, 16.0f / 9, c.source).note;
  };
  const std::string n = note(s);
  EXPECT_NE(n.find("sees object 'right cube' as a speck (0.3 degrees of the view's 40: the objects' box is 100 m "
                   "across); give the scene a [camera] target (and position) to look at it"),
            std::string::npos)
      << n;
  EXPECT_EQ(note(test::cubic_wall_scene()), "");
  SceneDef own = s;
  own.camera.target = Vec3d{50, 0, 0.2};
  EXPECT_EQ(note(own), "");
  // Said by the run, once, unless quiet.
  TempDir d;
  const fs::path scene = d.path() / "far.toml";
  std::ofstream(scene) << io::scene_to_toml(s);
  const Result r = run_mca("run " + scene.string() + " --steps 1 --no-vtk --render --render-size 64x36 --out " +
                           (d.path() / "out").string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("note: the automatic camera at "), std::string::npos) << r.output;
  const Result q = run_mca("run " + scene.string() + " -q --steps 1 --no-vtk --render --render-size 64x36 --out " +
                           (d.path() / "quiet").string());
  ASSERT_EQ(q.code, 0) << q.output;
  EXPECT_EQ(q.output.find("note:"), std::string::npos) << q.output;
}

// The overlay's time shows the time between frames: a run of frames 10 ns apart read "t = 0.00 ms" in each.
TEST(Render, TheTimeShownResolvesTheFrames) {
  EXPECT_EQ(text::sim_time(0.005, 0.005), "5.00 ms");
  EXPECT_EQ(text::sim_time(0.0, 0.005), "0.00 ms");
  EXPECT_EQ(text::sim_time(6e-8, 1e-8), "0.000060 ms");
  EXPECT_EQ(text::sim_time(7.5e-6, 2.5e-6), "0.0075 ms");
  EXPECT_EQ(text::sim_time(0.0015, 0.0005), "1.50 ms");
  // Without a resolution (a picture of its own): three digits of the time.
  EXPECT_EQ(text::sim_time(0.0123), "12.30 ms");
  EXPECT_EQ(text::sim_time(6e-8), "0.0000600 ms");
  // Frames 10 s apart, in seconds (they read "20000.00 ms").
  EXPECT_EQ(text::sim_time(20, 10), "20.00 s");
  EXPECT_EQ(text::sim_time(12.5), "12.50 s");
}

// Materials past the palette's ten take colours of their own (the eleventh was the first's), each apart from
// every other by a visible step.
TEST(Render, EveryMaterialHasAColourOfItsOwn) {
  for (std::size_t a = 0; a < 24; ++a)
    for (std::size_t b = 0; b < a; ++b) {
      const render::Rgba x = render::group_colour(a), y = render::group_colour(b);
      EXPECT_GT(std::abs(x[0] - y[0]) + std::abs(x[1] - y[1]) + std::abs(x[2] - y[2]), 25) << a << " and " << b;
    }
}

// Fragment ids are renumbered by mass every frame; a piece's colour must not follow them (the video
// flickered): from one frame to the next, an automaton whose piece keeps its smallest automaton keeps its
// colour, while the ids of many such automata change.
TEST(Render, FragmentColoursStayWithThePieceAcrossFrames) {
  Engine sim(test::cubic_wall_scene());
  sim.advance(4500);  // 9 ms: pieces fly off, the wall's main body still holds most of it
  render::SnapshotOptions o;
  o.all_automata = true;
  const auto frame = [&] {
    const auto frags = analysis::label_model_fragments(sim.model(), sim.state().intact.data());
    const auto snap = render::make_snapshot(sim.model(), sim.state(), frags, o, {0, 0, 0});
    // Per automaton: its fragment's smallest automaton and size.
    std::vector<std::uint32_t> first(static_cast<std::size_t>(frags.count), UINT32_MAX);
    std::vector<std::size_t> size(first.size());
    for (std::size_t a = 0; a < frags.id.size(); ++a) {
      first[frags.id[a]] = std::min<std::uint32_t>(first[frags.id[a]], static_cast<std::uint32_t>(a));
      ++size[frags.id[a]];
    }
    return std::make_tuple(frags, snap, first, size);
  };
  const auto [fa, sa, first_a, size_a] = frame();
  sim.advance(sim.steps_per_frame());
  const auto [fb, sb, first_b, size_b] = frame();
  ASSERT_EQ(sa.automata.size(), sim.model().size());
  std::size_t kept = 0, renumbered = 0, grey = 0;
  const render::Rgba body = render::main_body_colour();
  for (std::size_t a = 0; a < sim.model().size(); ++a) {
    const auto ia = fa.id[a], ib = fb.id[a];
    if (2 * size_a[ia] > sim.model().size()) {
      grey += sa.automata[a].colour == body;
      continue;
    }
    if (first_a[ia] != first_b[ib] || 2 * size_b[ib] > sim.model().size()) continue;
    ++kept;
    renumbered += ia != ib;
    EXPECT_EQ(sa.automata[a].colour, sb.automata[a].colour) << "automaton " << a << ": fragment " << ia << " -> " << ib;
    EXPECT_NE(sa.automata[a].colour, body) << a;
  }
  EXPECT_GT(kept, 100u);
  EXPECT_GT(renumbered, 10u) << "the fragments were not renumbered: this frame pair tests nothing";
  EXPECT_GT(grey, 1000u) << "largest fragments " << size_a[0] << " " << size_a[1] << " of " << sim.model().size();  // the wall's main body
}

TEST(Render, ExposedAutomataAreThoseWithABrokenOrMissingLink) {
  Engine sim(test::cubic_wall_scene());
  const auto exposed = render::exposed_automata(sim.model(), sim.state());
  // 40 x 4 x 30 automata: the 38 x 2 x 28 inside have all six links.
  std::size_t n = 0;
  for (auto e : exposed) n += e;
  EXPECT_EQ(n, 4800u - 38u * 2u * 28u);
}

// Drawn as links, a piece of one automaton (no intact link) is its cube, so debris does not vanish.
TEST(Render, LinksModeDrawsPiecesOfOneAutomatonAsCubes) {
  Engine sim(test::cubic_wall_scene());
  State st = sim.state();
  sim.model().for_each_link_of(1234, [&](std::size_t l) { st.intact[l] = 0; });
  const auto frags = analysis::label_model_fragments(sim.model(), st.intact.data());
  render::SnapshotOptions so;
  so.draw = render::DrawMode::links;
  const auto snap = render::make_snapshot(sim.model(), st, frags, so, {0, 0, 0});
  ASSERT_EQ(snap.automata.size(), 1u);
  EXPECT_FLOAT_EQ(snap.automata[0].x, static_cast<float>(st.x[1234].x));
  EXPECT_GT(snap.links.size(), 0u);
}

TEST(View, ScriptedShotUnderAVirtualDisplayShowsTheBrokenWall) {
  if (shell("command -v xvfb-run").code != 0) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh)";
  TempDir d;
  const fs::path script = d.path() / "shots.txt", png = d.path() / "view.png";
  std::ofstream(script) << "# time x y\n0.002 0.6 0.45\n";
  const Result r = shell("timeout 120 xvfb-run -a -s '-screen 0 1280x720x24' " + std::string(MCA_BINARY) +
                         " view " + kCubicWall + " --size 480x270 --frames 12 --script " + script.string() + " --screenshot " + png.string());
  ASSERT_EQ(r.code, 0) << r.output;
  // 12 frames of 2 ms; the scene's ball and the scripted one.
  EXPECT_NE(r.output.find("t = 22.00 ms, 1 shot fired, 2 projectiles"), std::string::npos) << r.output;
  const render::Image im = render::read_png(png);
  ASSERT_EQ(im.width, 480);
  ASSERT_EQ(im.height, 270);
  EXPECT_TRUE(is_background(at(im, im.width - 1, 0)));
  // Broken: many pixels in the hues of fragments other than the largest.
  std::size_t coloured = 0;
  for (int y = 0; y < im.height; ++y)
    for (int x = 0; x < im.width; ++x) {
      const Pixel q = at(im, x, y);
      coloured += std::max({q.r, q.g, q.b}) - std::min({q.r, q.g, q.b}) > 60;
    }
  EXPECT_GT(coloured, static_cast<std::size_t>(im.width * im.height / 20));
}

// Runs `mca view` under a virtual display with `args`.
Result view_under_xvfb(const std::string& args) {
  return shell("timeout 120 xvfb-run -a -s '-screen 0 1280x720x24' " + std::string(MCA_BINARY) + " view " + kCubicWall + " " + args);
}

// Every scripted shot fires (each later one is checked against where the earlier balls are now, not where
// they started), and --frames N ends at N simulated frames even after a refused shot.
TEST(View, EveryScriptedShotFiresAndFramesAreSimulatedFrames) {
  if (shell("command -v xvfb-run").code != 0) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh)";
  TempDir d;
  const fs::path script = d.path() / "shots.txt", png = d.path() / "view.png";
  // The second shot at 20 ms, while the scene's ball is inside the wall's starting volume.
  std::ofstream(script) << "0.0 0.5 0.5\n0.02 0.3 0.5\n";
  const Result r = view_under_xvfb("--size 320x180 --frames 16 --script " + script.string() + " --screenshot " + png.string());
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("t = 30.00 ms, 2 shots fired, 3 projectiles"), std::string::npos) << r.output;
  EXPECT_EQ(render::read_png(png).width, 320);
  // Two balls fired at once from the same eye overlap: the second is refused with the reason, and the
  // 16 frames still end at 30 ms.
  std::ofstream(script) << "0.0 0.5 0.5\n0.0 0.5 0.5\n";
  const Result o = view_under_xvfb("--size 320x180 --frames 16 --script " + script.string());
  ASSERT_EQ(o.code, 0) << o.output;
  EXPECT_NE(o.output.find("'shot2' overlaps projectile[1] 'shot1'"), std::string::npos) << o.output;
  EXPECT_NE(o.output.find("t = 30.00 ms, 1 shot fired, 2 projectiles"), std::string::npos) << o.output;
}

// The CUDA backend's view: the simulation thread has the backend write its draw lists into GL buffers of
// its own context (shared with the window's: zero copy) and the window draws from them. Its emulation's
// picture is the CPU backend's, pixel for pixel, but for the overlay's rates; a shot rebuilds the engine
// (and its backend) while the buffers stay.
TEST(View, TheCudaBackendsDrawListsInSharedBuffersShowTheCpusPicture) {
  if (shell("command -v xvfb-run").code != 0) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh)";
  TempDir d;
  const fs::path script = d.path() / "shots.txt";
  std::ofstream(script) << "0.004 0.45 0.5\n";
  std::vector<render::Image> shots;
  for (const std::string backend : {"cpu", "cuda-emulation"}) {
    const fs::path png = d.path() / (backend + ".png");
    const Result r = view_under_xvfb("--size 480x270 --frames 14 --backend " + backend + " --script " + script.string() +
                                     " --screenshot " + png.string());
    ASSERT_EQ(r.code, 0) << r.output;
    EXPECT_NE(r.output.find("t = 26.00 ms, 1 shot fired, 2 projectiles"), std::string::npos) << r.output;
    shots.push_back(render::read_png(png));
  }
  const render::Image &a = shots[0], &b = shots[1];
  ASSERT_EQ(a.rgba.size(), b.rgba.size());
  // The overlay's top lines (rates, drawn counts) aside.
  const int top = 8 + 5 * 11;
  std::size_t differ = 0, coloured = 0;
  for (int y = top; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) {
      const Pixel p = at(a, x, y), q = at(b, x, y);
      differ += p.r != q.r || p.g != q.g || p.b != q.b;
      coloured += std::max({q.r, q.g, q.b}) - std::min({q.r, q.g, q.b}) > 60;
    }
  EXPECT_EQ(differ, 0u) << "pixels below the overlay differ between the cpu and cuda-emulation views";
  EXPECT_GT(coloured, static_cast<std::size_t>(a.width * a.height / 50)) << "nothing broken drawn";
}

// A line that is not TIME X Y is refused with its file and line (before any window); a shot after the
// last frame is reported.
TEST(View, ScriptLinesAreCheckedAndLateShotsReported) {
  TempDir d;
  const fs::path script = d.path() / "shots.txt";
  for (const std::string bad : {"foo bar baz", "nan 0.5 0.5", "0.1 0.5", "0.1 0.5 0.5 7", "-1 0.5 0.5"}) {
    std::ofstream(script) << "# aim\n0.0 0.5 0.5\n" << bad << "\n";
    const Result r = shell("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(MCA_BINARY) + " view --frames 1 --script " +
                           script.string());
    EXPECT_EQ(r.code, 2) << bad << ": " << r.output;
    EXPECT_NE(r.output.find(script.string() + ":3: '" + bad + "' is not 'TIME X Y'"), std::string::npos) << r.output;
  }
  if (shell("command -v xvfb-run").code != 0) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh)";
  // Two frames of 2 ms with the shots of `lines`; the view ends normally.
  const auto view_with = [&](const std::string& lines) {
    std::ofstream(script) << lines;
    const Result r = view_under_xvfb("--size 64x64 --frames 2 --script " + script.string());
    EXPECT_EQ(r.code, 0) << r.output;
    return r.output;
  };
  const std::string late = view_with("0.5 0.5 0.5\n");
  EXPECT_NE(late.find("1 shot was not fired: the view ended at t = 2.00 ms, before t = 500.00 ms"), std::string::npos)
      << late;
  // Two shots due at the last frame along one ray: the second overlaps the first and is refused, so one
  // went into the simulation after that frame, not two (a hostile review: a refused one was counted).
  const std::string last = view_with("0.002 0.5 0.5\n0.002 0.5 0.5\n");
  EXPECT_NE(last.find("warning: shot not fired"), std::string::npos) << last;
  EXPECT_NE(last.find("mca view: 1 shot due at the last frame shown (t = 2.00 ms) went into the simulation after it"),
            std::string::npos) << last;
  // One alone at the last frame, refused (the ball fired at the first frame is 8 cm along its ray): none
  // went in.
  const std::string refused = view_with("0 0.5 0.5\n0.002 0.5 0.5\n");
  EXPECT_NE(refused.find("warning: shot not fired"), std::string::npos) << refused;
  EXPECT_EQ(refused.find("due at the last frame"), std::string::npos) << refused;
}

// Ctrl-C in the terminal closes the viewer as Q does, with its closing line, and the exit code of the
// signal (it ended the process without a word: the hostile review of 2026-12-05).
TEST(View, CtrlCClosesTheViewWithItsSummary) {
  if (shell("command -v xvfb-run").code != 0) GTEST_SKIP() << "xvfb-run is not installed (scripts/setup.sh)";
  const Result r = shell("timeout 120 xvfb-run -a -s '-screen 0 1280x720x24' sh -c '" + std::string(MCA_BINARY) +
                         " view " + kCubicWall + " --size 160x90 --frames 1000000 --screenshot never.png & p=$!; sleep 6; "
                         "kill -INT $p; "
                         "wait $p; echo \"exit $?\"'");
  EXPECT_NE(r.output.find("mca view: closed by SIGINT (Ctrl-C): "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" frames shown, t = "), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("exit 130"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("; no screenshot: never.png is of frame 1000000, and the view closed before"),
            std::string::npos)
      << r.output;
}

TEST(View, BadSizeAndScreenshotNamesAreRefusedWithTheViewersOptions) {
  const Result size = run_mca("view --size 7x5 --frames 1");
  EXPECT_EQ(size.code, 2) << size.output;
  EXPECT_NE(size.output.find("--size 7x5 is out of range"), std::string::npos) << size.output;
  EXPECT_EQ(size.output.find("--render-size"), std::string::npos) << size.output;
  const Result jpg = run_mca("view --frames 1 --screenshot v.jpg");
  EXPECT_EQ(jpg.code, 2) << jpg.output;
  EXPECT_NE(jpg.output.find("ending in .png"), std::string::npos) << jpg.output;
}

TEST(View, NoDisplayPointsToRunRender) {
  const Result r = shell("env -u DISPLAY -u WAYLAND_DISPLAY " + std::string(MCA_BINARY) + " view --frames 1");
  EXPECT_EQ(r.code, 2) << r.output;
  EXPECT_NE(r.output.find("mca run --render"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace mca
