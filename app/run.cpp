// `mca run` and `mca resume`: step a scene frame by frame, write outputs, show progress.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <optional>
#include <fstream>
#include <string_view>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <sys/resource.h>
#include <unistd.h>

#include "app/commands.hpp"
#include "app/frame_output.hpp"
#include "app/render_output.hpp"
#include "app/run_folder.hpp"
#include "backend/backend.hpp"
#include "backend/cuda/device_memory.hpp"
#include "core/files.hpp"
#include "core/text.hpp"
#include "analysis/crack_isotropy.hpp"
#include "io/checkpoint.hpp"
#include "io/json_text.hpp"
#include "io/measures_json.hpp"
#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "sim/engine.hpp"
#include "sim/state_check.hpp"

namespace mca::app {
namespace {

// The signal that stops the run (or the view), 0 while none came: SIGINT (Ctrl-C), SIGTERM (kill, a batch
// system's time limit) and SIGHUP (the terminal closed) alike end a run at the next chunk of steps with its
// summary, and with a checkpoint when at a frame's end.
std::atomic<int> g_stop_signal{0};
static_assert(std::atomic<int>::is_always_lock_free, "set from a signal handler");
extern "C" void on_stop_signal(int sig) { g_stop_signal = sig; }

}  // namespace

const std::atomic<int>& catch_stop_signals() {
  for (const int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, on_stop_signal);
  return g_stop_signal;
}

std::string_view signal_name(int sig) {
  switch (sig) {
    case SIGINT: return "SIGINT (Ctrl-C)";
    case SIGTERM: return "SIGTERM";
    case SIGHUP: return "SIGHUP (the terminal closed)";
    default: return "a signal";
  }
}

namespace {

// The build of the model (a mesh fill or a large lattice can take minutes) does not look at g_stop_signal:
// a signal then ends the process at once, saying so (it used to end it without a word). Nothing of the run
// has been written by then; a resumed run's folder is as it was, and the folders a new run made for its
// output are removed again (rmdir is async-signal-safe, and removes only a folder that is empty).
std::vector<std::string> g_made_for_the_run;  // deepest first; set before the handler, read only by it
extern "C" void on_build_signal(int sig) {
  // (Every one: "out/" and "a/./b" list a folder twice, and a name that fails is no reason to keep the rest.)
  for (const std::string& folder : g_made_for_the_run) rmdir(folder.c_str());
  static const char kMessage[] = "\nmca: stopped by a signal while building the model, before the first step; "
                                 "nothing was written\n";
  if (write(STDERR_FILENO, kMessage, sizeof kMessage - 1) < 0) {
  }
  _exit(128 + sig);
}
// While one lives, SIGINT, SIGTERM and SIGHUP end a build as above, removing the (empty) folders `made`;
// then their default action again, until run_loop takes them.
struct BuildSignals {
  explicit BuildSignals(const std::vector<std::filesystem::path>& made = {}) {
    g_made_for_the_run.assign(made.begin(), made.end());
    for (const int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, on_build_signal);
  }
  ~BuildSignals() {
    for (const int sig : {SIGINT, SIGTERM, SIGHUP}) std::signal(sig, SIG_DFL);
    g_made_for_the_run.clear();
  }
  BuildSignals(const BuildSignals&) = delete;
  BuildSignals& operator=(const BuildSignals&) = delete;
};

// Progress and the messages of a stopped run go to stderr without throwing: after SIGHUP the terminal is
// gone and writes to it fail (EIO), where fmt::print would throw past the summary and the checkpoint.
template <class... A>
void say(fmt::format_string<A...> f, A&&... a) {
  const std::string s = fmt::format(f, std::forward<A>(a)...);
  std::fwrite(s.data(), 1, s.size(), stderr);
}

std::string human_time(double s) {
  if (s < 60) return fmt::format("{:.0f}s", s);
  if (s < 3600) return fmt::format("{:.0f}m{:02.0f}s", std::floor(s / 60), std::fmod(s, 60));
  return fmt::format("{:.0f}h{:02.0f}m", std::floor(s / 3600), std::fmod(s / 60, 60));
}


constexpr std::int64_t kMaxSteps = Engine::kMaxSteps;

// `steps` is checked against kMaxSteps by run(), before the model is built.
Plan make_plan(const Engine& sim, const std::optional<std::int64_t>& steps) {
  // (The Engine refuses durations past kMaxSteps when it builds the model.)
  return plan_of(steps ? *steps : sim.total_steps(), sim.steps_per_frame());
}

// The frame clock of a checkpoint: the run writes frame k at step min(k * spf, total_steps) and saves a
// checkpoint right after a frame, with `frame` the count of frames written. Counters that disagree
// (a damaged or edited file) would make resume list or write absurd numbers of frames.
Plan resume_plan(const io::Checkpoint& cp, int spf, const std::string& source, std::string_view between_frames) {
  const auto fail = [&](const std::string& what) {
    return Error(fmt::format("{}: {}; the file is damaged or was edited: use an earlier checkpoint (remove this "
                             "one) or start the run again",
                             source, what));
  };
  if (cp.total_steps <= 0 || cp.total_steps > kMaxSteps)
    throw fail(fmt::format("the run's step count {} is outside 1..{}", cp.total_steps, kMaxSteps));
  const Plan p = plan_of(cp.total_steps, spf);
  if (cp.frame < 1 || cp.frame - 1 > p.total_frames)
    throw fail(fmt::format("frame {} is outside the run's frames 0..{}", cp.frame - 1, p.total_frames));
  const std::int64_t step = std::min(p.total_steps, (cp.frame - 1) * spf);
  // A state between two frames is a checkpoint the Python module saved where its user stopped
  // (mca.Simulation.checkpoint), not a damaged one: mca resume continues a run from a frame.
  if (cp.state.step != step && cp.state.step > 0 && cp.state.step < p.total_steps && cp.state.step % spf != 0)
    throw Error(fmt::format("{}: its state is at step {}, between frames {} and {} (steps {} and {}): it was saved "
                            "between frames (by mca.Simulation.checkpoint), and {}",
                            source, cp.state.step, cp.state.step / spf, cp.state.step / spf + 1,
                            cp.state.step / spf * spf, std::min(p.total_steps, (cp.state.step / spf + 1) * spf),
                            between_frames.empty()
                                ? "mca resume continues a run from the end of a frame; continue it with "
                                  "mca.Simulation.resume in Python (writing its frames into another folder), or "
                                  "remove it to resume from the checkpoint before"
                                : between_frames));
  if (cp.state.step != step)
    throw fail(fmt::format("its state is at step {}, but frame {} is at step {}", cp.state.step, cp.frame - 1, step));
  if (!(cp.wall_seconds >= 0 && cp.wall_seconds <= 1e10))  // (1e10 s: three centuries)
    throw fail(fmt::format("the wall time {} s is outside 0..1e10 s", cp.wall_seconds));
  return p;
}

}  // namespace

Plan plan_of(std::int64_t total_steps, std::int64_t steps_per_frame) {
  Plan p;
  p.total_steps = total_steps;
  // Rounded up without forming total_steps + steps_per_frame - 1.
  p.total_frames = total_steps / steps_per_frame + (total_steps % steps_per_frame != 0);
  return p;
}

// Every fragment, heaviest first: one row each (the summary lists the largest).
void write_fragments_csv(const std::filesystem::path& path, const std::vector<analysis::FragmentInfo>& infos) {
  io::write_file_atomic(
      path,
      [&](std::ostream& os) {
        fmt::memory_buffer b;
        fmt::format_to(std::back_inserter(b),
                       "id,automata,mass,volume,centre_x,centre_y,centre_z,velocity_x,velocity_y,velocity_z,box_min_x,"
                       "box_min_y,box_min_z,box_max_x,box_max_y,box_max_z\n");
        for (const auto& f : infos) {
          // Shortest round-trip form of each double: 9 digits made a centre 1e6 m out (the documented
          // range) 1000000.00, and a velocity of 2,000 m/s lost its last 5e-5.
          fmt::format_to(std::back_inserter(b), "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
                         f.id, f.automata, f.mass, f.volume, f.centre[0], f.centre[1], f.centre[2], f.velocity[0],
                         f.velocity[1], f.velocity[2], f.box_min[0], f.box_min[1], f.box_min[2], f.box_max[0],
                         f.box_max[1], f.box_max[2]);
          // (In pieces: a row is about 300 bytes, and a body in 10^6 pieces held 300 MB of them at once.)
          if (b.size() >= (1u << 20)) {
            os.write(b.data(), static_cast<std::streamsize>(b.size()));
            b.clear();
          }
        }
        os.write(b.data(), static_cast<std::streamsize>(b.size()));
      },
      false);
}

// `wall_before`: the wall seconds of the sessions before this one (a resume's checkpoint); `session_wall`
// and `session_steps`: this session's own, which give the rate (the steps of a resume over the whole
// wall time would understate it by the share of the earlier sessions).
// `resumed_from`: the checkpoint this session started from (a resume), else empty; the scene of a resumed
// run is its folder's scene.toml (which the checkpoint's was checked to be).
void write_summary(const std::filesystem::path& dir, const Engine& sim, const analysis::Fragments& frags,
                   double wall_before, double session_wall, std::int64_t session_steps, int threads,
                   const std::string& status, const std::filesystem::path& resumed_from) {
  const double wall = wall_before + session_wall;
  const Model& m = sim.model();
  const State& s = sim.state();
  nlohmann::json j;
  j["scene"] = sim.scene().name;
  j["scene_file"] = resumed_from.empty() ? sim.scene().source : (dir / "scene.toml").string();
  if (!resumed_from.empty()) j["resumed_from"] = resumed_from.string();
  j["status"] = status;
  j["automata"] = m.size();
  j["links"] = m.link_count();
  j["spacing"] = m.spacing;
  j["time_step"] = m.dt;
  j["steps"] = s.step;
  j["steps_per_frame"] = sim.steps_per_frame();
  j["simulated_time"] = s.time;
  j["threads"] = threads;  // (the worker threads: the CPU backend's step, the frames' analysis and files)
  j["backend"] = sim.backend().name();
  j["steps_run_on"] = steps_run_on(sim.backend().name(), threads);  // (this session's, as its closing line says)
  j["wall_seconds"] = wall;
  j["session_steps"] = session_steps;
  j["session_wall_seconds"] = session_wall;
  // The process's peak resident memory so far (compare with `mca info`'s estimate).
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  j["peak_memory_bytes"] = static_cast<std::int64_t>(usage.ru_maxrss) * 1024;
  j["automaton_steps_per_second"] =
      session_wall > 0 ? static_cast<double>(session_steps) * static_cast<double>(m.size()) / session_wall : 0.0;
  j["broken_links"] = {{"displacement", s.broken_by[0]}, {"stress", s.broken_by[1]},
                       {"total", s.broken_by[0] + s.broken_by[1]}};
  j["intact_links"] = m.link_count() - static_cast<std::size_t>(s.broken_by[0] + s.broken_by[1]);
  static_assert(sizeof(DVec3) == 3 * sizeof(double), "DVec3 arrays are read as three doubles each");
  const auto infos = analysis::describe_fragments(frags, m.mass.data(), reinterpret_cast<const double*>(s.x.data()),
                                                  reinterpret_cast<const double*>(s.v.data()), m.volume.data());
  const Energies e = sim.energies();
  j["energy"] = {{"kinetic", e.kinetic},
                 {"elastic", e.elastic},
                 {"contact", e.contact},
                 {"projectile_kinetic", e.projectile_kinetic},
                 {"gravity_work", e.gravity_work},
                 {"grip_work", e.grip_work},
                 {"load_work", e.load_work},
                 {"projectile_work", e.projectile_work},
                 {"initial", s.initial_energy},
                 {"balance", e.total() - e.external_work()}};
  j["total_mass"] = m.total_mass;
  j["fragment_count"] = frags.count;
  // The summary stays short (a shattered run has 10^3 to 10^5 fragments): the largest ones, the rest
  // summed up, and the mass by fragment size; every fragment is in fragments.csv.
  constexpr std::size_t kListed = 20;
  nlohmann::json list = nlohmann::json::array();
  double rest_mass = 0;
  std::int64_t rest_automata = 0;
  for (const auto& f : infos) {
    if (list.size() < kListed) {
      list.push_back({{"id", f.id}, {"automata", f.automata}, {"mass", f.mass}, {"volume", f.volume},
                      {"centre", f.centre}, {"velocity", f.velocity}, {"box_min", f.box_min}, {"box_max", f.box_max}});
    } else {
      rest_mass += f.mass;
      rest_automata += f.automata;
    }
  }
  j["fragments"] = list;
  j["unlisted_fragments"] = {{"count", infos.size() > kListed ? infos.size() - kListed : 0},
                             {"automata", rest_automata}, {"mass", rest_mass}};
  nlohmann::json bins = nlohmann::json::array();
  for (const auto& b : analysis::fragment_size_bins(infos))
    bins.push_back({{"automata_min", b.automata_min}, {"automata_max", b.automata_max}, {"fragments", b.fragments},
                    {"mass", b.mass}});
  j["fragment_sizes"] = bins;
  // Issue 21's two measures, as tools/fracture_metrics.py computes them from the folder (both cost one
  // pass over the automata): the log-binned mass distribution with its power-law fit, and the damage
  // around the impact by 45-degree sector.
  j["fragment_mass_distribution"] = io::mass_distribution_json(analysis::fragment_mass_distribution(infos));
  j["crack_isotropy"] = io::crack_isotropy_json(analysis::crack_isotropy(m, sim.scene(), s.intact.data(),
                                                                              s.link_damage.empty() ? nullptr : s.link_damage.data()));
  j["fragments_file"] = "fragments.csv";
  write_fragments_csv(dir / "fragments.csv", infos);
  nlohmann::json proj = nlohmann::json::array();
  for (std::size_t p = 0; p < m.projectiles.size(); ++p) {
    const auto& ps = s.projectiles[p];
    proj.push_back({{"name", m.projectiles[p].name},
                    {"position", {ps.position.x, ps.position.y, ps.position.z}},
                    {"velocity", {ps.velocity.x, ps.velocity.y, ps.velocity.z}}});
  }
  j["projectiles"] = proj;
  j["state_hash"] = fmt::format("{:016x}", state_hash(s));
  io::write_file_atomic(dir / "summary.json", [&](std::ostream& os) { os << io::json_text(j) << "\n"; }, false);
}

namespace {

// What a run writes at its end from its last state (the summary also when interrupted): the summary,
// fragments.csv, the fragment meshes and (`plots`) the plots of tools/plot_run.py. One left by an earlier
// session describes a state the folder no longer ends at, so a new run and a resume remove them before they
// step: a resume that stops on an error, like a new run, then leaves none. Sets them aside in `removal`
// (`plots`: the plots too); returns the plots set aside.
std::size_t stage_end_outputs(io::StagedRemoval& removal, const std::filesystem::path& dir, bool plots) {
  stage_run_files(removal, dir, {RunPart::end});
  return plots ? stage_run_files(removal, dir, {RunPart::plots}) : 0;
}

// FrameWriter::recover_folder, what it says on stderr.
void recover_folder(const std::filesystem::path& dir, bool quiet) {
  for (const std::string& said : FrameWriter::recover_folder(dir))
    if (!quiet) fmt::print(stderr, "mca: {}\n", said);
}

// What a session writes (`frames` more, pictures of render_width x render_height, 0 for none) must fit the
// disk in `dir`, and its peak the memory (check_output_fits, check_memory_fits); returns the disk estimate.
OutputEstimate check_run_fits(const Engine& sim, const SceneDef& scene, std::int64_t frames, int render_width,
                              int render_height, const std::filesystem::path& dir) {
  const Model& m = sim.model();
  const OutputEstimate estimate = estimate_output(m, scene.output, frames, render_width, render_height);
  check_output_fits(estimate, dir, scene);
  MemoryEstimate memory = estimate_memory(m, scene.output, render_width, render_height);
  memory.emulated_gpu = emulated_gpu_bytes(sim.backend().name(), gpu::DeviceMemory::held());
  check_memory_fits(memory, scene);
  return estimate;
}

// Whether `line` is a whole stats.csv row of `frame`: its frame number first, then numbers, as many cells
// as the header.
bool whole_stats_row(const std::string& line, std::int64_t frame, std::size_t cells) {
  std::size_t n = 0, at = 0;
  for (;;) {
    const std::size_t end = std::min(line.find(',', at), line.size());
    const std::string cell = line.substr(at, end - at);
    char* stop = nullptr;
    const double v = std::strtod(cell.c_str(), &stop);
    if (cell.empty() || stop != cell.c_str() + cell.size()) return false;
    if (n == 0 && v != static_cast<double>(frame)) return false;
    ++n;
    if (end == line.size()) break;
    at = end + 1;
  }
  return n == cells;
}

// The first `frames` data rows of an earlier run's stats.csv (for resume), each a whole row of its frame
// (whole_stats_row, ended by a line break). Rows past the checkpoint (a run stopped after a frame's row
// and before its checkpoint) are left out, and so are a row cut short (a write interrupted by a full disk
// or a crash) and whatever follows it.
std::vector<std::string> read_back_stats(const std::filesystem::path& dir, std::int64_t frames, std::size_t cells) {
  // A FIFO blocked the resume for ever, a link to /dev/zero read without end.
  files::require_regular_file(dir / "stats.csv", "the run's stats file",
                              "remove it: the resume writes stats.csv again, from the checkpoint's state for its own "
                              "frame");
  std::ifstream in(dir / "stats.csv", std::ios::binary);
  std::vector<std::string> rows;
  std::string line;
  if (!std::getline(in, line)) return rows;  // header
  // A row ended by CR LF (the file saved by an editor or spreadsheet that writes them) is the same row.
  auto without_cr = [](std::string& l) -> std::string& {
    if (!l.empty() && l.back() == '\r') l.pop_back();
    return l;
  };
  while (static_cast<std::int64_t>(rows.size()) < frames && std::getline(in, line) && !in.eof() &&
         whole_stats_row(without_cr(line), static_cast<std::int64_t>(rows.size()), cells))
    rows.push_back(line);
  return rows;
}

struct Loop {
  Engine& sim;
  std::filesystem::path dir;
  int threads;
  bool quiet;
  int checkpoint_every;
  Plan plan;
  std::int64_t frame = 0;      // frames written so far
  double wall_before = 0;      // wall seconds of earlier sessions (resume)
  RenderOutput* render = nullptr;  // --render
  bool warned_removal = false;     // an older checkpoint could not be removed (said once)
  std::filesystem::path resumed_from;  // the checkpoint a resume started from
};

void save_checkpoint(Loop& L, FrameWriter& writer, double wall) {
  writer.sync_stats();  // the rows up to it first: a resume from it reads them back
  const auto ckdir = io::output_subfolder(L.dir, "checkpoints");
  io::Checkpoint cp;
  cp.scene = L.sim.scene();
  cp.state = L.sim.state();
  cp.frame = L.frame;
  cp.total_steps = L.plan.total_steps;
  cp.wall_seconds = wall;
  cp.model_fingerprint = model_fingerprint(L.sim.model());
  io::write_checkpoint(ckdir / io::checkpoint_name(L.frame - 1), cp);
  // Keep the two newest: the newest may still be refused on resume (a damaged disk, an edit), and then
  // the one before is the way back.
  // One that cannot be removed (a file made immutable, a folder's permissions) costs its disk space, not
  // the run: a warning, once.
  const auto all = io::list_checkpoints(ckdir);
  for (std::size_t k = 0; k + 2 < all.size(); ++k) {
    std::error_code ec;
    if (std::filesystem::remove(all[k], ec) || !ec || L.warned_removal) continue;
    L.warned_removal = true;
    fmt::print(stderr, "{}warning: cannot remove the older checkpoint '{}' ({}); the run goes on and keeps it, "
               "with the others that cannot be removed: remove them by hand to free the disk\n",
               !L.quiet && isatty(STDERR_FILENO) ? "\n" : "", all[k].string(), ec.message());
  }
}

int run_loop(Loop& L, FrameWriter& writer) {
  Engine& sim = L.sim;
  const Model& m = sim.model();
  const bool tty = !L.quiet && isatty(STDERR_FILENO);
  const auto start = std::chrono::steady_clock::now();
  const std::int64_t first_step = sim.state().step;
  auto elapsed = [&] { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); };
  const std::atomic<int>& stop = catch_stop_signals();
  double last_print = -1;
  const int spf = sim.steps_per_frame();

