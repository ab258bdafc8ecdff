// mca.Simulation and mca.render: the Engine the command steps, its state as numpy arrays, the command's
// outputs (VTK frames, stats.csv, checkpoints) and its renderer.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <ctime>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <fmt/format.h>
#include <tbb/global_control.h>

#include "analysis/fragments.hpp"
#include "app/commands.hpp"
#include "app/frame_output.hpp"
#include "app/render_output.hpp"
#include "app/run_folder.hpp"
#include "bindings.hpp"
#include "core/text.hpp"
#include "io/checkpoint.hpp"
#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"
#include "render/camera.hpp"
#include "render/egl_context.hpp"
#include "render/image.hpp"
#include "render/renderer.hpp"
#include "render/snapshot.hpp"
#include "sim/engine.hpp"
#include "sim/state_check.hpp"

namespace mca::python {
namespace {

static_assert(sizeof(DVec3) == 3 * sizeof(double), "DVec3 arrays are copied as three doubles each");
static_assert(sizeof(Quat) == 4 * sizeof(float), "Quat arrays are copied as four floats each (w, x, y, z)");

// The folder a Simulation writes frames into (write_frame): held locked as a run holds its folder.
struct OutputFolder {
  std::filesystem::path dir;
  std::unique_ptr<io::OutputLock> lock;
  std::unique_ptr<app::FrameWriter> writer;
  std::int64_t next_frame = 0;
  std::int64_t last_step = -1;  // the step of the last frame written
  // The folder goes on from the checkpoint of its run that the Simulation was resumed from, and no frame
  // was written since: the checkpoint's own frame (next_frame - 1, at last_step) is the state's.
  bool at_checkpoint = false;
  std::optional<app::Plan> clock;  // the folder goes on as above: its frames on the run's (check_run_clock)
};

// f() without the GIL, which is taken back in this function's body rather than in a destructor: at the
// interpreter's exit a daemon thread taking the GIL back is ended by a forced unwind (pthread_exit), which
// the destructor of py::gil_scoped_release, noexcept, turned into std::terminate ("terminate called without
// an active exception", exit code 134, for a script whose daemon thread was in advance).
template <class F>
void without_gil(F&& f) {
  PyThreadState* const state = PyEval_SaveThread();
  try {
    f();
  } catch (...) {
    PyEval_RestoreThread(state);
    throw;
  }
  PyEval_RestoreThread(state);
}

// Stepping runs on a thread of its own, in slices (calls of Engine::advance) of about kSliceSeconds, while
// the calling thread waits without the GIL and wakes every 50 ms to check for Ctrl-C and report progress.
// Ctrl-C raises KeyboardInterrupt at once and asks the stepping thread to stop after its slice; whatever
// reads or steps the simulation next waits for that slice first, so the state it sees is whole. Slices are
// long because each call of Engine::advance costs extra: it gathers the backend's arrays into its State
// (O(automata + links)) and the last step of a call writes the stress tensors; on wall_357k that is about
// half a step per call (docs/benchmarks.md, "Python module"), so the first slice is one step, to measure
// the rate, and the next ones 2 s each: a handful of calls in a benchmark of 100 steps.
constexpr double kSliceSeconds = 2.0;
class PySimulation {
 public:
  enum class Busy { no, advancing, finishing };
  PySimulation(const SceneDef& scene, int threads) : threads_(threads) {
    Engine::check_environment();
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads_));
    without_gil([&] { engine_ = std::make_shared<Engine>(scene); });
  }
  PySimulation(const io::Checkpoint& cp, const std::filesystem::path& file, int threads)
      : threads_(threads), resumed_from_(file) {
    const std::string source = fmt::format("checkpoint '{}'", file.string());
    Engine::check_environment();
    tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads_));
    without_gil([&] { engine_ = std::make_shared<Engine>(cp.scene, cp.state, source, cp.model_fingerprint); });
    wall_ = first_wall_ = cp.wall_seconds;
    first_step_ = cp.state.step;
    // All of the checkpoint but its state, which is the engine's: write_frame goes on in its run's folder.
    resumed_head_.scene = cp.scene;
    resumed_head_.frame = cp.frame;
    resumed_head_.total_steps = cp.total_steps;
    resumed_head_.wall_seconds = cp.wall_seconds;
    resumed_head_.model_fingerprint = cp.model_fingerprint;
    resumed_head_.state.step = cp.state.step;
  }
  ~PySimulation() {
    stop_ = true;
    join();
    output.reset();  // its FrameWriter refers to the engine's model
  }
  PySimulation(const PySimulation&) = delete;
  PySimulation& operator=(const PySimulation&) = delete;

  // The engine, for reading: after the slice a Ctrl-C left running has ended. Refused while another
  // Python thread is in advance (the state is the backend's own arrays) or writes the run's end.
  const Engine& engine() const {
    refuse_while_busy();
    join();
    // Another thread may have begun an advance while this one waited for the slice (without the GIL); from
    // here this thread holds the GIL, so none can begin until it has read.
    refuse_while_busy();
    return *engine_;
  }
  const std::shared_ptr<Engine>& shared() const { return engine_; }
  bool advancing() const { return busy_ == Busy::advancing; }
  bool finishing() const { return busy_ == Busy::finishing; }
  void refuse_while_busy() const {
    switch (busy_.load()) {
      case Busy::no:
        return;
      case Busy::advancing:
        throw Error("the simulation is advancing (in another thread, or this is advance's progress callback, which "
                    "gets done and total); read its state when advance returns");
      case Busy::finishing:
        throw Error("the simulation is writing its run's end (close_output(finish=True), in another thread or from "
                    "its progress callback); use it when that returns");
    }
  }
  int threads() const { return threads_; }
  double wall() const {
    join();
    return wall_;
  }
  // Where this Simulation began (a checkpoint's step and wall seconds; 0 for a new one), and the checkpoint
  // it was resumed from (empty for a new one).
  std::int64_t first_step() const { return first_step_; }
  double first_wall() const { return first_wall_; }
  const std::filesystem::path& resumed_from() const { return resumed_from_; }
  // The run's steps: the scene's duration's, or those of the run a checkpoint was saved from.
  std::int64_t total_steps() const {
    return resumed_from_.empty() ? engine().total_steps() : resumed_head_.total_steps;
  }
  // The checkpoint it was resumed from without its state (whose step is there), where it was.
  const io::Checkpoint& resumed_head() const { return resumed_head_; }

  void advance(std::int64_t steps, const py::object& progress) {
    if (steps < 0) throw Error(fmt::format("advance({}): the step count is negative; give 0 or more steps", steps));
    if (steps > Engine::kMaxSteps)
      throw Error(fmt::format("advance({}): more than {:.0e} steps would not end; give fewer", steps,
                              static_cast<double>(Engine::kMaxSteps)));
    claim(Busy::advancing);
    // However advance ends, the slices stop (a slice still running is one a Ctrl-C left, or one of a daemon
    // thread the interpreter's exit ended; a finished advance has none, and the next one starts afresh).
    struct Done {
      std::atomic<Busy>& b;
      std::atomic<bool>& stop;
      ~Done() {
        stop = true;
        b = Busy::no;
      }
    } done_guard{busy_, stop_};
    join();
    report_left_over();
    stop_ = false;
    done_ = 0;
    running_ = true;
    // (Not while another thread joins the last one: join() holds the lock.)
    without_gil([&] {
      std::lock_guard<std::mutex> lock(join_mutex_);
      worker_ = std::thread([this, steps] { step_slices(steps); });
    });
    std::int64_t reported = 0;
    for (;;) {
      without_gil([&] {
        std::unique_lock<std::mutex> lock(mutex_);
        finished_.wait_for(lock, std::chrono::milliseconds(50), [this] { return !running_; });
      });
      const bool finished = !running_;
      // Ctrl-C (or an exception from the callback): raised now; the slice in flight ends on its own.
      if (PyErr_CheckSignals() != 0) {
        stop_ = true;
        throw py::error_already_set();
      }
      const std::int64_t d = done_;
      if (!progress.is_none() && d > reported) {
        reported = d;
        try {
          progress(d, steps);
        } catch (...) {
          stop_ = true;
          throw;
        }
      }
      if (finished) break;
    }
    join();
    report_left_over();
  }

  // The run's end (close_output(finish=True)), whose fragment meshes may take a minute: work(poll, each) on a
  // thread of its own with the Simulation's threads, while this thread waits without the GIL and wakes every
  // 50 ms for Ctrl-C and progress(done, total) (each(done, total) counts what work has written), as advance
  // does. Ctrl-C, or progress raising, makes poll and each throw in work, which ends within the piece being
  // meshed, and is raised once it has. Reads, steps and another end wait for it (they are refused).
  using Poll = std::function<void()>;
  using Each = std::function<void(std::size_t done, std::size_t total)>;
  void finish(const std::function<void(const Poll&, const Each&)>& work, const py::object& progress) {
    claim(Busy::finishing);
    struct Release {
      std::atomic<Busy>& b;
      ~Release() { b = Busy::no; }
    } release{busy_};
    join();
    struct Stopped {};
    std::atomic<bool> stop{false}, running{true};
    std::atomic<std::size_t> done{0}, total{0};
    std::exception_ptr failed;
    std::mutex m;
    std::condition_variable ended;
    std::thread worker;
    without_gil([&] {
      worker = std::thread([&] {
        try {
          tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads_));
          const Poll poll = [&] {
            if (stop) throw Stopped{};
          };
          work(poll, [&](std::size_t d, std::size_t t) {
            total = t;
            done = d;
            poll();
          });
        } catch (const Stopped&) {
        } catch (...) {
          failed = std::current_exception();
        }
        {
          std::lock_guard<std::mutex> lock(m);
          running = false;
        }
        ended.notify_all();
      });
    });
    // (With the GIL or without it: a daemon thread ended at the interpreter's exit unwinds from taking it back.)
    const auto end = [&] {
      stop = true;
      if (PyGILState_Check()) without_gil([&] { worker.join(); });
      else worker.join();
    };
    try {
      std::size_t reported = 0;
      for (;;) {
        without_gil([&] {
          std::unique_lock<std::mutex> lock(m);
          ended.wait_for(lock, std::chrono::milliseconds(50), [&] { return !running; });
        });
        const bool finished = !running;
        if (PyErr_CheckSignals() != 0) throw py::error_already_set();
        const std::size_t d = done;
        if (!progress.is_none() && d > reported) {
          reported = d;
          progress(d, total.load());
        }
        if (finished) break;
      }
    } catch (...) {
      end();
      throw;
    }
    end();
    if (failed) std::rethrow_exception(failed);
  }

  // The module's cost over the command for advance (bench/python_overhead.py): from one snapshot of the
  // state, uploaded before each timed run as `mca bench` does, `pairs` times in turn: advance(steps) as
  // Python calls it (the stepping thread, its slices, the waits and signal checks) and one
  // Engine::advance(steps) as `mca bench` times it. Returns the pairs of wall seconds; the state is left
  // at the snapshot's steps later.
  struct BenchPair {
    double module_wall, command_wall, module_cpu, command_cpu;  // seconds
  };
  static double cpu_seconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
  }
  std::vector<BenchPair> bench_advance(std::int64_t steps, int pairs) {
    if (steps < 1 || steps > std::numeric_limits<int>::max() || pairs < 1)
      throw Error(fmt::format("_bench_advance({}, {}): give at least one step (at most 2^31 - 1) and one pair", steps,
                              pairs));
    join();
    const State snapshot = engine_->state();
    std::vector<BenchPair> out;
    const auto seconds = [](auto t0) {
      return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
    for (int k = 0; k < pairs; ++k) {
      BenchPair p{};
      engine_->backend().upload(snapshot);
      auto t0 = std::chrono::steady_clock::now();
      double c0 = cpu_seconds();
      advance(steps, py::none());
      p.module_wall = seconds(t0);
      p.module_cpu = cpu_seconds() - c0;
      engine_->backend().upload(snapshot);
      without_gil([&] {
        tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads_));
        t0 = std::chrono::steady_clock::now();
        c0 = cpu_seconds();
        engine_->advance(static_cast<int>(steps));
        p.command_wall = seconds(t0);
        p.command_cpu = cpu_seconds() - c0;
      });
      out.push_back(p);
    }
    return out;
  }

  std::unique_ptr<OutputFolder> output;
  std::optional<render::Framing> framing;  // the renderer's, of the starting state (as a run's camera)

 private:
  void step_slices(std::int64_t steps) {
    try {
      tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads_));
      // The first slice of a Simulation is one step, which measures the rate; later ones take kSliceSeconds at
      // the rate of the slice before (also across calls of advance), but at most twice its steps: the rate
      // falls as a run goes on (contacts, breaking, a busier machine), and a slice planned at the rate of
      // the quiet first steps ran for 15 s.
      std::int64_t chunk = per_step_ > 0 ? std::min(slice_steps(per_step_), 2 * last_slice_) : 1, taken = 0;
      if (steps == 0) engine_->advance(0);  // (no step; a simulation that stopped says so, as on every call)
      while (taken < steps && !stop_) {
        const int n = static_cast<int>(std::min(chunk, steps - taken));
        const auto t0 = std::chrono::steady_clock::now();
        const StepHealth h = engine_->advance(n);
        const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        wall_ += took;
        if (h.flags != kHealthy) {
          health_ = h;
          break;
        }
        taken += n;  // a healthy call takes all its steps
        done_ = taken;
        // The next slice: kSliceSeconds at the rate of this one, at most twice its steps.
        if (took > 0) per_step_ = took / n;
        last_slice_ = n;
        chunk = per_step_ > 0 ? std::min(slice_steps(per_step_), std::int64_t{2} * n) : std::int64_t{2} * n;
      }
    } catch (...) {
      error_ = std::current_exception();
    }
    {
      std::lock_guard<std::mutex> lock(mutex_);
      running_ = false;
    }
    finished_.notify_all();
  }

  static std::int64_t slice_steps(double per_step) {
    return static_cast<std::int64_t>(std::clamp(kSliceSeconds / per_step, 1.0, 1073741824.0));
  }

  // What a call that steps or writes the run's end takes first, refused while another holds it.
  void claim(Busy what) {
    for (;;) {
      Busy was = Busy::no;
      if (busy_.compare_exchange_strong(was, what)) return;
      if (was == Busy::advancing && what == Busy::advancing)
        throw Error("the simulation is advancing (in another thread, or this is advance's progress callback); one "
                    "advance at a time");
      refuse_while_busy();  // (unless what held it has just ended: then again)
    }
  }

  // Waits for the stepping thread's last slice. Two Python threads may wait at once (a read in one, an
  // advance in the other, after a Ctrl-C left a slice running): one joins, under join_mutex_, and the other
  // then finds nothing to join (joining one thread twice hung the second for good).
  void join() const {
    const auto wait = [&] {
      std::lock_guard<std::mutex> lock(join_mutex_);
      if (worker_.joinable()) worker_.join();
    };
    if (PyGILState_Check()) {
      without_gil(wait);
    } else {
      wait();
    }
  }

  // What the last slices ended with: an exception, or a step that went unstable (then the state is that
  // step's, as the command leaves it).
  void report_left_over() {
    if (error_) {
      std::exception_ptr e = error_;
      error_ = nullptr;
      std::rethrow_exception(e);
    }
    if (health_.flags != kHealthy) {
      const StepHealth h = health_;
      health_ = StepHealth{};
      throw Error(instability_message(*engine_, h));
    }
  }

  int threads_;
  std::shared_ptr<Engine> engine_;
  mutable std::thread worker_;
  mutable std::mutex join_mutex_;  // held while worker_ is joined or replaced
  std::mutex mutex_;
  std::condition_variable finished_;
  std::atomic<bool> running_{false};  // the stepping thread is going (set false under mutex_, for finished_)
  std::atomic<bool> stop_{false};
  std::atomic<Busy> busy_{Busy::no};
  std::atomic<std::int64_t> done_{0};
  std::exception_ptr error_;
  StepHealth health_;
  double wall_ = 0;  // seconds of stepping, all sessions (a checkpoint's included)
  double first_wall_ = 0;
  std::int64_t first_step_ = 0;
  std::filesystem::path resumed_from_;
  io::Checkpoint resumed_head_;
  double per_step_ = 0;         // seconds a step took in the last slice
  std::int64_t last_slice_ = 1;  // its steps
};

