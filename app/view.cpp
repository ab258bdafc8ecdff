// `mca view`: the live viewer. A GLFW window draws with the same renderer as `mca run --render`; the
// simulation runs in its own thread and hands the window a finished Snapshot (positions, orientations,
// colours) through a mutex-guarded slot, so drawing never waits for a step and never reads the state.
// libepoxy before GLFW, which then leaves out its own GL header.
#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cerrno>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include <unistd.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <tbb/global_control.h>

#include "analysis/fragments.hpp"
#include "app/commands.hpp"
#include "core/files.hpp"
#include "core/text.hpp"
#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "render/camera.hpp"
#include "render/image.hpp"
#include "render/renderer.hpp"
#include "render/snapshot.hpp"
#include "sim/engine.hpp"

namespace mca::app {
namespace {

struct Shot {
  double time = 0;      // scripted: simulated time to fire at [s]
  float x = 0.5f, y = 0.5f;  // the cursor as a share of the window (0, 0 top left)
};

// A script of timed shots: one per line, "TIME X Y" (simulated seconds; the aim as shares of the window's
// width and height from its top left); '#' starts a comment.
std::vector<Shot> read_script(const std::string& path) {
  std::error_code ec;
  if (const std::string kind = files::non_regular_kind(path); !kind.empty())
    throw Error(fmt::format("--script {}: is {}, not a file of shots (mca reads only regular files); give a file of "
                            "shots, one 'TIME X Y' per line",
                            path, kind));
  if (!std::filesystem::exists(path, ec))
    throw Error(fmt::format("--script {}: no such file; give a file of shots, one 'TIME X Y' per line", path));
  std::ifstream in(path);
  if (!in) throw Error(fmt::format("--script {}: cannot open it: {}", path, std::strerror(errno)));
  std::vector<Shot> shots;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    line = line.substr(0, line.find('#'));
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;  // a blank line or a comment
    std::istringstream ss(line);
    Shot s;
    std::string rest;
    if (!(ss >> s.time >> s.x >> s.y) || (ss >> rest) || !std::isfinite(s.time) || !(s.time >= 0) ||
        !(s.x >= 0 && s.x <= 1 && s.y >= 0 && s.y <= 1))
      throw Error(fmt::format("--script {}:{}: '{}' is not 'TIME X Y' (simulated seconds >= 0, then the aim as shares "
                              "0..1 of the window's width and height from the top left), e.g. 0.002 0.5 0.5; '#' "
                              "starts a comment",
                              path, n, line));
    shots.push_back(s);
  }
  if (in.bad()) throw Error(fmt::format("--script {}: cannot read it: {}", path, std::strerror(errno)));
  std::sort(shots.begin(), shots.end(), [](const Shot& a, const Shot& b) { return a.time < b.time; });
  return shots;
}

struct Ball {
  float speed = 40;   // m/s
  float radius = 0.1f;  // m
  float mass = 32;    // kg (steel, r = 0.1 m)
  // Within what a scene's projectile may be (the keys had no bounds: a ball made 60 times faster, or so heavy
  // for its size that its density left the range a scene takes, was refused with a scene file's advice):
  // 1 m/s to 3 km/s, 1 mm to 100 m, a density of 0.1 to 1e5 kg/m^3 (the mass follows a changed radius).
  void keep_in_range() {
    speed = std::clamp(speed, 1.0f, 3000.0f);
    radius = std::clamp(radius, 1e-3f, 100.0f);
    const float volume = 4.18879f * radius * radius * radius;
    // (inside the bounds by a thousandth: the density a scene is given back from the mass is rounded)
    mass = std::clamp(mass, float(MaterialDef::kMinDensity * 1.001) * volume,
                      float(MaterialDef::kMaxDensity * 0.999) * volume);
  }
};

struct Command {
  enum Kind { restart, step, shoot, redraw } kind;  // redraw: a new snapshot of the same state (colour, draw)
  glm::dvec3 origin{0}, direction{0};
  Ball ball;
};

// What the simulation thread shares with the window.
struct Shared {
  std::mutex mutex;
  std::condition_variable changed;
  std::shared_ptr<const render::Snapshot> snapshot;  // the newest, replaced whole (never written in place)
  std::uint64_t sequence = 0;                        // snapshots published so far
  std::deque<Command> commands;
  // Commands queued and handled so far (a shot fired or refused), and the shots refused: the window tells
  // from them what became of the shots it queued.
  std::uint64_t queued = 0, handled = 0, refused = 0;
  std::string message;                               // the last shot's error, shown in the overlay
  bool finished = false;                             // the simulation thread has stopped (quit or an error)
  std::atomic<bool> quit{false}, paused{false};
  std::atomic<int> shots{0};                         // balls fired so far (since the last restart)
  std::atomic<int> colour{0}, draw{0};
  std::atomic<double> steps_per_second{0};
  // Zero copy: the simulation thread has the backend write its draw lists into three sets of GL buffers
  // (render::SharedBuffers, made in a context that shares the window's objects), and the window draws from
  // them. One is the window's (the snapshot it holds), one the published snapshot's not yet taken, and the
  // third is free to write. -1: none (a snapshot with its lists in itself). The buffers belong to the
  // window's thread (they outlive the simulation thread, which may stop on an error while the window still
  // shows its last snapshot); `drawn` holds, per set, a fence after the window's last draw from it, which
  // the simulation thread waits for before it writes the set again.
  std::array<render::SharedBuffers*, 3> buffers{};
  int held = -1, pending = -1;
  std::array<GLsync, 3> drawn{};
};

// Fires a ball: the engine is rebuilt from the scene with one more projectile, continuing from the current
// state with the ball added (Engine's constructor from a state checks it against the new model). The
// projectiles already there are put at their current positions and velocities first, so the new ball is
// checked against where they are, not where they started (Engine's `projectiles_in_flight`). The new
// ball's kinetic energy joins the run's energy budget, as if it had been there from the start.
std::unique_ptr<Engine> with_shot(const Engine& sim, const Command& c, int shot) {
  SceneDef scene = sim.scene();
  State s = sim.state();
  const std::size_t in_flight = scene.projectiles.size();
  for (std::size_t p = 0; p < in_flight && p < s.projectiles.size(); ++p) {
    const ProjectileState& now = s.projectiles[p];
    scene.projectiles[p].position = {now.position.x, now.position.y, now.position.z};
    scene.projectiles[p].velocity = {now.velocity.x, now.velocity.y, now.velocity.z};
    scene.projectiles[p].angular_velocity = {now.angular_velocity.x, now.angular_velocity.y, now.angular_velocity.z};
  }
  ProjectileDef p;
  p.name = fmt::format("shot{}", shot);
  p.radius = c.ball.radius;
  p.material = "steel";
  p.density = c.ball.mass / (4.0 / 3.0 * 3.14159265358979 * std::pow(c.ball.radius, 3));
  const glm::dvec3 v = c.direction * static_cast<double>(c.ball.speed);
  p.position = {c.origin.x, c.origin.y, c.origin.z};
  p.velocity = {v.x, v.y, v.z};
  scene.projectiles.push_back(p);
  ProjectileState ps;
  ps.position = {c.origin.x, c.origin.y, c.origin.z};
  ps.velocity = {v.x, v.y, v.z};
  s.projectiles.push_back(ps);
  s.initial_energy += 0.5 * c.ball.mass * c.ball.speed * c.ball.speed;
  return std::make_unique<Engine>(scene, s, "the viewer's shot", std::nullopt, in_flight);
}

// `context`: a GL context sharing the window's objects, for the draw lists' buffers (sh.buffers; null:
// none).
void simulate(const SceneDef& scene, Shared& sh, bool lockstep, std::array<double, 3> origin, GLFWwindow* context) {
  struct Context {  // current on this thread while it runs
    GLFWwindow* c;
    explicit Context(GLFWwindow* c) : c(c) {
      if (c) glfwMakeContextCurrent(c);
    }
    ~Context() {
      if (c) glfwMakeContextCurrent(nullptr);
    }
  } current(context);
  auto sim = std::make_unique<Engine>(scene);
  std::int64_t chunk = 16;
  auto publish = [&] {
    const Model& m = sim->model();
    render::SnapshotOptions o;
    o.colour = static_cast<render::ColourMode>(sh.colour.load());
    o.draw = static_cast<render::DrawMode>(sh.draw.load());
    if (o.draw == render::DrawMode::surface && m.surface.faces() == 0) o.draw = render::DrawMode::cubes;
    // The backend's draw list where it builds one (the CUDA backend: no download of the state), written
    // into the free set of buffers where it can; else from its state.
    int free = -1;
    GLsync last_draw = nullptr;
    if (context) {
      std::lock_guard lock(sh.mutex);
      for (free = 0; free == sh.held || free == sh.pending; ++free) {
      }
      std::swap(last_draw, sh.drawn[static_cast<std::size_t>(free)]);
    }
    if (last_draw) {  // the window's last draw from this set is done before it is written again
      while (!sh.quit && glClientWaitSync(last_draw, 0, 100'000'000) == GL_TIMEOUT_EXPIRED) {
      }
      glDeleteSync(last_draw);
    }
    auto snap = std::make_shared<render::Snapshot>(
        render::make_snapshot(m, sim->backend(), o, origin, context ? sh.buffers[static_cast<std::size_t>(free)] : nullptr));
    const bool shared = snap->drawn_from_shared_buffers();
    if (shared) glFinish();  // written before the window's context draws from them
    std::unique_lock lock(sh.mutex);
    sh.pending = shared ? free : -1;
    sh.snapshot = std::move(snap);
    ++sh.sequence;
    sh.changed.notify_all();
    // In lockstep (scripted runs) the window shows every snapshot, and queues the shots due at its time
    // as it takes it: the simulation goes on only then, so a shot fires at the same step on every run.
    if (lockstep) sh.changed.wait(lock, [&] { return sh.quit || !sh.snapshot; });
  };
  publish();
  while (!sh.quit) {
    std::deque<Command> todo;
    {
      std::lock_guard lock(sh.mutex);
      todo.swap(sh.commands);
    }
    int steps = 0;
    for (const Command& c : todo) {
      try {
        if (c.kind == Command::restart) {
          sim = std::make_unique<Engine>(scene);
          sh.shots = 0;
        }
        if (c.kind == Command::shoot) {
          sim = with_shot(*sim, c, sh.shots + 1);
          ++sh.shots;
        }
        if (c.kind == Command::step) steps += sim->steps_per_frame();
      } catch (const Error& e) {
        std::lock_guard lock(sh.mutex);
        const bool shot = c.kind == Command::shoot;
        // (The scene's check of the ball named the scene file and its keys; the viewer's are the fix.)
        sh.message = shot ? fmt::format("shot not fired (a ball of {:.3g} m/s, r {:.3g} m, {:.3g} kg; Up/Down, Left/Right "
                                        "and PageUp/PageDown change it): {}",
                                        c.ball.speed, c.ball.radius, c.ball.mass, e.what())
                          : std::string(e.what());
        if (lockstep) fmt::print(stderr, "warning: {}\n", sh.message);
        if (shot) ++sh.refused;
      }
      std::lock_guard lock(sh.mutex);
      ++sh.handled;
      sh.changed.notify_all();
    }
    if (lockstep) steps = sim->steps_per_frame();
    else if (!sh.paused) steps = static_cast<int>(chunk);
    if (steps == 0) {
      if (!todo.empty()) publish();
      std::unique_lock lock(sh.mutex);
      sh.changed.wait_for(lock, std::chrono::milliseconds(20), [&] { return sh.quit || !sh.commands.empty(); });
      continue;
    }
    const auto t0 = std::chrono::steady_clock::now();
    const StepHealth h = sim->advance(steps);
    const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    sh.steps_per_second = took > 0 ? steps / took : 0;
    // About 30 snapshots per second of wall time.
    if (took < 0.025 && chunk < 1 << 20) chunk *= 2;
    else if (took > 0.05 && chunk > 1) chunk /= 2;
    if (h.flags != kHealthy) {
      std::lock_guard lock(sh.mutex);
      sh.message = "the run became unstable: paused (R restarts)";
      sh.paused = true;
    }
    publish();
  }
}

struct Input {
  double last_x = 0, last_y = 0, press_x = 0, press_y = 0;
  bool left = false, right = false, dragged = false;
  float yaw = 0, pitch = 0, distance = 1;
  glm::vec3 target{0};
  std::vector<std::pair<int, int>> keys;  // key, mods
  std::vector<std::pair<double, double>> clicks;
  double scroll = 0;
};

}  // namespace