  auto progress = [&](double wall, bool finished) {
    if (L.quiet || !(finished || (tty ? wall - last_print > 0.2 : wall - last_print > 10.0))) return;
    last_print = wall;
    const double done = static_cast<double>(sim.step() - first_step);
    const double left = static_cast<double>(L.plan.total_steps - sim.step());
    const double rate = wall > 0 ? done * m.size() / wall : 0;
    const double eta = done > 0 ? wall * left / done : 0;
    const double frac = static_cast<double>(sim.step()) / static_cast<double>(L.plan.total_steps);
    const int bar = static_cast<int>(frac * 30);
    say("{}[{}{}] {:3.0f}%  t={:.4g}/{:.4g} s  frame {}/{}  {:.2f} M automaton-steps/s  broken {}  ETA {}{}",
               tty ? "\r" : "", std::string(bar, '#'), std::string(30 - bar, '.'), 100 * frac, sim.time(),
               L.plan.total_steps * static_cast<double>(m.dt), L.frame - 1, L.plan.total_frames, rate / 1e6,
               sim.broken_links(), human_time(eta), tty ? "   " : "\n");
  };

  // Why no checkpoint continues the run (none saved yet, inside or writing frame `frame`), and what to do
  // instead.
  const auto no_checkpoint = [&](std::int64_t frame, const std::string& instead) {
    const std::int64_t every = L.checkpoint_every;
    return every > 0 ? fmt::format("no checkpoint was saved yet (the first at the end of frame {}): {}",
                                   (frame + every - 1) / every * every, instead)
                     : fmt::format("no checkpoint was saved (--checkpoint-every N saves them): {}", instead);
  };
  // A run stopped by an error in frame `frame` (exit 2): the message, and how the newest checkpoint continues
  // it (`fix`: what to do first; `flags`: of mca resume and of a new start).
  const auto stopped = [&](const Error& e, const std::string& where, std::int64_t frame, const std::string& fix,
                           const std::string& flags) {
    const auto saved = io::list_checkpoints(L.dir / "checkpoints");
    if (tty) fmt::print(stderr, "\n");
    fmt::print(stderr, "error: {}\nThe run stopped {}; {}\n", e.what(), where,
               !saved.empty() ? fmt::format("{}continue it from the newest checkpoint ({}) with:\n  mca resume {}{}", fix,
                                            saved.back().filename().string(), text::shell_word(L.dir.string()), flags)
                              : no_checkpoint(frame, fix + (flags.empty() ? "start it again"
                                                                          : "start it again with" + flags)));
    return 2;
  };
  // Steps go to the engine in chunks of about a quarter of a second, so that a long frame (up to 1e9
  // steps) still shows progress and answers Ctrl-C; how steps are grouped into calls changes no result.
  std::int64_t chunk = 16;
  while (sim.step() < L.plan.total_steps) {
    const std::int64_t frame_end = std::min(L.plan.total_steps, sim.step() + spf);
    StepHealth h;
    while (sim.step() < frame_end && h.flags == kHealthy) {
      const auto t0 = std::chrono::steady_clock::now();
      try {
        h = sim.advance(static_cast<int>(std::min(chunk, frame_end - sim.step())));
      } catch (const Error& e) {
        // The machine refused a step (a GPU whose memory is full): the state is part of a step, so no
        // summary or checkpoint is written from it; the newest checkpoint continues the run.
        return stopped(e, fmt::format("inside frame {}", L.frame), L.frame, "", " --backend cpu");
      }
      const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (took < 0.1 && chunk < (std::int64_t{1} << 30)) chunk *= 2;
      else if (took > 0.5 && chunk > 1) chunk /= 2;
      if (const int sig = stop; sig != 0 && h.flags == kHealthy && sim.step() < frame_end) {
        // Checkpoints hold frame boundaries only: stop here, and point to the newest one.
        const auto saved = io::list_checkpoints(L.dir / "checkpoints");
        write_summary(L.dir, sim, writer.fragments(sim.state()), L.wall_before, elapsed(),
                      sim.state().step - first_step, L.threads, "interrupted", L.resumed_from);
        say("{}interrupted by {} inside frame {} (step {} of the run); checkpoints are saved at frame ends only, so "
            "{}\n",
            tty ? "\n" : "", signal_name(sig), L.frame, sim.state().step,
            saved.empty() ? no_checkpoint(L.frame, "start the run again")
                          : fmt::format("continue from the newest ({}) with: mca resume {}",
                                        saved.back().filename().string(), text::shell_word(L.dir.string())));
        return 128 + sig;
      }
      progress(elapsed(), false);
    }
    const auto frags = writer.fragments(sim.state());
    FrameStats st = writer.stats(L.frame, sim.state(), frags);
    if (h.flags != kHealthy) {
      if (tty) fmt::print(stderr, "\n");
      fmt::print(stderr, "error: {}. The last good frame ({}) is on disk in {}.\n", instability_message(sim, h),
                 L.frame - 1, L.dir.string());
      return 3;
    }
    // A write that fails (a full disk) stops the run, naming the newest checkpoint, which continues it.
    const std::int64_t writing = L.frame;
    double wall = 0;
    try {
      writer.write_frame(L.frame, sim.state(), frags);
      if (L.render) L.render->write_frame(L.frame, sim.state(), frags);
      writer.append_stats(writer.format_row(st));
      ++L.frame;
      wall = elapsed();
      if (L.checkpoint_every > 0 && (L.frame - 1) % L.checkpoint_every == 0)
        save_checkpoint(L, writer, L.wall_before + wall);
    } catch (const Error& e) {
      return stopped(e, fmt::format("writing frame {}", writing), writing,
                     "once the disk has room (or the cause above is fixed), ", "");
    }
    progress(wall, sim.state().step >= L.plan.total_steps);
    if (const int sig = stop; sig != 0) {
      save_checkpoint(L, writer, L.wall_before + wall);
      write_summary(L.dir, sim, frags, L.wall_before, wall, sim.state().step - first_step, L.threads,
                    "interrupted", L.resumed_from);
      say("{}interrupted by {} after frame {}; a checkpoint is saved. Continue with: mca resume {}\n",
          tty ? "\n" : "", signal_name(sig), L.frame - 1, text::shell_word(L.dir.string()));
      return 128 + sig;
    }
  }
  const double wall = elapsed();
  const auto frags = writer.fragments(sim.state());
  // The end's outputs: the fragment meshes (thousands of pieces take a minute: progress, and a stop signal
  // ends them within the piece being meshed), then the summary, whose peak memory counts them.
  struct MeshesStopped {};
  std::size_t meshes = 0;
  bool meshes_done = false;
  try {
    auto shown = std::chrono::steady_clock::now();
    meshes = writer.write_fragment_meshes(sim.state(), frags, [&](std::size_t done, std::size_t total) {
      if (stop != 0) throw MeshesStopped{};
      const auto now = std::chrono::steady_clock::now();
      if (!tty || (now - shown < std::chrono::milliseconds(250) && done < total)) return;
      shown = now;
      fmt::print(stderr, "\rfragment meshes: {} of {}", done, total);
    }, [&] {
      if (stop != 0) throw MeshesStopped{};
    });
    meshes_done = true;
    write_summary(L.dir, sim, frags, L.wall_before, wall, sim.state().step - first_step, L.threads, "finished",
                  L.resumed_from);
  } catch (const MeshesStopped&) {
    const int sig = stop;
    try {
      save_checkpoint(L, writer, L.wall_before + wall);
      write_summary(L.dir, sim, frags, L.wall_before, wall, sim.state().step - first_step, L.threads,
                    "interrupted", L.resumed_from);
    } catch (const Error& e) {
      return stopped(e, "after its last step", L.frame - 1, "", "");
    }
    say("{}interrupted by {} while writing the fragment meshes, after the run's last step; a checkpoint of it "
        "is saved, and mca resume {} writes them\n",
        tty ? "\n" : "", signal_name(sig), text::shell_word(L.dir.string()));
    return 128 + sig;
  } catch (const Error& e) {
    // A fragment mesh that cannot be written (a disk that filled, the meshes past the estimate's room): the
    // run's steps are done, so its last state is kept as a checkpoint, in the room the meshes written so far
    // took, and a resume writes the end from it, as after a stop signal here.
    if (!meshes_done) {
      std::string no_checkpoint_why;
      try {
        remove_run_files(L.dir, {RunPart::end});
        save_checkpoint(L, writer, L.wall_before + wall);
      } catch (const Error& ce) {
        no_checkpoint_why = ce.what();
      }
      // (The summary and fragments.csv, where they fit, whichever way: the run's results.)
      try {
        write_summary(L.dir, sim, frags, L.wall_before, wall, sim.state().step - first_step, L.threads,
                      "interrupted", L.resumed_from);
      } catch (const Error&) {
      }
      if (no_checkpoint_why.empty()) {
        if (tty) fmt::print(stderr, "\n");
        fmt::print(stderr, "error: {}\nThe run stopped writing its fragment meshes, after its last step; those it had "
                   "written are removed, and a checkpoint of its last frame is saved: once the disk has room (or the "
                   "cause above is fixed), write them (and summary.json, fragments.csv) with:\n  mca resume {}\n",
                   e.what(), text::shell_word(L.dir.string()));
        return 2;
      }
      return stopped(e, fmt::format("writing its fragment meshes, after its last step, and could not save a "
                                    "checkpoint of its last frame either ({})",
                                    no_checkpoint_why),
                     L.frame - 1, "once the disk has room (or the cause above is fixed), ", "");
    }
    return stopped(e, "writing its end (the fragment meshes, summary.json, fragments.csv) after its last step",
                   L.frame - 1, "once the disk has room (or the cause above is fixed), ", "");
  }
  if (!L.quiet && sim.scene().output.fragments) {
    fmt::print(stderr, "{}{}\n", tty ? "\n" : "",
               meshes > 0 ? fmt::format("{} fragment meshes in fragments/", meshes)
                          : fmt::format("no fragment has more than output.fragment_min_automata = {} automata: no "
                                        "fragment mesh written",
                                        sim.scene().output.fragment_min_automata));
  }
  if (L.render) {
    if (tty) fmt::print(stderr, "\n");
    L.render->finish();
    if (stop == 0) run_plot_script(L.dir, L.quiet, stop);
  }
  // A stop signal after the last step: the run and its files are whole, what is left of its end is not made.
  if (const int sig = stop; sig != 0) {
    say("{}interrupted by {} after the run's last frame ({}): {}\n", tty ? "\n" : "", signal_name(sig), L.frame - 1,
        L.render ? fmt::format("its outputs are complete but for {}the plots in render/, not all made: python3 {} {} "
                               "makes them",
                               L.render->video_stopped() ? "the video (the command above makes it) and " : "",
                               text::shell_word(plot_script().string()), text::shell_word(L.dir.string()))
                 : std::string("its outputs are complete"));
    return 128 + sig;
  }
  if (!L.quiet) {
    const State& s = sim.state();
    fmt::print(stderr, "{}done: {}, {} in {:.1f} s ({:.2f} M automaton-steps/s on {}, backend {}); "
               "broken links {} (displacement {}, stress {}); {}.\noutput: {}\n",
               tty ? "\n" : "", text::count(m.size(), "automaton|automata"), text::count(s.step - first_step, "step"), wall,
               wall > 0 ? (s.step - first_step) * static_cast<double>(m.size()) / wall / 1e6 : 0.0,
               steps_run_on(sim.backend().name(), L.threads), sim.backend().name(), s.broken_by[0] + s.broken_by[1],
               s.broken_by[0], s.broken_by[1], text::count(frags.count, "fragment"), L.dir.string());
  }
  return 0;
}

}  // namespace