// ---- arrays ------------------------------------------------------------------------------------------------

// A new array holding a copy of `data`.
template <class T>
py::array_t<T> copy_of(const T* data, std::vector<py::ssize_t> shape) {
  py::array_t<T> a(shape);
  if (a.size() > 0) std::memcpy(a.mutable_data(), data, static_cast<std::size_t>(a.nbytes()));
  return a;
}

// A read-only view of one of the model's arrays (fixed once built), which keeps the engine alive as long
// as the array is: it outlives the Simulation object safely.
template <class T>
py::array view_of(const std::shared_ptr<Engine>& engine, const std::vector<T>& v) {
  if (v.empty()) return py::array_t<T>(std::vector<py::ssize_t>{0});
  auto* keep = new std::shared_ptr<Engine>(engine);
  py::capsule base(keep, [](void* p) { delete static_cast<std::shared_ptr<Engine>*>(p); });
  py::array_t<T> a({static_cast<py::ssize_t>(v.size())}, {static_cast<py::ssize_t>(sizeof(T))}, v.data(), base);
  a.attr("setflags")(py::arg("write") = false);
  return a;
}

py::array_t<double> vec3_array(const std::vector<DVec3>& v) {
  return copy_of(reinterpret_cast<const double*>(v.data()), {static_cast<py::ssize_t>(v.size()), 3});
}