int view(const ViewOptions& o) {
  Engine::check_environment();  // a bad MCA_SIMD or MCA_BACKEND, before a window opens
  SceneDef scene = o.scene ? io::load_scene_file(*o.scene) : io::load_default_scene();
  if (o.backend) scene.solver.backend = backend_from_name(*o.backend, "--backend");
  const std::vector<Shot> script = o.script ? read_script(*o.script) : std::vector<Shot>{};
  if (o.frames && *o.frames < 1) throw Error(fmt::format("--frames {} must be at least 1", *o.frames));
  // Where the screenshot goes, before the frames are shown (it was found at the end, after them all).
  if (o.screenshot) {
    namespace fs = std::filesystem;
    const fs::path shot(*o.screenshot), folder = shot.parent_path().empty() ? fs::path(".") : shot.parent_path();
    std::error_code ec;
    if (fs::is_directory(shot, ec))
      throw Error(fmt::format("--screenshot {}: it is a folder; give a file name ending in .png", *o.screenshot));
    if (!fs::is_directory(folder, ec))
      throw Error(fmt::format("--screenshot {}: its folder {} does not exist; make it, or give a file in another",
                              *o.screenshot, folder.string()));
    if (::access(folder.c_str(), W_OK | X_OK) != 0)
      throw Error(fmt::format("--screenshot {}: its folder {} cannot be written ({}); give a file in another",
                              *o.screenshot, folder.string(), std::strerror(errno)));
  }
  const int threads = thread_count(o.threads);
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  if (!glfwInit())
    throw Error("mca view needs a display (an X11 or Wayland session; DISPLAY is not set or cannot be opened); "
                "without one, render the run offscreen with `mca run --render` (pictures and a video), or use a "
                "virtual display: xvfb-run -a mca view");
  struct Terminate {
    ~Terminate() { glfwTerminate(); }
  } terminate;
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  GLFWwindow* win = glfwCreateWindow(o.width, o.height, fmt::format("mca view: {}", scene.name).c_str(), nullptr, nullptr);
  if (!win)
    throw Error("mca view: the display gives no OpenGL 4.5 core window (install libgl1-mesa-dri, scripts/setup.sh); "
                "`mca run --render` renders offscreen without a window");
  // A hidden context sharing the window's objects, for the simulation thread's draw lists (zero copy);
  // without one the lists come in the snapshots.
  glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
  GLFWwindow* sim_context = glfwCreateWindow(16, 16, "mca view: simulation", nullptr, win);
  glfwWindowHint(GLFW_VISIBLE, GLFW_TRUE);
  glfwMakeContextCurrent(win);
  glfwSwapInterval(o.frames ? 0 : 1);
  render::Renderer renderer;
  // The simulation thread's draw lists (zero copy; Shared::buffers), deleted here after it has stopped.
  std::array<render::SharedBuffers, 3> shared_buffers;

  // The camera of the scene (or framed automatically) at the start, then moved by the mouse, and what the
  // window needs of the model: from an engine on the CPU, let go at once (the simulation thread builds the
  // scene's own; a second one on the GPU would hold the model's device memory for the whole session).
  bool has_surface = false;
  render::Framing framing;
  render::Camera start;
  double dt = 0, resolution = 0;  // the step; the time between frames, which the shown times' decimals show
  std::size_t scene_projectiles = 0;
  {
    SceneDef probe = scene;
    probe.solver.backend = SolverDef::Backend::cpu;
    const Engine first(probe);
    has_surface = first.model().surface.faces() > 0;
    framing = render::objects_box(first.model(), first.state());
    start = render::make_camera(scene.camera, first.model(), framing, static_cast<float>(o.width) / static_cast<float>(o.height),
                                scene.source);
    if (!start.note.empty()) fmt::print(stderr, "note: {}\n", start.note);
    dt = static_cast<double>(first.model().dt);
    resolution = first.frame_interval();
    scene_projectiles = first.model().projectiles.size();
  }
  Input in;
  {
    const glm::vec3 d = start.eye - start.target;
    const glm::vec3 up = start.up;
    in.distance = glm::length(d);
    in.target = start.target;
    in.pitch = std::asin(std::clamp(glm::dot(d, up) / in.distance, -1.0f, 1.0f));
    // Yaw measured in the plane perpendicular to up, from an axis of that plane.
    const glm::vec3 a = glm::normalize(std::abs(up.x) < 0.9f ? glm::cross(up, glm::vec3(1, 0, 0)) : glm::cross(up, glm::vec3(0, 1, 0)));
    const glm::vec3 b = glm::cross(up, a);
    in.yaw = std::atan2(glm::dot(d, b), glm::dot(d, a));
  }
  const glm::vec3 up = start.up;
  const glm::vec3 axis_a = glm::normalize(std::abs(up.x) < 0.9f ? glm::cross(up, glm::vec3(1, 0, 0)) : glm::cross(up, glm::vec3(0, 1, 0)));
  const glm::vec3 axis_b = glm::cross(up, axis_a);
  auto camera = [&] {
    render::Camera c = start;
    const glm::vec3 dir = std::cos(in.pitch) * (std::cos(in.yaw) * axis_a + std::sin(in.yaw) * axis_b) + std::sin(in.pitch) * up;
    c.target = in.target;
    c.eye = in.target + in.distance * dir;
    c.near = std::max(1e-3f, 0.02f * in.distance);
    c.far = 100.0f * in.distance + 100.0f;
    return c;
  };

  glfwSetWindowUserPointer(win, &in);
  glfwSetKeyCallback(win, [](GLFWwindow* w, int key, int, int action, int mods) {
    if (action == GLFW_PRESS || action == GLFW_REPEAT) static_cast<Input*>(glfwGetWindowUserPointer(w))->keys.push_back({key, mods});
  });
  glfwSetScrollCallback(win, [](GLFWwindow* w, double, double dy) { static_cast<Input*>(glfwGetWindowUserPointer(w))->scroll += dy; });
  glfwSetMouseButtonCallback(win, [](GLFWwindow* w, int button, int action, int) {
    auto& I = *static_cast<Input*>(glfwGetWindowUserPointer(w));
    double x, y;
    glfwGetCursorPos(w, &x, &y);
    if (button == GLFW_MOUSE_BUTTON_LEFT) {
      if (action == GLFW_PRESS) {
        I.left = true;
        I.dragged = false;
        I.press_x = x;
        I.press_y = y;
      } else {
        I.left = false;
        if (!I.dragged) I.clicks.push_back({x, y});  // a click, not a drag: shoot
      }
    }
    if (button == GLFW_MOUSE_BUTTON_RIGHT || button == GLFW_MOUSE_BUTTON_MIDDLE) I.right = action == GLFW_PRESS;
    I.last_x = x;
    I.last_y = y;
  });
  glfwSetCursorPosCallback(win, [](GLFWwindow* w, double x, double y) {
    auto& I = *static_cast<Input*>(glfwGetWindowUserPointer(w));
    const double dx = x - I.last_x, dy = y - I.last_y;
    if (I.left && std::hypot(x - I.press_x, y - I.press_y) > 4) I.dragged = true;
    if (I.left && I.dragged) {
      I.yaw -= static_cast<float>(dx) * 0.006f;
      I.pitch = std::clamp(I.pitch + static_cast<float>(dy) * 0.006f, -1.5f, 1.5f);
    }
    I.last_x = x;
    I.last_y = y;
  });

  Shared sh;
  if (sim_context)
    for (std::size_t k = 0; k < 3; ++k) sh.buffers[k] = &shared_buffers[k];
  const bool lockstep = o.frames.has_value();
  std::thread worker([&] {
    std::string error;
    try {
      simulate(scene, sh, lockstep, framing.origin, sim_context);
    } catch (const std::exception& e) {
      error = e.what();
    }
    std::lock_guard lock(sh.mutex);
    if (!error.empty()) sh.message = error;
    sh.finished = true;
    sh.changed.notify_all();
  });
  struct Join {
    Shared& sh;
    std::thread& t;
    ~Join() {
      sh.quit = true;
      sh.changed.notify_all();
      if (t.joinable()) t.join();
      for (GLsync& f : sh.drawn)
        if (f) glDeleteSync(f);
    }
  } join{sh, worker};

  Ball ball;
  std::size_t next_shot = 0;
  // A shot is due with the first snapshot at or after its time. Snapshot times are whole steps of a float
  // time step (0.002 s comes out as 0.0019999999), so a time within half a step of a snapshot's is its.
  const double half_step = 0.5 * dt;
  std::size_t due_at_last = 0;  // scripted shots queued with the newest snapshot (in the state from the next)
  std::uint64_t refused_before_last = 0;  // Shared::refused when they were queued
  std::int64_t shown = 0;
  std::shared_ptr<const render::Snapshot> snap;
  auto fps_t0 = std::chrono::steady_clock::now();
  int fps_frames = 0;
  double fps = 0;
  double last_px = 0, last_py = 0;
  std::vector<std::uint8_t> pixels;
  auto shot_command = [&](double fx, double fy, int w, int h) {
    // The ray from the eye through the cursor.
    const render::Camera c = camera();
    const glm::mat4 inv = glm::inverse(c.projection(static_cast<float>(w) / h) * c.view());
    const glm::vec4 far = inv * glm::vec4(2 * fx - 1, 1 - 2 * fy, 1, 1);
    const glm::vec3 dir = glm::normalize(glm::vec3(far) / far.w - c.eye);
    return Command{Command::shoot, glm::dvec3(c.eye) + glm::dvec3(framing.origin[0], framing.origin[1], framing.origin[2]),
                   glm::dvec3(dir), ball};
  };
  auto push = [&](const Command& c) {
    std::lock_guard lock(sh.mutex);
    sh.commands.push_back(c);
    ++sh.queued;
    sh.changed.notify_all();
  };
  bool died = false;  // the simulation thread stopped on an error
  // Ctrl-C in the terminal (or SIGTERM, SIGHUP) closes the window as Q does, with the closing line (it
  // ended the process without one), and the exit code of a signal.
  const std::atomic<int>& stop = catch_stop_signals();
  while (!glfwWindowShouldClose(win) && stop == 0) {
    glfwPollEvents();
    int w = 0, h = 0;
    glfwGetFramebufferSize(win, &w, &h);
    // The newest snapshot (in lockstep: wait for the next one, so that N frames are N simulated frames).
    {
      std::unique_lock lock(sh.mutex);
      if (lockstep) sh.changed.wait(lock, [&] { return sh.snapshot != nullptr || sh.finished; });
      if (sh.snapshot) {
        snap = std::move(sh.snapshot);
        sh.snapshot.reset();
        sh.held = sh.pending;  // its buffers (if any) are the window's now; the one it held is free
        sh.pending = -1;
        // Scripted shots due by this snapshot's time, queued before the simulation goes on (see publish).
        due_at_last = 0;
        refused_before_last = sh.refused;
        while (next_shot < script.size() && script[next_shot].time <= snap->time + half_step) {
          sh.commands.push_back(shot_command(script[next_shot].x, script[next_shot].y, w, h));
          ++sh.queued;
          ++next_shot;
          ++due_at_last;
        }
        sh.changed.notify_all();
      } else if (lockstep && sh.finished) {
        died = true;
        break;
      }
    }
    if (!snap) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
      continue;
    }
    // Input.
    double px, py;
    glfwGetCursorPos(win, &px, &py);
    if (in.right) {
      // Pan: move the target in the view plane by the cursor's motion, scaled to the distance.
      const render::Camera c = camera();
      const glm::vec3 f = glm::normalize(c.target - c.eye), r = glm::normalize(glm::cross(f, up)), u = glm::cross(r, f);
      const float k = in.distance * 0.0015f;
      in.target += (-static_cast<float>(px - last_px) * r + static_cast<float>(py - last_py) * u) * k;
    }
    last_px = px;
    last_py = py;
    if (in.scroll != 0) {
      in.distance *= std::pow(0.9f, static_cast<float>(in.scroll));
      in.scroll = 0;
    }
    for (const auto& [key, mods] : in.keys) {
      const auto cycle = [&](std::atomic<int>& v, int n) { v = (v + ((mods & GLFW_MOD_SHIFT) ? n - 1 : 1)) % n; };
      switch (key) {
        case GLFW_KEY_SPACE: sh.paused = !sh.paused; break;
        case GLFW_KEY_N: {
          sh.paused = true;
          push({Command::step, {}, {}, ball});
          break;
        }
        case GLFW_KEY_R: {
          push({Command::restart, {}, {}, ball});
          std::lock_guard lock(sh.mutex);
          sh.message.clear();
          break;
        }
        case GLFW_KEY_C:
        case GLFW_KEY_D: {
          // A new snapshot of the current state in the new mode (paused, none would come otherwise).
          if (key == GLFW_KEY_C) cycle(sh.colour, 6);
          else {
            cycle(sh.draw, 4);
            // Without mesh objects there is no surface to draw: skip it.
            if (!has_surface && static_cast<render::DrawMode>(sh.draw.load()) == render::DrawMode::surface) cycle(sh.draw, 4);
          }
          push({Command::redraw, {}, {}, ball});
          break;
        }
        case GLFW_KEY_UP: ball.speed *= 1.25f; break;
        case GLFW_KEY_DOWN: ball.speed /= 1.25f; break;
        case GLFW_KEY_RIGHT: ball.radius *= 1.25f; break;
        case GLFW_KEY_LEFT: ball.radius /= 1.25f; break;
        case GLFW_KEY_PAGE_UP: ball.mass *= 1.5f; break;
        case GLFW_KEY_PAGE_DOWN: ball.mass /= 1.5f; break;
        case GLFW_KEY_ESCAPE:
        case GLFW_KEY_Q: glfwSetWindowShouldClose(win, GLFW_TRUE); break;
        default: break;
      }
      ball.keep_in_range();
      std::lock_guard lock(sh.mutex);
      sh.changed.notify_all();
    }
    in.keys.clear();
    for (const auto& [cx, cy] : in.clicks) push(shot_command(cx / std::max(w, 1), cy / std::max(h, 1), w, h));
    in.clicks.clear();

    // Draw.
    ++fps_frames;
    const double since = std::chrono::duration<double>(std::chrono::steady_clock::now() - fps_t0).count();
    if (since > 0.5) {
      fps = fps_frames / since;
      fps_frames = 0;
      fps_t0 = std::chrono::steady_clock::now();
    }
    // (In the first half second: the frames so far over their time, not 0.)
    const double shown_fps = fps > 0 ? fps : since > 0 ? fps_frames / since : 0.0;
    // (A frame that waits seconds for the simulation, as with --frames on a large scene, is 0.3 fps, not 0.)
    const std::string fps_text = shown_fps < 9.95 ? fmt::format("{:.1f}", shown_fps) : fmt::format("{:.0f}", shown_fps);
    render::Overlay ov;
    ov.time_resolution = resolution;
    std::string message;
    {
      std::lock_guard lock(sh.mutex);
      message = sh.message;
    }
    ov.lines = {fmt::format("{} fps   {:.0f} steps/s{}", fps_text, sh.steps_per_second.load(), sh.paused ? "   paused" : ""),
                fmt::format("automata {}   drawn {}", snap->automata_total, snap->drawn_automata()),
                fmt::format("ball {:.0f} m/s  r {:.2f} m  {:.1f} kg   colour {}  draw {}", ball.speed, ball.radius, ball.mass,
                            render::name(static_cast<render::ColourMode>(sh.colour.load())),
                            render::name(static_cast<render::DrawMode>(sh.draw.load())))};
    if (!message.empty()) ov.lines.push_back(message.substr(0, 400));
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    renderer.draw(*snap, static_cast<render::DrawMode>(sh.draw.load()), camera(), w, h, ov);
    if (snap->drawn_from_shared_buffers()) {
      // Drawn from the shared buffers: a fence for the simulation thread to wait for before it writes them.
      std::lock_guard lock(sh.mutex);
      if (sh.held >= 0) {
        GLsync& f = sh.drawn[static_cast<std::size_t>(sh.held)];
        if (f) glDeleteSync(f);
        f = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
        glFlush();
      }
    }
    ++shown;
    const bool last = o.frames && shown >= *o.frames;
    if (last && o.screenshot) {
      render::Image im{w, h, {}};
      glReadBuffer(GL_BACK);
      render::read_pixels(w, h, im.rgba);
      const auto bytes = render::encode_png(im);
      io::write_file_atomic(*o.screenshot, [&](std::ostream& os) {
        os.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
      });
    }
    glfwSwapBuffers(win);
    glfwSetWindowTitle(win, fmt::format("mca view: {}  t = {}  broken {}  fragments {}  {} fps", scene.name,
                                        text::sim_time(snap->time, resolution), snap->broken_links, snap->fragments,
                                        fps_text)
                                .c_str());
    if (last) break;
  }
  if (next_shot < script.size())
    fmt::print(stderr, "warning: --script {}: {} not fired: the view ended at t = {}, before t = {}{}\n",
               *o.script, script.size() - next_shot == 1 ? std::string("1 shot was") : fmt::format("{} shots were", script.size() - next_shot),
               text::sim_time(snap ? snap->time : 0.0, resolution), text::sim_time(script[next_shot].time, resolution),
               o.frames ? "; give more --frames (one per output frame of the scene)" : "");
  if (died) {
    std::lock_guard lock(sh.mutex);
    throw Error(fmt::format("mca view: the simulation stopped after {} frames: {}", shown, sh.message));
  }
  using text::count;
  // Counted in the last frame shown (the simulation thread runs a frame ahead and may have fired more): its
  // projectiles are the scene's and the shots fired since the start (or the last restart).
  const std::size_t projectiles = snap ? snap->projectiles.size() : 0;
  const std::size_t fired = projectiles > scene_projectiles ? projectiles - scene_projectiles : 0;
  // The shots due at the last frame shown: fired or refused once the simulation thread has taken them (it
  // does so before it steps on), each refused one reported by it.
  std::size_t fired_at_last = due_at_last;
  if (due_at_last > 0) {
    std::unique_lock lock(sh.mutex);
    sh.changed.wait_for(lock, std::chrono::seconds(30), [&] { return sh.handled >= sh.queued || sh.finished; });
    fired_at_last -= std::min<std::size_t>(due_at_last, sh.refused - refused_before_last);
  }
  if (fired_at_last > 0 && o.frames && !o.quiet)
    fmt::print(stderr, "mca view: {} due at the last frame shown (t = {}) went into the simulation after it and "
               "{} in no frame; give one more --frames to see {}\n",
               count(fired_at_last, "shot"), text::sim_time(snap ? snap->time : 0.0, resolution),
               fired_at_last == 1 ? "is" : "are", fired_at_last == 1 ? "it" : "them");
  const int sig = stop;
  if (!o.quiet)
    fmt::print(stderr, "mca view: {}{} shown, t = {}, {} fired, {}, broken links {}, fragments {}{}\n",
               sig ? fmt::format("closed by {}: ", signal_name(sig)) : "", count(static_cast<std::size_t>(shown), "frame"),
               text::sim_time(snap ? snap->time : 0.0, resolution), count(fired, "shot"), count(projectiles, "projectile"),
               snap ? snap->broken_links : 0, snap ? snap->fragments : 0,
               !o.screenshot ? std::string()
               : o.frames && shown >= *o.frames
                   ? fmt::format("; screenshot {}", *o.screenshot)
                   : fmt::format("; no screenshot: {} is of frame {}, and the view closed before", *o.screenshot,
                                 o.frames ? *o.frames : 0));
  return sig ? 128 + sig : 0;
}

}  // namespace mca::app