int thread_count(int requested, std::string_view given_as) {
  if (requested < 0) throw Error(fmt::format("{}{} is negative; give 0 (all cores) or a count", given_as, requested));
  // More threads than the machine runs at once would not run: the count reported is the one used.
  const int cores = tbb::info::default_concurrency();
  return requested == 0 ? cores : std::min(requested, cores);
}

std::string steps_run_on(const std::string& backend, int threads) {
  if (backend.rfind("cpu", 0) == 0) return fmt::format("{} thread{}", threads, threads == 1 ? "" : "s");
  return backend.rfind("cuda-emulation", 0) == 0 ? "one core" : "the GPU";
}

int run(const RunOptions& o) {
  if (o.out && o.out->empty())
    throw Error("--out is empty; give the output folder, or leave out --out for the default out/<scene name>");
  if (o.steps && *o.steps <= 0) throw Error(fmt::format("--steps {}: give at least one step, or leave it out", *o.steps));
  if (o.steps && *o.steps > kMaxSteps)
    throw Error(fmt::format("--steps {} is out of range: must be 1..{:.0e} (a run of more steps would not end); "
                            "give a smaller number of steps, or --duration",
                            *o.steps, static_cast<double>(kMaxSteps)));
  RenderOptions ro;
  if (o.render) {
    std::tie(ro.width, ro.height) = parse_render_size(o.render_size);
    const auto colour = render::parse_colour_mode(o.render_colour);
    if (!colour)
      throw Error(fmt::format("--render-colour '{}' is not a colour mode; give one of: {}", o.render_colour,
                              render::colour_mode_names()));
    ro.colour = *colour;
    const auto draw = render::parse_draw_mode(o.render_draw.empty() ? "cubes" : o.render_draw);
    if (!draw)
      throw Error(fmt::format("--render-draw '{}' is not a draw mode; give one of: {}", o.render_draw,
                              render::draw_mode_names()));
    ro.draw = *draw;
    if (!(o.render_fps == 0 || (o.render_fps >= 1 && o.render_fps <= 240)))
      throw Error(fmt::format("--render-fps {} is out of range: give 1 to 240 frames per second, or 0 for automatic",
                              o.render_fps));
    ro.fps = o.render_fps;
  }
  SceneDef scene = o.scene ? io::load_scene_file(*o.scene) : io::load_default_scene();
  // A mesh object is drawn as its own triangles unless asked otherwise (the automata that carry none,
  // inside a volume fill, show as cubes once exposed).
  if (o.render && o.render_draw.empty() &&
      std::any_of(scene.objects.begin(), scene.objects.end(), [](const ObjectDef& d) { return d.shape == Shape::mesh; }))
    ro.draw = render::DrawMode::surface;
  if (o.duration) {
    if (!(*o.duration > 0) || !std::isfinite(*o.duration))
      throw Error(fmt::format("--duration {} must be a positive, finite number of seconds", *o.duration));
    scene.output.duration = *o.duration;
  }
  if (o.seed) scene.solver.seed = *o.seed;
  if (o.backend) scene.solver.backend = backend_from_name(*o.backend, "--backend");
  if (o.checkpoint_every) {
    if (*o.checkpoint_every < 0)
      throw Error(fmt::format("--checkpoint-every {} must be 0 (off) or a number of frames", *o.checkpoint_every));
    scene.output.checkpoint_every = *o.checkpoint_every;
  }
  if (o.vtk) scene.output.vtk = *o.vtk;
  const int threads = thread_count(o.threads);
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  // The scene's name is shown as it is; only a sanitised form of it names the default folder.
  const std::filesystem::path dir =
      o.out ? std::filesystem::path(*o.out) : std::filesystem::path("out") / io::scene_folder_name(scene.name);
  Engine::check_environment();  // a bad MCA_SIMD is refused before anything is written
  if (o.render) render::VideoEncoder::time_limit();  // and so is a bad MCA_FFMPEG_TIMEOUT
  // The folders this run creates, removed again (when still empty) if it stops before writing anything:
  // a refused --render (no OpenGL, a camera that sees nothing) leaves no empty output folder behind.
  struct CreatedFolders {
    std::vector<std::filesystem::path> made;  // deepest first
    bool keep = false;
    ~CreatedFolders() {
      std::error_code ec;
      for (const auto& f : made)
        if (!keep && std::filesystem::is_empty(f, ec) && !ec) std::filesystem::remove(f, ec);
    }
  } created;
  {
    // (A path that cannot be examined, a name over the file system's limit or a loop of symbolic links,
    // ends the walk: prepare_output_dir reports it.)
    std::error_code ec;
    for (std::filesystem::path f = std::filesystem::absolute(dir); !f.empty(); f = f.parent_path()) {
      const bool there = std::filesystem::exists(f, ec);
      if (there || (ec && ec != std::errc::no_such_file_or_directory)) break;
      // (A name through ".." may come to be a folder that is there: new/../E is E once new is made.)
      if (f.lexically_normal() != f && std::filesystem::exists(f.lexically_normal(), ec)) continue;
      created.made.push_back(f);
    }
  }
  io::prepare_output_dir(dir);
  io::check_output_subfolders(dir, run_subfolders(scene, o.render));
  io::check_inputs_outside_subfolders(dir, mesh_inputs(scene));
  const io::OutputLock lock(dir);
  recover_folder(dir, o.quiet);
  // The run writes the scene as run to <dir>/scene.toml: never over the scene file it reads.
  if (o.scene) {
    std::error_code ec;
    if (std::filesystem::equivalent(*o.scene, dir / "scene.toml", ec))
      throw Error(fmt::format("--out {} would overwrite the scene file {} with the scene as run; give another output "
                              "folder, or rename the scene file",
                              dir.string(), *o.scene));
  }
  check_folder_is_a_runs(dir);

  if (!o.quiet) fmt::print(stderr, "mca: scene '{}' ({}): building...\n", scene.name, scene.source);
  std::optional<lattice::BuildProgress> building;
  if (!o.quiet) building.emplace();
  std::optional<BuildSignals> build_signals;
  build_signals.emplace(created.made);
  Engine sim(scene);
  build_signals.reset();
  const std::atomic<int>& stop = catch_stop_signals();  // (from here a signal is the run's to answer: the
                                                        // renderer's set-up, frame 0)
  building.reset();
  const Plan plan = make_plan(sim, o.steps);
  // What the run will write must fit the disk (frame_rate = 1e9 plans 4,000,000 frames, terabytes).
  const OutputEstimate estimate =
      check_run_fits(sim, scene, plan.total_frames + 1, o.render ? ro.width : 0, o.render ? ro.height : 0, dir);
  if (!o.quiet) {
    // Which lattice the volume fills are on (the default changed to the random one: a scene written for the
    // cubic lattice that does not say so runs on the random one).
    const Model& m = sim.model();
    const std::string name = lattice_name(m, scene.solver.lattice_jitter);
    const std::string lattice = name.empty() ? "" : fmt::format(" on the {} lattice", name);
    fmt::print(stderr, "mca: {}{}, {}, time step {:.4g} s, {} per frame, {}, {} on {}; about {} of output\n",
               text::count(m.size(), "automaton|automata"), lattice, text::count(m.link_count(), "link"), m.dt,
               text::count(sim.steps_per_frame(), "step"), text::count(plan.total_frames, "frame"),
               text::count(plan.total_steps, "step"),
               steps_run_on(sim.backend().name(), threads), human_bytes(estimate.total()));
    for (const std::string& note : scene_notes(m, scene)) fmt::print(stderr, "note: {}\n", note);
  }
  // Outputs of an earlier run in this folder would mix with this one's: they are set aside first, all or
  // none, and removed once the renderer has started and the scene is written; a run that stops before
  // leaves the folder as it was.
  io::StagedRemoval earlier(dir);
  stage_earlier_run(earlier, dir);  // (its scene file written anew below: the earlier one goes back with the rest)
  // The scene as run (overrides applied), so the folder says what produced it. First of what the run writes:
  // a session killed from here on leaves a folder the next one knows for a run's, and rolls back.
  // A step count is not a key of the scene: a comment at the top says it (resuming reads the count from
  // the checkpoints).
  earlier.will_write(dir / "scene.toml");
  io::write_file_atomic(dir / "scene.toml", [&](std::ostream& os) {
    if (o.steps)
      os << fmt::format("# This run: --steps {} ({:.6g} s of simulated time), not output.duration below; "
                        "`mca run scene.toml --steps {}` repeats it\n",
                        *o.steps, static_cast<double>(*o.steps) * sim.model().dt, *o.steps);
    os << io::scene_to_toml(scene);
  }, false);
  // The renderer before any frame: a missing OpenGL or a camera that sees nothing stops here (and the
  // earlier run goes back, the scene file written above removed).
  std::unique_ptr<RenderOutput> render;
  if (o.render) render = std::make_unique<RenderOutput>(dir, sim, ro, plan.total_frames, o.quiet, 0, &stop, earlier);
  created.keep = true;
  // A stop signal so far: no run has begun, and the earlier one goes back whole.
  if (const int sig = stop; sig != 0) {
    fmt::print(stderr, "mca: interrupted by {} before the run began: {} is as it was\n", signal_name(sig), dir.string());
    return 128 + sig;
  }
  earlier.commit();
  remove_empty_output_folders(dir, render != nullptr);
  FrameWriter writer(dir, sim.model(), scene.output);
  Loop L{sim, dir, threads, o.quiet, scene.output.checkpoint_every, plan, 0, 0.0, render.get(), false, {}};
  // Frame 0: the initial state.
  const auto frags = writer.fragments(sim.state());
  try {
    writer.write_frame(0, sim.state(), frags);
    if (render) render->write_frame(0, sim.state(), frags);
    writer.start_stats({writer.format_row(writer.stats(0, sim.state(), frags))});
  } catch (const Error& e) {  // (a full disk: as a write that fails later, but no step was made)
    throw Error(fmt::format("{}\nThe run stopped writing frame 0, before its first step; once the disk has room (or "
                            "the cause above is fixed), start it again",
                            e.what()));
  }
  L.frame = 1;
  return run_loop(L, writer);
}