std::string hash_text(const State& s) { return fmt::format("{:016x}", state_hash(s)); }

// ---- the renderer ------------------------------------------------------------------------------------------

// One OpenGL context per process, made on the thread that renders first and kept until the process ends
// (a context torn down while the interpreter exits can crash in the driver): every Simulation draws with it.
struct Gl {
  render::EglContext context;
  render::Renderer renderer;
  std::thread::id thread = std::this_thread::get_id();
};
Gl& gl() {
  static Gl* instance = new Gl();
  if (instance->thread != std::this_thread::get_id())
    throw Error("mca.render draws with an OpenGL context of the thread that rendered first; call it from that thread");
  return *instance;
}

// A file to write (a picture, a checkpoint): not empty, not a folder.
void check_file_path(const std::filesystem::path& path, const std::string& key, const char* what) {
  if (path.empty()) throw Error(fmt::format("{} is empty (\"\"); give the path of the {} file", key, what));
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw Error(fmt::format("{} = '{}' is a folder; give the path of the {} file (a name in that folder)", key,
                            path.string(), what));
}

// progress=: None or a callable, checked before any step is taken.
void check_progress(const py::object& progress) {
  if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
    throw Error(fmt::format("progress = {} is not callable; give a function progress(done, total) or None",
                            shown(progress)));
}

py::array_t<std::uint8_t> render_to(PySimulation& sim, Given<py_type::optional_path> path_given,
                                    Given<py_type::str> colour_arg, Given<py_type::optional_str> draw_given,
                                    Given<py_type::size> size_given) {
  const py::handle path_arg = path_given, draw_arg = draw_given, size_arg = size_given;
  std::optional<std::filesystem::path> path;
  if (!path_arg.is_none()) {
    path = to_path(path_arg, "render: path");
    check_file_path(*path, "render: path", "PNG");
    // (By the name's text: for ".png" alone, std::filesystem's extension is empty, and the message said the
    // path did not end in .png.)
    const std::string name = path->filename().string();
    const bool bare = name == ".png" || name == ".PNG";
    if (bare || !(name.size() > 4 && (name.ends_with(".png") || name.ends_with(".PNG"))))
      throw Error(fmt::format("render: path = '{}' {}; the picture is written as PNG, so give a name ending in .png "
                              "(e.g. frame.png)",
                              path->string(), bare ? "is the extension .png alone, with no name before it"
                                                   : "does not end in .png"));
  }
  const std::string colour_text = to_text(colour_arg, "render: colour", "a str: one of " + render::colour_mode_names());
  std::optional<std::string> draw_text;
  if (!draw_arg.is_none()) draw_text = to_text(draw_arg, "render: draw", "a str: one of " + render::draw_mode_names());
  const std::string size_what = "(width, height), two whole numbers of pixels";
  // (The size of a sequence that has none, a numpy array of no dimension, is an error to clear: it raised
  // a TypeError.)
  Py_ssize_t size_count = -1;
  if (py::isinstance<py::sequence>(size_arg) && !PyUnicode_Check(size_arg.ptr()) &&
      (size_count = PySequence_Size(size_arg.ptr())) < 0)
    PyErr_Clear();
  if (size_count != 2)
    throw Error(fmt::format("render: size = {} is not two whole numbers; give {}", shown(size_arg), size_what));
  const auto size_seq = py::reinterpret_borrow<py::sequence>(size_arg);
  const int width = static_cast<int>(to_whole(size_seq[0], "render: size[0]", std::numeric_limits<int>::min(),
                                              std::numeric_limits<int>::max(), size_what));
  const int height = static_cast<int>(to_whole(size_seq[1], "render: size[1]", std::numeric_limits<int>::min(),
                                               std::numeric_limits<int>::max(), size_what));
  const Engine& e = sim.engine();
  const Model& m = e.model();
  app::check_render_size(width, height, "size");
  const auto colour = render::parse_colour_mode(colour_text);
  if (!colour)
    throw Error(fmt::format("colour '{}' is not a colour mode; give one of: {}", colour_text, render::colour_mode_names()));
  // As the command: a mesh object is drawn as its own triangles unless asked otherwise.
  const bool meshes = std::any_of(e.scene().objects.begin(), e.scene().objects.end(),
                                  [](const ObjectDef& d) { return d.shape == Shape::mesh; });
  const std::string draw_name = draw_text ? *draw_text : meshes ? "surface" : "cubes";
  const auto draw = render::parse_draw_mode(draw_name);
  if (!draw) throw Error(fmt::format("draw '{}' is not a draw mode; give one of: {}", draw_name, render::draw_mode_names()));
  if (*draw == render::DrawMode::surface && m.surface.faces() == 0)
    throw Error(fmt::format("draw \"surface\" needs an object of shape \"mesh\" (its triangles are drawn); scene '{}' "
                            "has none: use draw=\"cubes\", \"spheres\" or \"links\"",
                            e.scene().source));
  Gl& g = gl();
  if (!sim.framing) sim.framing = render::objects_box(m, initial_state(m));
  const render::Camera camera = render::make_camera(e.scene().camera, m, *sim.framing,
                                                    static_cast<float>(width) / static_cast<float>(height),
                                                    e.scene().source);
  // The colour scales of RenderOutput (app/render_output.cpp): speeds up to the fastest initial speed,
  // stresses up to the strongest tensile strength in use.
  double scale_max = 0;
  if (*colour == render::ColourMode::speed) {
    for (const auto& p : m.projectiles) scale_max = std::max<double>(scale_max, length(p.velocity));
    for (const DVec3& v : m.velocity0) scale_max = std::max<double>(scale_max, length(v));
    if (scale_max <= 0) scale_max = 1;
  } else if (*colour == render::ColourMode::stress) {
    std::vector<std::uint8_t> used(m.groups.size());
    for (auto gr : m.group) used[gr] = 1;
    for (std::size_t gr = 0; gr < m.groups.size(); ++gr)
      if (used[gr]) scale_max = std::max<double>(scale_max, m.groups[gr].tensile_strength);
  }
  render::SnapshotOptions so;
  so.draw = *draw;
  so.colour = *colour;
  so.scale_max = scale_max;
  // The backend's draw list (the CUDA backend's written into the renderer's buffers where CUDA can share
  // them), else from its state.
  const render::Snapshot snap = render::make_snapshot(m, e.backend(), so, sim.framing->origin, &g.renderer.draw_target());
  render::OffscreenTarget target(width, height);
  target.bind();
  g.renderer.draw(snap, *draw, camera, width, height);
  render::Image im;
  im.width = width;
  im.height = height;
  target.read_rgba(im.rgba);
  if (path) {
    const auto png = render::encode_png(im);
    io::write_file_atomic(*path, [&](std::ostream& os) {
      os.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
    });
  }
  return copy_of(im.rgba.data(), {height, width, 4});
}