Plan checkpoint_plan(const std::filesystem::path& dir, const Engine& sim, const io::Checkpoint& cp,
                     const std::string& source, std::string_view between_frames) {
  const Plan plan = resume_plan(cp, sim.steps_per_frame(), source, between_frames);
  // The folder's run is of a step count too (its --steps, or its duration's): a checkpoint of the same scene
  // run for another count ends the folder at that one's end, past or short of its frames.
  if (const auto given = read_scene_head(dir).steps; given.value_or(sim.total_steps()) != plan.total_steps)
    throw Error(fmt::format("{} is of a run of {} steps, and the run in {} is of {} (its scene.toml's {}): it was "
                            "copied in from another run; remove it, or resume the run it belongs to in its own folder",
                            source, plan.total_steps, dir.string(), given.value_or(sim.total_steps()),
                            given ? "--steps" : "output.duration"));
  return plan;
}

FolderGoingOn go_on_in_folder(const std::filesystem::path& dir, const Engine& sim, const io::Checkpoint& cp,
                              const Plan& plan, const GoingOn& how) {
  const bool steps_left = cp.state.step < plan.total_steps;
  // A rendered run goes on rendering, as it began (render/render.json), unless told not to; the renderer
  // comes before any output, as for a new run.
  const auto rendered = load_render_options(dir);
  const bool will_render = rendered && how.draw;
  io::check_output_subfolders(dir, run_subfolders(cp.scene, will_render));
  check_run_names_are_files(dir);
  io::check_inputs_outside_subfolders(dir, mesh_inputs(cp.scene));
  if (how.check_fits)
    check_run_fits(sim, cp.scene, plan.total_frames + 1 - cp.frame, will_render ? rendered->width : 0,
                   will_render ? rendered->height : 0, dir);
  // Rows past the checkpoint (frames the interrupted run wrote after it) are dropped: they are written
  // again as the run continues. Read before any file is touched: a stats file that cannot be read stops
  // the resume with the folder as it was.
  auto rows = read_back_stats(dir, cp.frame, FrameWriter::stats_header(sim.model()).size());
  // The earlier end (the plots too, where steps are left; the frames the renderer draws again, its video and
  // sheet) is set aside here, all or none: a resume that stops before its collections and stats are written
  // again leaves it as it was. (The plots are made again only by a rendered run; a run with no step left
  // keeps them, and its stats.)
  io::StagedRemoval earlier_end(dir);
  const std::size_t plots_removed = stage_end_outputs(earlier_end, dir, steps_left);
  FolderGoingOn going;
  if (const auto& ro = rendered) {
    if (how.draw) {
      going.render = std::make_unique<RenderOutput>(dir, sim, *ro, plan.total_frames, how.quiet, cp.frame, how.stop,
                                                    earlier_end);
    } else if (steps_left) {  // (with none left, the rendering is whole and stays so)
      // Its frames stop here: a later resume must not take the folder for a whole rendering. (Those the
      // interrupted run drew past the checkpoint go, as its rows there do.)
      earlier_end.stage(dir / "render" / "render.json");
      RenderOutput::remove_frames_from(dir / "render", cp.frame, earlier_end);
      how.warn(fmt::format("{}: {} keeps the frames drawn so far (0..{}); the frames this run adds are not drawn, "
                           "and no video is made",
                           how.not_drawn, (dir / "render").string(), cp.frame - 1));
    }
  } else if (steps_left) {
    // Frames drawn by an earlier session without the options they were drawn with: this one cannot go on.
    std::size_t drawn = 0;
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir / "render", ec))
      if (io::numbered(e.path().filename().string(), "frame_", ".png")) ++drawn;
    if (drawn > 0)
      how.warn(fmt::format("{} holds {} rendered frames but no render.json (the options a rendered run draws with; a "
                           "resume with --no-render removes it): the frames this resume adds are not drawn, and no "
                           "video is made; to draw them, stop this resume and restore render.json, or start the run "
                           "again with --render",
                           (dir / "render").string(), drawn));
  }
  going.writer = std::make_unique<FrameWriter>(dir, sim.model(), cp.scene.output);
  FrameWriter& writer = *going.writer;
  // Its stats and collections, written again below without the entries past the checkpoint, are set aside
  // with the end: a resume stopped before its commit left them cut back beside the earlier run's summary.
  for (const std::string& name : writer.restored_files()) {
    earlier_end.stage(dir / name);
    earlier_end.will_write(dir / name);
  }
  // Frame f is at the step the run wrote it at (min(f spf, total)), at that step's time.
  auto missing = writer.restore(cp.frame, [&](std::int64_t f) {
    return static_cast<double>(std::min(f * sim.steps_per_frame(), plan.total_steps)) * sim.model().dt;
  });
  // The checkpoint's own frame's row is the checkpoint's state's: one lost or cut short is made again from it.
  if (static_cast<std::int64_t>(rows.size()) == cp.frame - 1) {
    const auto frags = writer.fragments(sim.state());
    rows.push_back(writer.format_row(writer.stats(cp.frame - 1, sim.state(), frags)));
  }
  if (static_cast<std::int64_t>(rows.size()) < cp.frame)
    how.warn(fmt::format("{} has {} of the {} rows up to the checkpoint; the rows of frames {}..{} will be missing "
                         "from it",
                         (dir / "stats.csv").string(), rows.size(), cp.frame, rows.size(), cp.frame - 1));
  // So are the checkpoint's own frame's files (below); those of earlier frames are gone for good (no state
  // of them is left), and the collections leave them out.
  const bool own_frame_lost = !missing.empty() && missing.back() == cp.frame - 1;
  if (own_frame_lost) missing.pop_back();
  if (!missing.empty())
    how.warn(fmt::format("{} lacks whole files (missing, empty or cut short) of {} of the {} frames before the "
                         "checkpoint (frame{} {}); {}a resume cannot write them again",
                         dir.string(), missing.size(), cp.frame - 1, missing.size() > 1 ? "s" : "",
                         text::number_runs(missing),
                         cp.scene.output.vtk ? "the .pvd collections list the frames that are whole, and " : ""));
  writer.start_stats(rows);
  earlier_end.commit();
  if (plots_removed > 0 && !going.render && !how.quiet)
    how.note(fmt::format("the plots in {} showed the run up to frame {} and are removed; python3 {} {} draws them "
                         "again when the run ends",
                         (dir / "render").string(), cp.frame - 1, text::shell_word(plot_script().string()),
                         text::shell_word(dir.string())));
  remove_empty_output_folders(dir, going.render != nullptr, true);
  // (After the earlier end is gone: a folder whose frame could not be written again says "finished" nowhere.)
  try {
    if (own_frame_lost) writer.write_frame(cp.frame - 1, sim.state(), writer.fragments(sim.state()));
    if (going.render) going.render->draw_checkpoint_frame(sim.state());
  } catch (const Error& e) {
    throw Error(fmt::format("{}\nThe resume stopped writing the checkpoint's frame {} again, before its first step; "
                            "once the disk has room (or the cause above is fixed), continue it with: mca resume {}",
                            e.what(), cp.frame - 1, text::shell_word(dir.string())));
  }
  return going;
}