// ---- outputs -------------------------------------------------------------------------------------------------

// A folder as one path however it is spelt ("out", "out/", "./out", through a link): the folder a
// Simulation writes into is known by it (spelt otherwise, it was taken for another folder, and started
// afresh: its frames removed).
std::filesystem::path folder_path(const std::filesystem::path& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path absolute = fs::absolute(dir, ec);
  if (ec) throw Error(fmt::format("write_frame: the folder '{}' has no absolute path: {}", dir.string(), ec.message()));
  fs::path p = fs::weakly_canonical(absolute, ec);
  if (ec) p = absolute.lexically_normal();
  if (!p.has_filename() && p.has_parent_path() && p != p.root_path()) p = p.parent_path();  // ("out/")
  return p;
}

// Whether `folder` is the run folder of the checkpoint `file` (FOLDER/checkpoints/frame_NNNNNN.mcack).
bool is_run_folder_of(const std::filesystem::path& file, const std::filesystem::path& folder) {
  if (file.empty() || !file.has_parent_path() || file.parent_path().filename() != "checkpoints" ||
      !io::numbered(file.filename().string(), "frame_", ".mcack"))
    return false;
  const std::filesystem::path run = file.parent_path().parent_path();
  std::error_code ec;
  return folder_path(run.empty() ? "." : run) == folder || std::filesystem::equivalent(run.empty() ? "." : run, folder, ec);
}

// In the folder of the run it was resumed from, a Simulation writes that run's frames: frame k at step
// min(k x steps_per_frame, the run's steps), `next` the one after the last written, and up to the run's end;
// or the checkpoint's own frame at its step (`at_checkpoint`: before any other). Throws, naming the step to
// write at, where the state is at no such step (the frames would be numbered off the run's clock, stats.csv
// and the collections pairing them with other frames' times, and mca resume would leave them behind).
void check_run_clock(const PySimulation& sim, const std::filesystem::path& dir, const app::Plan& clock, std::int64_t next,
                     bool at_checkpoint) {
  const Engine& e = sim.engine();
  const std::int64_t step = e.state().step, spf = e.steps_per_frame(), total = clock.total_steps,
                     frames = clock.total_frames;
  if (at_checkpoint && step == sim.resumed_head().state.step) return;
  const std::string how = fmt::format(
      "write_frame: the run in {} goes on frame by frame as mca resume writes it (frame k at step k x {}, up to its "
      "end at step {}, frame {})",
      dir.string(), spf, total, frames);
  if (next > frames)
    throw Error(fmt::format("{}, and its last frame is written; this Simulation is at step {}. Give write_frame "
                            "another folder for frames past the run's end",
                            how, step));
  const std::int64_t due = std::min(next * spf, total);
  if (step < due)
    throw Error(fmt::format("{}: its next frame, {}, is at step {}, and this Simulation is at step {}; advance({}) "
                            "first",
                            how, next, due, step, due - step));
  if (step > due)
    throw Error(fmt::format("{}: its next frame, {}, is at step {}, and this Simulation is past it, at step {}{}. To "
                            "write its frames, resume the folder again (mca.Simulation.resume(\"{}\"): from that "
                            "checkpoint, the frames after it stepped again); or give write_frame another folder",
                            how, next, due, step,
                            at_checkpoint ? fmt::format(" (the folder goes on from its newest checkpoint, frame {}, "
                                                        "whatever was written there since)",
                                                        next - 1)
                                          : "",
                            text::utf8_shown(dir.string())));
}

// The run folder `out` (locked, recovered) of the checkpoint the Simulation was resumed from, readied as
// mca resume readies it (app::go_on_in_folder) for the frames after the checkpoint's; the frames written
// next are numbered on from it. Returns the warnings to give.
std::vector<std::string> ready_run_folder(PySimulation& sim, OutputFolder& out) {
  const Engine& e = sim.engine();
  const io::Checkpoint& head = sim.resumed_head();
  const std::filesystem::path& file = sim.resumed_from();
  // From the checkpoint resumed, not from one after it: their frames would be gone, and mca resume would go
  // on from the newest (the fixes keep the folder one run).
  const auto all = io::list_checkpoints(out.dir / "checkpoints");
  std::error_code ec;
  if (all.empty() || !std::filesystem::equivalent(all.back(), file, ec))
    throw Error(fmt::format(
        "write_frame: {} is the folder of the run whose checkpoint {} this Simulation was resumed from, and {}: "
        "going on from that one would leave the checkpoints of a run it no longer is. Resume the newest "
        "(mca.Simulation.resume(\"{}\")), remove the checkpoints after it, or give write_frame another folder",
        out.dir.string(), file.filename().string(),
        all.empty() ? std::string("its checkpoints/ holds no checkpoint now")
                    : fmt::format("its newest checkpoint is {}", all.back().filename().string()),
        text::utf8_shown(out.dir.string())));
  io::check_checkpoint_scene(head, file, out.dir);
  // (Saved between two frames, mca resume's message names this module's resume as the way on.)
  const std::string source = fmt::format("checkpoint '{}'", file.string());
  const app::Plan plan = app::checkpoint_plan(out.dir, e, head, source,
                                              "a run's frames go on in its folder from the end of a frame: give "
                                              "write_frame another folder (a new run from this state), or resume a "
                                              "checkpoint saved at the end of a frame");
  // (Once the checkpoint is known to be the folder's run's, before anything is removed.)
  check_run_clock(sim, out.dir, plan, head.frame, true);
  std::vector<std::string> said;
  if (app::summary_status(out.dir) == "finished")
    said.push_back(fmt::format("the run in {} had finished (its summary.json says so): it goes on from its newest "
                               "checkpoint (frame {}), and its end (summary.json, fragments.csv, the fragment meshes) "
                               "is removed; close_output(finish=True) writes it again from the last frame written",
                               out.dir.string(), head.frame - 1));
  app::GoingOn how;
  how.draw = false;
  how.not_drawn = "write_frame draws no pictures";
  how.check_fits = false;  // (as write_frame into a new folder: the frames are the caller's to count)
  how.warn = how.note = [&](const std::string& w) { said.push_back(w); };
  app::FolderGoingOn going = app::go_on_in_folder(out.dir, e, head, plan, how);
  out.writer = std::move(going.writer);
  out.next_frame = head.frame;
  out.last_step = head.state.step;
  out.at_checkpoint = true;
  out.clock = plan;
  return said;
}

// Frame `next_frame` of `dir` as `mca run` writes it: the VTK frames and their collections, the bound
// surface (output.surface), a row of stats.csv; the first frame in a folder makes a new run's checks, writes
// scene.toml and removes what an earlier run left there (as a new run does; other files stay).
std::int64_t write_frame_unworded(PySimulation& sim, const std::filesystem::path& dir);