int resume(const std::string& out_dir, int threads_requested, bool quiet, bool no_render,
           const std::optional<std::string>& backend) {
  Engine::check_environment();  // a bad MCA_SIMD or MCA_BACKEND, before anything is read or written
  // An empty path would silently mean the current folder.
  if (out_dir.empty()) throw Error("mca resume: the folder is empty (\"\"); give the --out folder of the run to continue");
  const std::filesystem::path dir(out_dir);
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    const bool there = std::filesystem::exists(dir, ec);
    const std::string why = there ? "is not a folder"
                            : ec && ec != std::errc::no_such_file_or_directory
                                ? fmt::format("cannot be reached ({})", ec.message())
                                : "does not exist";
    throw Error(fmt::format("mca resume: '{}' {}; give the --out folder of a run started with --checkpoint-every N "
                            "(its checkpoints are in <folder>/checkpoints)",
                            out_dir, why));
  }
  const io::OutputLock lock(dir);
  io::check_output_subfolders(dir, {"checkpoints"});  // (first: no subfolder a link out of the folder)
  recover_folder(dir, quiet);
  const auto ckdir = dir / "checkpoints";
  const auto all = io::list_checkpoints(ckdir);
  if (all.empty())
    throw Error(fmt::format("no checkpoint in '{}': a run writes them with --checkpoint-every N (and when Ctrl-C "
                            "stops it at the end of a frame); pass that run's --out folder",
                            ckdir.string()));
  io::Checkpoint cp = io::read_checkpoint(all.back());
  // A checkpoint copied in from another run would write its scene's frames and summary into this folder.
  const SolverDef::Backend folder_backend = io::check_checkpoint_scene(cp, all.back(), dir);
  // Any backend continues any checkpoint with the same bits: --backend for this session, else the folder's
  // scene.toml's (the checkpoint's is that of the session that wrote it, which may have been told another).
  cp.scene.solver.backend = backend ? backend_from_name(*backend, "--backend") : folder_backend;
  if (!backend && folder_backend == SolverDef::Backend::cuda) {
    std::string why;
    if (cuda_device(&why).empty())
      throw Error(fmt::format("{}: solver.backend = \"cuda\", where this resume would run: {}; continue it on the CPU "
                              "with the same bits: mca resume {} --backend cpu",
                              (dir / "scene.toml").string(), why, text::shell_word(dir.string())));
  }
  const int threads = thread_count(threads_requested);
  tbb::global_control gc(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
  if (!quiet)
    fmt::print(stderr, "mca: resuming '{}' from {} (frame {}, step {})\n", cp.scene.name, all.back().string(),
               cp.frame - 1, cp.state.step);
  // The file is untrusted: the model rebuilt from its scene must be the one it was saved from, and the
  // state must fit that model, before a backend is given the state.
  const std::string source = fmt::format("checkpoint '{}'", all.back().string());
  std::optional<lattice::BuildProgress> building;
  if (!quiet) building.emplace();
  std::optional<BuildSignals> build_signals;
  build_signals.emplace();
  Engine sim(cp.scene, cp.state, source, cp.model_fingerprint);
  build_signals.reset();
  const std::atomic<int>& stop = catch_stop_signals();  // (from here a signal is the run's to answer: the
                                                        // renderer's set-up, frame 0)
  building.reset();
  const Plan plan = checkpoint_plan(dir, sim, cp, source);
  // A run that had reached its last frame (one that finished, or was stopped there) has no step left: its
  // outputs (summary, fragments, video) are finished again from that frame, with the same results.
  const bool steps_left = cp.state.step < plan.total_steps;
  // The scene's notes, as the run said them when it began (a resume's log may be the only one read).
  if (steps_left && !quiet)
    for (const std::string& note : scene_notes(sim.model(), cp.scene)) fmt::print(stderr, "note: {}\n", note);
  if (!steps_left && !quiet)
    fmt::print(stderr, "mca: the checkpoint holds the run's last frame ({}, step {}): no step is left to run; its "
               "outputs are finished again from it\n",
               cp.frame - 1, cp.state.step);
  // A finished run whose newest checkpoint is before its end is run again from there (it said nothing, and
  // rewrote the summary as a resume's).
  if (steps_left && !quiet && summary_status(dir) == "finished")
    fmt::print(stderr, "mca: the run in {} has finished (its summary.json says so), and its newest checkpoint is of "
               "frame {} (the run ends at frame {}): the resume runs the frames after it again, with the same "
               "bits, and writes the run's end again (its summary then that of a resumed run)\n",
               dir.string(), cp.frame - 1, plan.total_frames);
  GoingOn how;
  how.draw = !no_render;
  how.not_drawn = "--no-render";
  how.quiet = quiet;
  how.stop = &stop;
  how.warn = [](const std::string& w) { say("warning: {}\n", w); };
  how.note = [](const std::string& n) { say("mca: {}\n", n); };
  FolderGoingOn going = go_on_in_folder(dir, sim, cp, plan, how);
  Loop L{sim, dir, threads, quiet, cp.scene.output.checkpoint_every, plan, 0, 0.0, going.render.get(), false, all.back()};
  L.frame = cp.frame;
  L.wall_before = cp.wall_seconds;
  return run_loop(L, *going.writer);
}

}  // namespace mca::app