std::int64_t write_frame(PySimulation& sim, const std::filesystem::path& dir) {
  try {
    return write_frame_unworded(sim, dir);
  } catch (const Error& refused) {
    // The output checks are the command's, and name its flag: here the folder is write_frame's.
    std::string what = refused.what();
    for (std::size_t at; (at = what.find(" (--out)")) != std::string::npos;) what.replace(at, 8, " for write_frame");
    throw Error(what);
  }
}

std::int64_t write_frame_unworded(PySimulation& sim, const std::filesystem::path& dir) {
  const Engine& e = sim.engine();
  const State& s = e.state();  // (first: a simulation that cannot be read touches no folder)
  if (dir.empty()) throw Error("write_frame: the folder is empty (\"\"); give the output folder");
  const std::filesystem::path folder = folder_path(dir);
  std::error_code ec;  // (the same folder through another mount: the same device and inode)
  const bool same = sim.output && (sim.output->dir == folder || std::filesystem::equivalent(sim.output->dir, dir, ec));
  if (!same) {
    // The folder before is released once the new one has passed its checks: a folder refused kept none, and
    // the next write_frame into the one before started it afresh, its frames removed.
    auto out = std::make_unique<OutputFolder>();
    out->dir = folder;
    const bool goes_on = is_run_folder_of(sim.resumed_from(), folder);
    io::prepare_output_dir(out->dir);
    auto subfolders = app::frame_subfolders(e.scene());
    if (goes_on) subfolders.emplace_back("checkpoints");
    io::check_output_subfolders(out->dir, subfolders);
    // (as mca run: a mesh the scene read, lying where the earlier run's files are removed, would go)
    io::check_inputs_outside_subfolders(out->dir, app::mesh_inputs(e.scene()));
    out->lock = std::make_unique<io::OutputLock>(out->dir);
    // (First: the files of an earlier run that a killed session had set aside are that run's again, and a
    // dead session's temporaries go.)
    for (const std::string& said : app::FrameWriter::recover_folder(out->dir))
      if (PyErr_WarnEx(PyExc_UserWarning, said.c_str(), 1) != 0) throw py::error_already_set();
    if (goes_on) {
      // (Said once the folder is this Simulation's: a warning raised as an error leaves it whole.)
      const std::vector<std::string> said = ready_run_folder(sim, *out);
      sim.output = std::move(out);
      for (const std::string& w : said)
        if (PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 1) != 0) throw py::error_already_set();
      return write_frame_unworded(sim, dir);
    }
    // As a new run: not a folder of files of a run's names that no run of mca wrote, nor a run that did
    // not finish (its frames would go, and its checkpoints could no longer be resumed).
    app::check_folder_is_a_runs(
        out->dir, "write_frame another folder",
        fmt::format("mca.Simulation.resume(\"{0}\") and its write_frame(\"{0}\"), or mca resume {1}",
                    text::utf8_shown(out->dir.string()), text::shell_word(out->dir.string())));
    sim.output.reset();
    // An earlier run's outputs, as mca run removes them (its summary.json and fragment meshes were left, and
    // the Blender importer took the old run's spacing and pieces for this one's): set aside, all or none,
    // and removed once the scene is written (a scene that cannot be written leaves the earlier run whole).
    io::StagedRemoval earlier(out->dir);
    app::stage_earlier_run(earlier, out->dir);
    earlier.will_write(out->dir / "scene.toml");
    io::write_file_atomic(out->dir / "scene.toml", [&](std::ostream& os) { os << io::scene_to_toml(e.scene()); },
                          false);
    earlier.commit();
    app::remove_empty_output_folders(out->dir, false);  // (as mca run: the earlier run's checkpoints/ went)
    out->writer = std::make_unique<app::FrameWriter>(out->dir, e.model(), e.scene().output);
    sim.output = std::move(out);
  }
  OutputFolder& out = *sim.output;
  if (out.at_checkpoint && s.step == out.last_step) return out.next_frame - 1;  // (its frame already)
  if (out.clock) check_run_clock(sim, out.dir, *out.clock, out.next_frame, false);
  out.at_checkpoint = false;
  if (out.next_frame == 0 && !e.scene().output.vtk && !e.scene().output.surface) {
    const std::string said = fmt::format("write_frame: output.vtk is false, so {} gets the frames' rows of stats.csv "
                                         "and no frames (set scene.output.vtk = True for them)",
                                         out.dir.string());
    if (PyErr_WarnEx(PyExc_UserWarning, said.c_str(), 1) != 0) throw py::error_already_set();
  }
  const auto frags = out.writer->fragments(s);
  const std::string row = out.writer->format_row(out.writer->stats(out.next_frame, s, frags));
  out.writer->write_frame(out.next_frame, s, frags);
  if (out.next_frame == 0) out.writer->start_stats({row});
  else out.writer->append_stats(row);
  out.last_step = s.step;
  return out.next_frame++;
}

// close_output(finish=True): the run's end as mca run writes it after its last frame, from the state of the
// last frame written: the fragment meshes (output.fragments), fragments.csv and summary.json, "finished".
void finish_output(PySimulation& sim, const py::object& progress) {
  const Engine& e = sim.engine();
  const State& s = e.state();
  if (!sim.output)
    throw Error("close_output(finish=True): no folder is open; write_frame(folder) first (the run's end describes "
                "its last frame)");
  OutputFolder& out = *sim.output;
  if (out.last_step != s.step)
    throw Error(fmt::format("close_output(finish=True): the state is at step {}, past the last frame written to {} "
                            "(frame {}, step {}); write_frame first, so that the run's end describes its last frame",
                            s.step, out.dir.string(), out.next_frame - 1, out.last_step));
  const auto frags = out.writer->fragments(s);
  sim.finish([&](const PySimulation::Poll& poll, const PySimulation::Each& each) {
    out.writer->write_fragment_meshes(s, frags, each, poll);
  }, progress);
  app::write_summary(out.dir, e, frags, sim.first_wall(), sim.wall() - sim.first_wall(), s.step - sim.first_step(),
                     sim.threads(), "finished", sim.resumed_from());
}

void checkpoint(PySimulation& sim, const std::filesystem::path& path) {
  check_file_path(path, "checkpoint: path", "checkpoint");
  const Engine& e = sim.engine();
  io::Checkpoint cp;
  cp.scene = e.scene();
  cp.state = e.state();
  // The frame clock of `mca resume`: a checkpoint saved at a frame's end (step = k x steps_per_frame, or the
  // run's last step, frame ceil(total / steps_per_frame)) says k + 1 frames were written, which `mca resume`
  // continues from (in a run folder with this scene.toml). (At a last frame shorter than the others it
  // counted one frame too few, and mca resume called the file damaged.)
  cp.total_steps = std::max(sim.total_steps(), cp.state.step);
  const std::int64_t spf = e.steps_per_frame();
  cp.frame = cp.state.step == cp.total_steps ? app::plan_of(cp.total_steps, spf).total_frames + 1
                                             : cp.state.step / spf + 1;
  cp.wall_seconds = sim.wall();
  cp.model_fingerprint = model_fingerprint(e.model());
  if (path.has_parent_path()) {
    std::error_code ec;
    if (!std::filesystem::is_directory(path.parent_path(), ec))
      throw Error(fmt::format("{}: the folder {} does not exist; create it first", path.string(),
                              path.parent_path().string()));
  }
  io::write_checkpoint(path, cp);
}

std::unique_ptr<PySimulation> resume(const std::filesystem::path& path, int threads,
                                     std::optional<SolverDef::Backend> backend) {
  std::filesystem::path file = path;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    // A run's folder (its checkpoints/) or a folder of checkpoints: the newest.
    auto all = io::list_checkpoints(path / "checkpoints");
    if (all.empty()) all = io::list_checkpoints(path);
    if (all.empty()) {
      // Checkpoints by other names (sim.checkpoint("out/py/at20ms.mcack")) are not a run's: named, not taken.
      std::vector<std::string> named;
      for (const auto& dir : {path, path / "checkpoints"})
        for (const auto& e : std::filesystem::directory_iterator(dir, ec))
          if (e.path().extension() == ".mcack" && e.is_regular_file(ec)) named.push_back(e.path().string());
      std::sort(named.begin(), named.end());
      if (!named.empty())
        throw Error(fmt::format("no checkpoint of a run (checkpoints/frame_NNNNNN.mcack) in '{}', which holds {}{}: give "
                                "the checkpoint's path, e.g. mca.Simulation.resume(\"{}\")",
                                path.string(), text::utf8_shown(named.front()),
                                named.size() > 1 ? fmt::format(" and {} more .mcack files", named.size() - 1) : "",
                                text::utf8_shown(named.front())));
      throw Error(fmt::format("no checkpoint in '{}' or '{}': give a .mcack file, or the --out folder of a run started "
                              "with --checkpoint-every N",
                              path.string(), (path / "checkpoints").string()));
    }
    file = all.back();
  }
  io::Checkpoint cp = io::read_checkpoint(file, file != path);
  // (Absolute: the folder it is of stays the same after os.chdir, and the summary names it.)
  if (const auto absolute = std::filesystem::absolute(file, ec); !ec) file = absolute.lexically_normal();
  // Any backend continues any checkpoint with the same bits.
  if (backend) cp.scene.solver.backend = *backend;
  return std::make_unique<PySimulation>(cp, file, app::thread_count(threads, "threads="));
}

// backend=: as to_backend, and "cuda" only where there is a GPU (the message names the argument, not the
// scene it would be written into).
std::optional<SolverDef::Backend> backend_here(py::handle v, const std::string& key) {
  const auto b = to_backend(v, key);
  std::string why;
  if (b == SolverDef::Backend::cuda && cuda_device(&why).empty())
    throw Error(fmt::format("{} = \"cuda\": {}; use \"cpu\" or \"auto\", or a build of mca made where nvcc is found, on "
                            "a machine with an NVIDIA GPU and its driver",
                            key, why));
  return b;
}

// threads=: a whole number (0: all cores); app::thread_count refuses a negative one.
int to_int_threads(py::handle v) {
  return static_cast<int>(to_whole(v, "threads", std::numeric_limits<int>::min(), std::numeric_limits<int>::max(),
                                   "a whole number of worker threads (0: all cores; at most 2147483647)"));
}

SceneDef scene_of(const py::handle& scene) {
  if (py::isinstance<PyScene>(scene)) return scene.cast<const PyScene&>().to_def();
  if (py::isinstance<py::str>(scene) || py::hasattr(scene, "__fspath__"))
    return io::load_scene_file(to_path(scene, "Simulation: scene"));
  throw Error(fmt::format("Simulation(scene=...): a {} is not a scene; give an mca.Scene or the path of a scene file",
                          py::str(py::type::handle_of(scene).attr("__name__")).cast<std::string>()));
}

}  // namespace

void bind_simulation(py::module_& m) {
  py::class_<PySimulation> sim(m, "Simulation", R"(A run of a scene: the model built from it and a backend stepping it.

Arrays are in the model's automaton order (objects in scene order, each in lattice order). Methods that
return state arrays return copies taken when called; strength_class(), masses() and object_ids() return
read-only views of the model, which never changes once built; every array stays valid after the
Simulation is gone.)");
  sim.def(py::init([](Given<py_type::scene_or_path> scene, Given<py_type::integer> threads_arg,
                       Given<py_type::optional_str> backend_arg) {
            const int threads = to_int_threads(threads_arg);
            SceneDef def = scene_of(scene);
            if (const auto b = backend_here(backend_arg, "Simulation: backend")) def.solver.backend = *b;
            return std::make_unique<PySimulation>(def, app::thread_count(threads, "threads="));
          }),
          py::arg("scene"), py::arg("threads") = 0, py::arg("backend") = py::none(),
          "Builds the model of `scene` (an mca.Scene or a scene file's path) with `threads` worker threads (0: all "
          "cores; more than the cores: the cores), stepped by `backend`: \"auto\", \"cpu\", \"cuda\" (an NVIDIA "
          "GPU) or \"cuda-emulation\" (the CUDA backend's algorithm on one core, for tests), as mca run --backend; "
          "None: the scene's solver.backend. Raises mca.Error for a scene that cannot be built, or a backend that "
          "cannot run here, with the command's message.")
      .def_static(
          "resume",
          [](Given<py_type::path> path, Given<py_type::integer> threads, Given<py_type::optional_str> backend) {
            return resume(to_path(path, "Simulation.resume: path"), to_int_threads(threads),
                          backend_here(backend, "Simulation.resume: backend"));
          },
          py::arg("path"), py::arg("threads") = 0, py::arg("backend") = py::none(),
          "Continues from a checkpoint: a .mcack file (sim.checkpoint, mca run --checkpoint-every), or a run's folder "
          "(its newest checkpoint). The file is checked as `mca resume` checks it; stepping on gives the bits an "
          "uninterrupted run gives, on any `backend` (as Simulation's; None: the one the run was on).")
      .def(
          "advance",
          [](PySimulation& s, Given<py_type::integer> steps, Given<py_type::progress> progress_arg) {
            const auto progress = py::reinterpret_borrow<py::object>(progress_arg.value);
            check_progress(progress);
            s.advance(to_whole(steps, "advance: steps", std::numeric_limits<std::int64_t>::min(),
                               std::numeric_limits<std::int64_t>::max(),
                               fmt::format("a whole number of steps, 0 to {:.0e}", static_cast<double>(Engine::kMaxSteps))),
                      progress);
          },
          py::arg("steps"), py::arg("progress") = py::none(),
          "Advances `steps` time steps on a stepping thread, without the GIL. Ctrl-C raises KeyboardInterrupt "
          "within about 0.05 s while the slice in flight (up to about 2 s of steps) ends in the background; whatever "
          "uses the simulation next waits for it, so the state is always at a whole step (advance again to go on). "
          "progress(done, total) is called after each slice, while the next one runs: it cannot read the simulation "
          "(sim.step or an array raises mca.Error), so use done and total; progress must be callable or None "
          "(checked before any step), and an exception it raises ends the advance after the slice in flight (the state "
          "at a whole step) and is raised from advance. One Simulation is used from one Python thread at a time: advance or a read "
          "from another thread while it runs raises mca.Error (it does not wait). Raises mca.Error when the run "
          "becomes unstable (the command's message; the state is the unstable step's), and when a step cannot be "
          "done (a GPU whose memory is full; the message says what to do): the simulation then steps and is read no "
          "more (mca.Error naming the step it stopped in; sim.step is the last whole step), and a state saved "
          "before (checkpoint, Simulation.resume) continues, with backend=\"cpu\".")
      .def(
          "advance_to",
          [](PySimulation& s, Given<py_type::number> time_arg, Given<py_type::progress> progress_arg) {
            const double time = to_number(time_arg, "advance_to: time", "a simulated time [s]");
            const auto progress = py::reinterpret_borrow<py::object>(progress_arg.value);
            check_progress(progress);
            const Engine& e = s.engine();
            const double dt = static_cast<double>(e.model().dt);
            if (!std::isfinite(time)) throw Error(fmt::format("advance_to({}): not a finite time", time));
            // (A time before the run's start is a mistake, a sign or a unit, not a time that has passed.)
            if (time < 0)
              throw Error(fmt::format("advance_to({}): a simulated time is 0 or more (a run starts at t = 0)", time));
            const double steps = std::round((time - e.time()) / dt);
            if (steps > static_cast<double>(Engine::kMaxSteps))
              throw Error(fmt::format("advance_to({}): {:.3g} steps of {:.4g} s would not end; give an earlier time",
                                      time, steps, dt));
            s.advance(steps > 0 ? static_cast<std::int64_t>(steps) : 0, progress);
          },
          py::arg("time"), py::arg("progress") = py::none(),
          "Advances to the step nearest the simulated time `time` [s] (nothing when it has passed; a negative time "
          "raises mca.Error); as advance.")
      .def_property_readonly("step", [](const PySimulation& s) { return s.engine().step(); }, "steps taken")
      .def_property_readonly("time", [](const PySimulation& s) { return s.engine().time(); }, "simulated time [s]")
      .def_property_readonly("time_step", [](const PySimulation& s) { return static_cast<double>(s.engine().model().dt); },
                             "the time step [s]")
      .def_property_readonly("steps_per_frame", [](const PySimulation& s) { return s.engine().steps_per_frame(); },
                             "steps in one output frame of the scene's frame rate")
      .def_property_readonly("total_steps", [](const PySimulation& s) { return s.total_steps(); },
                             "the run's steps: the scene's output.duration's; for a Simulation resumed from a "
                             "checkpoint, those of the run it was saved from (mca run --steps N: N)")
      .def_property_readonly("automata", [](const PySimulation& s) { return s.engine().model().size(); },
                             "automata in the model")
      .def_property_readonly("link_count", [](const PySimulation& s) { return s.engine().model().link_count(); },
                             "links at the start (intact and broken)")
      .def_property_readonly("threads", &PySimulation::threads,
                             "worker threads (threads=0 gives every core; more than the machine's cores are cut to "
                             "them): the cpu backend steps on them; cuda-emulation "
                             "steps on one core, cuda on the GPU (see backend)")
      .def_property_readonly("backend", [](const PySimulation& s) { return s.engine().backend().name(); },
                             "the backend stepping the model")
      .def_property_readonly("scene", [](const PySimulation& s) { return PyScene::from_def(s.engine().scene()); },
                             "a copy of the scene as built (changing it changes nothing here)")
      .def(
          "positions", [](const PySimulation& s) { return vec3_array(s.engine().state().x); },
          "Automaton centres [m]: (N, 3) float64, a copy.")
      .def(
          "velocities", [](const PySimulation& s) { return vec3_array(s.engine().state().v); },
          "Automaton velocities [m/s] (the integrator's half-step velocities, as the VTK frames): (N, 3) float64, a copy.")
      .def(
          "angular_velocities", [](const PySimulation& s) { return vec3_array(s.engine().state().w); },
          "Angular velocities [rad/s]: (N, 3) float64, a copy.")
      .def(
          "rotations",
          [](const PySimulation& s) {
            const auto& q = s.engine().state().q;
            return copy_of(reinterpret_cast<const float*>(q.data()), {static_cast<py::ssize_t>(q.size()), 4});
          },
          "Orientations as unit quaternions (w, x, y, z): (N, 4) float32 (the state's own precision), a copy.")
      .def(
          "damage",
          [](const PySimulation& s) {
            const Engine& e = s.engine();
            py::array_t<float> a(static_cast<py::ssize_t>(e.model().size()));
            automaton_damage(e.model(), e.state().intact.data(),
                             e.state().link_damage.empty() ? nullptr : e.state().link_damage.data(), a.mutable_data());
            return a;
          },
          "Share of each automaton's links that broke: (N,) float32 in [0, 1], a copy.")
      .def(
          "fragment_ids",
          [](const PySimulation& s) {
            const Engine& e = s.engine();
            const auto f = analysis::label_model_fragments(e.model(), e.state().intact.data());
            return copy_of(f.id.data(), {static_cast<py::ssize_t>(f.id.size())});
          },
          "Fragment of each automaton (connected by intact links; 0 = the heaviest, as the VTK frames and "
          "fragments.csv): (N,) int32, a copy.")
      .def(
          "strength_class", [](const PySimulation& s) { return view_of(s.shared(), s.engine().model().strength_class); },
          "Strength class 1..4 of each automaton: (N,) uint8, a read-only view of the model.")
      .def(
          "masses", [](const PySimulation& s) { return view_of(s.shared(), s.engine().model().mass); },
          "Automaton masses [kg]: (N,) float32, a read-only view of the model.")
      .def(
          "object_ids", [](const PySimulation& s) { return view_of(s.shared(), s.engine().model().object); },
          "Index of the scene object of each automaton: (N,) int32, a read-only view of the model.")
      .def(
          "links",
          [](const PySimulation& s) {
            const Engine& e = s.engine();
            const Model& md = e.model();
            const auto& intact = e.state().intact;
            std::vector<std::uint32_t> pairs;
            pairs.reserve(2 * md.link_count());
            md.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int) {
              if (intact[l]) {
                pairs.push_back(i);
                pairs.push_back(j);
              }
            });
            return copy_of(pairs.data(), {static_cast<py::ssize_t>(pairs.size() / 2), 2});
          },
          "The intact links as automaton pairs (i < j): (L, 2) uint32, a copy.")
      .def(
          "broken_links",
          [](const PySimulation& s) {
            const State& st = s.engine().state();
            py::dict d;
            d["displacement"] = st.broken_by[0];
            d["stress"] = st.broken_by[1];
            d["total"] = st.broken_by[0] + st.broken_by[1];
            return d;
          },
          "Links broken so far by criterion, as summary.json's broken_links: {displacement, stress, total}.")
      .def(
          "projectiles",
          [](const PySimulation& s) {
            const Engine& e = s.engine();
            const Model& md = e.model();
            const State& st = e.state();
            const auto n = static_cast<py::ssize_t>(md.projectiles.size());
            py::list names;
            py::array_t<double> pos({n, py::ssize_t{3}}), vel({n, py::ssize_t{3}}), ang({n, py::ssize_t{3}});
            py::array_t<double> radius(n), mass(n);
            auto P = pos.mutable_unchecked<2>();
            auto V = vel.mutable_unchecked<2>();
            auto W = ang.mutable_unchecked<2>();
            for (py::ssize_t p = 0; p < n; ++p) {
              const auto& ps = st.projectiles[static_cast<std::size_t>(p)];
              const auto& pm = md.projectiles[static_cast<std::size_t>(p)];
              names.append(pm.name);
              const double xyz[3][3] = {{ps.position.x, ps.position.y, ps.position.z},
                                        {ps.velocity.x, ps.velocity.y, ps.velocity.z},
                                        {ps.angular_velocity.x, ps.angular_velocity.y, ps.angular_velocity.z}};
              for (int k = 0; k < 3; ++k) {
                P(p, k) = xyz[0][k];
                V(p, k) = xyz[1][k];
                W(p, k) = xyz[2][k];
              }
              radius.mutable_at(p) = pm.radius;
              mass.mutable_at(p) = pm.mass;
            }
            py::dict d;
            d["name"] = names;
            d["position"] = pos;
            d["velocity"] = vel;
            d["angular_velocity"] = ang;
            d["radius"] = radius;
            d["mass"] = mass;
            return d;
          },
          "The projectiles: {name: list of P str, position, velocity, angular_velocity: (P, 3) float64, radius, mass: "
          "(P,) float64}, copies.")
      .def(
          "energies",
          [](const PySimulation& s) {
            const Engine& e = s.engine();
            const Energies en = e.energies();
            py::dict d;
            d["kinetic"] = en.kinetic;
            d["elastic"] = en.elastic;
            d["contact"] = en.contact;
            d["projectile_kinetic"] = en.projectile_kinetic;
            d["gravity_work"] = en.gravity_work;
            d["grip_work"] = en.grip_work;
            d["load_work"] = en.load_work;
            d["projectile_work"] = en.projectile_work;
            d["initial"] = e.state().initial_energy;
            d["total"] = en.total();
            d["balance"] = en.total() - en.external_work();
            return d;
          },
          "Energies and works [J], summary.json's \"energy\" (with total = kinetic + elastic + projectile_kinetic).")
      .def(
          "fragments",
          [](const PySimulation& s) {
            const Engine& e = s.engine();
            const Model& md = e.model();
            const State& st = e.state();
            const auto frags = analysis::label_model_fragments(md, st.intact.data());
            const auto infos = analysis::describe_fragments(frags, md.mass.data(),
                                                            reinterpret_cast<const double*>(st.x.data()),
                                                            reinterpret_cast<const double*>(st.v.data()), md.volume.data());
            const auto n = static_cast<py::ssize_t>(infos.size());
            py::array_t<std::int32_t> id(n);
            py::array_t<std::int64_t> automata(n);
            std::vector<py::array_t<double>> cols;
            const char* names[] = {"mass",       "volume",     "centre_x",   "centre_y",   "centre_z",   "velocity_x",
                                   "velocity_y", "velocity_z", "box_min_x",  "box_min_y",  "box_min_z",  "box_max_x",
                                   "box_max_y",  "box_max_z"};
            for (std::size_t c = 0; c < 14; ++c) cols.emplace_back(n);
            for (py::ssize_t k = 0; k < n; ++k) {
              const auto& f = infos[static_cast<std::size_t>(k)];
              id.mutable_at(k) = f.id;
              automata.mutable_at(k) = f.automata;
              const double v[14] = {f.mass,       f.volume,     f.centre[0],  f.centre[1],  f.centre[2],
                                    f.velocity[0], f.velocity[1], f.velocity[2], f.box_min[0], f.box_min[1],
                                    f.box_min[2], f.box_max[0], f.box_max[1], f.box_max[2]};
              for (std::size_t c = 0; c < 14; ++c) cols[c].mutable_at(k) = v[c];
            }
            py::dict d;
            d["id"] = id;
            d["automata"] = automata;
            for (std::size_t c = 0; c < 14; ++c) d[names[c]] = cols[c];
            return d;
          },
          "Every fragment, heaviest first: the columns of fragments.csv by name (id int32, automata int64, the rest "
          "float64), each a (F,) array, copies.")
      .def(
          "state_hash", [](const PySimulation& s) { return hash_text(s.engine().state()); },
          "The FNV-1a hash of the whole state as 16 hex digits, summary.json's state_hash (equal hashes: bitwise "
          "equal states).")
      .def(
          "write_frame",
          [](PySimulation& s, Given<py_type::path> out) { return write_frame(s, to_path(out, "write_frame: out")); },
          py::arg("out"),
          "Writes the state as the next frame of the folder `out`, as `mca run --out` writes a frame: "
          "frames/automata_NNNNNN.vtu, projectiles, the .pvd collections, the bound surface (output.surface), a row "
          "of stats.csv. The first call for a folder numbers from 0, refuses what mca run refuses (a folder of "
          "another program's files of a run's names, a run that did not finish, a subfolder that is a link), "
          "writes scene.toml and removes what an earlier run left there (frames, stats, summary, fragments, "
          "checkpoints, pictures); the folder (however it is spelt) stays locked (as a run's) until another "
          "folder is given and passes these checks, close_output() or the Simulation goes; giving the first folder again starts it afresh "
          "(frame 0, its earlier frames and stats removed). A Simulation resumed from a run folder's newest checkpoint "
          "(Simulation.resume(folder)) goes on in that folder instead, as mca resume does: it writes the run's frames on "
          "its clock (frame k at step k x steps_per_frame, up to total_steps; another step is refused, naming the "
          "one to write at) from the checkpoint's (whose own frame is the resumed state: write_frame before advancing "
          "returns its number), and what the run wrote past the checkpoint (frames, rows, its end, the plots) is "
          "replaced; its pictures stop (write_frame draws none). Returns the frame number.")
      .def(
          "close_output",
          [](PySimulation& s, Given<py_type::boolean> finish, Given<py_type::progress> progress_arg) {
            const auto progress = py::reinterpret_borrow<py::object>(progress_arg.value);
            check_progress(progress);
            if (s.finishing()) s.refuse_while_busy();  // (another thread writes the run's end with its writer)
            if (to_bool(finish, "close_output: finish", "True or False")) finish_output(s, progress);
            s.output.reset();
          },
          py::arg("finish") = false, py::arg("progress") = py::none(),
          "Releases the folder of write_frame (its files stay). finish=True first writes the run's end as mca run "
          "does after its last frame, from the state of the last frame written (write_frame it first): summary.json "
          "(status \"finished\": the run ends where the script ends it, whatever output.duration says), fragments.csv "
          "and, with output.fragments, the fragment meshes; the folder is then a finished run to the Blender importer "
          "and to mca. The meshes (a shattered object's thousands of pieces take a minute) are made on a thread of "
          "their own with the Simulation's threads: progress(meshes written, meshes) is called as they are written, "
          "and Ctrl-C raises KeyboardInterrupt within the piece being meshed; the folder then stays open without its "
          "summary.json, and close_output(finish=True) again writes the end whole.")
      .def(
          "checkpoint",
          [](PySimulation& s, Given<py_type::path> path) { checkpoint(s, to_path(path, "checkpoint: path")); },
          py::arg("path"),
          "Saves the scene and the whole state to the file `path` (.mcack, the command's format; not a folder); Simulation.resume(path) "
          "continues bitwise as if uninterrupted. `mca resume` continues it in a run folder when it was saved at a "
          "frame's end (step a multiple of steps_per_frame).")
      .def(
          "_bench_advance",
          [](PySimulation& s, std::int64_t steps, int pairs) {
            py::list out;
            for (const auto& p : s.bench_advance(steps, pairs))
              out.append(py::make_tuple(p.module_wall, p.command_wall, p.module_cpu, p.command_cpu));
            return out;
          },
          py::arg("steps"), py::arg("pairs"),
           "For bench/python_overhead.py: from the state now, uploaded again before each timed run as `mca bench` "
           "does, `pairs` times: advance(steps) as from Python, then one Engine::advance(steps) as `mca bench` "
           "times it. Returns [(module_wall, command_wall, module_cpu, command_cpu), ...] in seconds (cpu: the process's "
           "CPU time).")
      .def("__repr__", [](const PySimulation& s) {
        if (s.advancing()) {  // (the scene and the model do not change while it steps; its step does)
          const Engine& e = *s.shared();
          return fmt::format("<mca.Simulation {}: {} automata, advancing, {} threads>", text::quoted(e.scene().name),
                             e.model().size(), s.threads());
        }
        const Engine& e = s.engine();
        return fmt::format("<mca.Simulation {}: {} automata, step {} (t = {:.6g} s), {} threads{}>",
                           text::quoted(e.scene().name), e.model().size(), e.step(), e.time(), s.threads(),
                           e.backend().stopped().empty() ? "" : ", stopped: it can no longer step or be read");
      });

  m.def("render", &render_to, py::arg("sim"), py::arg("path") = py::none(), py::arg("colour") = "fragment",
        py::arg("draw") = py::none(), py::arg("size") = py::make_tuple(1280, 720),
        "Draws the simulation's state with the renderer of `mca run --render` (OpenGL through EGL: offscreen, no "
        "display needed) from the run's camera (the scene's [camera], else framed on the starting state). colour: "
        "fragment, damage, class, group, stress or speed; draw: cubes, spheres, surface or links (default: surface "
        "with a mesh object, else cubes); size: (width, height). Writes a PNG to `path` when given; returns the "
        "picture as (height, width, 4) uint8 RGBA, top row first. `path` is a file name ending in .png (a folder or "
        "another extension is refused).");
}

}  // namespace mca::python
