#include "sim/engine.hpp"

#include <cmath>
#include <cstdlib>
#include <utility>
#include <fmt/format.h>

#include "backend/cpu/lattice_kernels.hpp"
#include "backend/cuda/device_memory.hpp"
#include "core/environment.hpp"
#include "core/fnv.hpp"
#include "core/text.hpp"
#include "lattice/lattice.hpp"
#include "mca/error.hpp"
#include "sim/state_check.hpp"

namespace mca {

void Engine::check_environment() {
  cpu::select_kernels();
  backend_from_environment();
  cuda_lattice();
  gpu::emulated_gpu_memory();
  profile_requested();
  cuda_sync_requested();
}

SolverDef::Backend backend_from_name(const std::string& name, const std::string& option) {
  if (const auto b = parse_backend(text::lower(name))) return *b;  // any case, as MCA_BACKEND: CPU is cpu
  throw Error(fmt::format("{} '{}': give auto (the default), cpu, cuda or cuda-emulation", option, name));
}

std::optional<SolverDef::Backend> backend_from_environment() {
  const char* env = std::getenv("MCA_BACKEND");
  if (!env || !*env) return std::nullopt;
  const auto b = parse_backend(text::lower(env));  // any case, as MCA_SIMD: CPU is cpu
  if (!b)
    throw Error(fmt::format("MCA_BACKEND = '{}' (what backend \"auto\" stands for): give auto, cpu, cuda or "
                            "cuda-emulation, or unset it",
                            env));
  if (*b == SolverDef::Backend::automatic) return std::nullopt;
  return b;
}

namespace {
// check(), its mca::Error (a bad environment variable) prefixed with `source`, the scene or checkpoint
// whose backend is being started.
template <class Check>
auto for_source(const std::string& source, Check check) {
  try {
    return check();
  } catch (const Error& e) {
    throw Error(fmt::format("{}: {}", source, e.what()));
  }
}
}  // namespace

std::unique_ptr<Backend> start_backend(const Model& model, SolverDef::Backend kind, const std::string& source,
                                       State state) {
  // MCA_BACKEND, where set, says what auto stands for on this machine (the tests set cpu, so that their
  // checks of the CPU backend stay on the CPU on a GPU machine).
  bool by_environment = false;
  if (kind == SolverDef::Backend::automatic) {
    if (const auto named = for_source(source, backend_from_environment)) {
      kind = *named;
      by_environment = true;
    }
  }
  // (A bad MCA_PROFILE, MCA_CUDA_LATTICE or MCA_EMULATED_GPU_MEMORY_MB is an error here, not a GPU that cannot
  // take the model.)
  for_source(source, profile_requested);
  if (kind != SolverDef::Backend::cpu) {
    for_source(source, cuda_lattice);
    for_source(source, gpu::emulated_gpu_memory);
  }
  std::unique_ptr<Backend> b;
  switch (kind) {
    case SolverDef::Backend::cuda_emulation:
      b = make_cuda_emulation_backend(model);
      break;
    case SolverDef::Backend::cuda: {
      std::string why;
      if (cuda_device(&why).empty())
        throw Error(by_environment
                        ? fmt::format("{}: backend \"auto\" with MCA_BACKEND = 'cuda': {}; unset MCA_BACKEND or set it to cpu",
                                      source, why)
                        : fmt::format("{}: solver.backend = \"cuda\" (or --backend cuda): {}; use backend \"cpu\" or "
                                      "\"auto\", or a build of mca made where nvcc is found, on a machine with an NVIDIA GPU "
                                      "and its driver",
                                      source, why));
      b = make_cuda_backend(model);
      break;
    }
    case SolverDef::Backend::automatic: {
      // The GPU where there is one this build can use (its state is the CPU's bit for bit: the CudaDevice
      // tests, scripts/gpu_check.sh), else the CPU; the backend's name says which. A GPU that cannot take
      // the model and its state (its memory) leaves them to the CPU, saying why.
      const std::string device = cuda_device();
      if (!device.empty()) {
        try {
          b = make_cuda_backend(model);
          b->upload(state);  // (a copy: the CPU's, should the GPU refuse it)
          return b;
        } catch (const Error& e) {
          b.reset();
          fmt::print(stderr, "mca: the GPU ({}) cannot take the model ({}); the CPU steps it\n", device, e.what());
        }
      }
      b = make_cpu_backend(model);
      break;
    }
    case SolverDef::Backend::cpu:
      b = make_cpu_backend(model);
      break;
  }
  b->upload(std::move(state));
  return b;
}

namespace {
Model build_for_frames(const SceneDef& scene, int& steps_per_frame, std::int64_t& total_steps,
                       std::size_t placed = 0) {
  Model m = lattice::build_model(scene, placed);
  double frame = 1.0 / scene.output.frame_rate;
  const bool given = scene.solver.time_step > 0;
  // A frame's steps are counted from the step as given, not from its float (time_step = 1e-6 is
  // 9.99999997e-7 in float, which made frames of 2e-6 s three steps).
  const double stable = given ? scene.solver.time_step : m.dt;
  if (given && frame < stable * (1 - 1e-9)) {
    throw Error(fmt::format("{}: output.frame_rate = {} asks for frames of {} s, shorter than solver.time_step = "
                            "{} s; lower output.frame_rate to at most {}, or remove solver.time_step",
                            scene.source, text::num(scene.output.frame_rate), text::distinct(frame, stable, 3).a,
                            text::num(scene.solver.time_step), text::at_most(1.0 / stable, 6)));
  }
  // A frame longer than the run is the run: its only frames are the first and the last (output.frame_rate
  // = 1e-6 over 0.05 s), however many steps a whole frame would take.
  // At most 1e9 steps a frame, give or take the float rounding of a given time step (1e-12 s is
  // 9.99999998e-13 in float, which made a frame of 1 ms 1,000,000,001 steps and refused the documented
  // frame_rate = 1000 while naming it as the fix).
  constexpr double kMaxFrameSteps = 1e9 * (1 + 1e-6);
  // (Whole steps a frame, spared the ratio's last bits: 1e-9 of a step, or 1e-12 of the count where the
  // frame is more than 1,000 steps.)
  auto whole_steps = [&](double f) { const double r = f / stable; return std::ceil(r - std::max(1e-9, 1e-12 * r)); };
  if (whole_steps(frame) > kMaxFrameSteps && scene.output.duration < frame) frame = scene.output.duration;
  const double steps = std::max(1.0, whole_steps(frame));
  if (steps > kMaxFrameSteps) {
    const double rate = steps / kMaxFrameSteps / frame;  // the frame rate at which a frame is 1e9 steps (give or take)
    if (given)
      throw Error(fmt::format("{}: a frame of {:.3g} s (output.frame_rate = {:g}) is {:.3g} steps of solver.time_step = "
                              "{:g} s, more than the 1e9 a frame can take; raise output.frame_rate to at least {}, "
                              "or give a larger solver.time_step",
                              scene.source, frame, scene.output.frame_rate, steps, stable, text::at_least(rate, 3)));
    throw Error(fmt::format("{}: a frame of {:.3g} s (output.frame_rate = {:g}) would take {:.3g} steps of {:.3g} s: "
                            "the critical time step is {:.3g} s, set by {}. Check the scene's numbers (densities, "
                            "moduli, sizes and their units), or raise output.frame_rate to at least {} so a frame "
                            "is at most 1e9 steps",
                            scene.source, frame, scene.output.frame_rate, steps, stable, m.critical_dt, m.dt_limited_by,
                            text::at_least(rate, 3)));
  }
  steps_per_frame = static_cast<int>(steps);
  // The automatic step is shortened so that a whole number of steps fills each frame. The count of steps
  // is checked in double first: a frame shorter than float32 resolves would be a step of 0.
  const double step = given ? stable : frame / steps_per_frame;
  const bool frames_set_it = !given && frame < stable;  // each frame is one step, shorter than the stable one
  if (!(std::round(scene.output.duration / step) <= static_cast<double>(Engine::kMaxSteps))) {
    throw Error(fmt::format("{}: output.duration = {:g} s is {:.3g} steps of {:.3g} s{}, more than the {:.0e} a run "
                            "can take; give a shorter output.duration (or --duration){}",
                            scene.source, scene.output.duration, std::round(scene.output.duration / step), step,
                            frames_set_it ? fmt::format(" (each frame of output.frame_rate = {:g} takes a step at least)",
                                                        scene.output.frame_rate)
                                          : "",
                            static_cast<double>(Engine::kMaxSteps),
                            frames_set_it ? " or a lower output.frame_rate" : ""));
  }
  if (!given) lattice::set_time_step(m, static_cast<float>(step));
  // (A given step counts the run's steps as it counts a frame's: from the value as written.)
  const double total = std::round(scene.output.duration / (given ? stable : static_cast<double>(m.dt)));
  if (!(total <= static_cast<double>(Engine::kMaxSteps))) {  // the float step a hair shorter than the double
    throw Error(fmt::format("{}: output.duration = {:g} s is {:.3g} steps of {:.3g} s, more than the {:.0e} a run "
                            "can take; give a shorter output.duration (or --duration)",
                            scene.source, scene.output.duration, total, m.dt, static_cast<double>(Engine::kMaxSteps)));
  }
  if (total < 1) {
    throw Error(fmt::format("{}: output.duration = {:g} s is shorter than half a time step ({:.3g} s); give a duration "
                            "(or --duration) of at least one step",
                            scene.source, scene.output.duration, m.dt));
  }
  total_steps = static_cast<std::int64_t>(total);
  // A body that crosses a large part of an automaton in one step skips contacts: the initial speeds must
  // stay below a tenth of the spacing per step (30 m/s at the default step is 1e-3 of it).
  double fastest = 0;
  std::string which;
  const ProjectileDef* spinning = nullptr;  // where the fastest is a ball's surface: that ball
  auto norm = [](const Vec3d& v) { return std::hypot(v[0], v[1], v[2]); };  // (1e300 is no inf)
  for (const auto& o : scene.objects) {
    const double v = norm(o.velocity);
    if (v > fastest) { fastest = v; which = fmt::format("object '{}'", o.name); }
  }
  for (const auto& p : scene.projectiles) {
    const double v = norm(p.velocity);
    if (v > fastest) { fastest = v; which = fmt::format("projectile '{}'", p.name); spinning = nullptr; }
    // Its surface turns past the automata it touches at angular_velocity x radius.
    const double w = norm(p.angular_velocity) * p.radius;
    if (w > fastest) {
      fastest = w;
      which = fmt::format("the surface of projectile '{}' (angular_velocity x radius)", p.name);
      spinning = &p;
    }
  }
  for (const auto& g : scene.grips) {
    const double v = norm(g.velocity);
    if (v > fastest) { fastest = v; which = fmt::format("grip '{}'", g.name); spinning = nullptr; }
  }
  if (!(fastest * m.dt <= 0.1 * m.spacing)) {
    const double fits = 0.1 * m.spacing / m.dt;  // the fastest speed taken
    const text::Distinct speed = text::distinct(fastest, fits);
    const text::Distinct reach = text::distinct(fastest * m.dt, 0.1 * m.spacing, 3);
    // A ball's spin: the angular_velocity that fits, within the turn per step below too.
    std::string fix = fmt::format("Lower its speed below {} m/s", text::at_most(fits, 4));
    if (spinning) {
      double limit = fits / spinning->radius;
      if (!spinning->kinematic) limit = std::min(limit, kLargestProjectileTurn / static_cast<double>(m.dt));
      fix = fmt::format("Lower its angular_velocity below {} rad/s", text::at_most(limit, 4));
    }
    throw Error(fmt::format("{}: {} starts at {} m/s, which crosses {} m per time step of {:.3g} s, more than a tenth "
                            "of the spacing ({} m of {:g} m): contacts would be skipped. {}, or lower solver.safety "
                            "or solver.time_step",
                            scene.source, which, speed.a, reach.a, m.dt, reach.b, m.spacing, fix));
  }
  // A ball's orientation turns by |angular_velocity| dt a step, in parts of at most 0.5 rad, each integrated
  // to first order and renormalised (core/math.hpp, integrate_projectile_orientation), up to 32 rad a step;
  // past that it is not followed (in one step, past 3.3 rad it turned into NaN: a ball of 1 mm at 3.5 rad a
  // step, its surface within the speed limit above, did while its run finished).
  // (A kinematic ball's orientation is not integrated: it keeps its spin, and its surface speed is checked.)
  for (const auto& p : scene.projectiles) {
    const double turn = norm(p.angular_velocity) * m.dt;
    if (!p.kinematic && turn > kLargestProjectileTurn)
      throw Error(fmt::format("{}: projectile '{}' spins at {:.4g} rad/s, which turns it by {} rad per time step "
                              "of {:.3g} s, more than the {:g} rad its orientation's integration follows; lower its "
                              "angular_velocity below {} rad/s, or lower solver.safety or solver.time_step",
                              scene.source, p.name, norm(p.angular_velocity),
                              text::distinct(turn, kLargestProjectileTurn, 3).a, m.dt, kLargestProjectileTurn,
                              text::at_most(kLargestProjectileTurn / m.dt, 4)));
  }
  return m;
}
}  // namespace

// The energy that breaks one link of the weakest material in use: E eps_b^2 V / 2 with eps_b the smaller
// of its breaking strains, times the weakest class factor, and at most that of a strain of 1e-4 (materials
// that do not break still get a floor).
double breaking_energy(const Model& m) {
  double least = INFINITY;
  float k_min = INFINITY;
  for (float k : m.class_factor) k_min = std::min(k_min, k);
  std::vector<char> used(m.groups.size(), 0);
  for (auto g : m.group) used[g] = 1;
  for (std::size_t g = 0; g < m.groups.size(); ++g) {
    if (!used[g]) continue;
    const GroupParams& p = m.groups[g];
    const double eps = std::min(1e-4, static_cast<double>(k_min * std::min(p.fracture_strain, p.tensile_strength / p.youngs)));
    least = std::min(least, 0.5 * p.youngs * eps * eps * static_cast<double>(m.spacing) * m.spacing * m.spacing);
  }
  return std::isfinite(least) ? least : 0.0;
}

// What gravity would put into the bodies if each fell from where it starts to the lowest point of the scene
// (the ground, else the lowest starting point of any automaton or projectile): the blow-up check's measure
// of the energy that gravity deals in. Its net work alone is not one: a ball bouncing back to where it fell
// from has taken none in net, and the one percent a bounce may gain at restitution 1 (the discrete contact)
// read as ten times the energy put in (a ball of 42 J near the top of its fourth bounce stopped its run).
namespace {
double fall_energy(const Model& m) {
  const double gx = m.gravity.x, gy = m.gravity.y, gz = m.gravity.z;
  const double g = std::sqrt(gx * gx + gy * gy + gz * gz);
  if (!(g > 0)) return 0.0;
  const auto height = [&](const DVec3& x) { return x.x * m.up.x + x.y * m.up.y + x.z * m.up.z; };
  double lowest = m.ground ? m.ground_height : INFINITY;
  for (std::size_t a = 0; a < m.size(); ++a) lowest = std::min(lowest, height(m.position0[a]) - m.radius[a]);
  for (const auto& p : m.projectiles) lowest = std::min(lowest, height(p.position) - p.radius);
  double fall = 0;
  for (std::size_t a = 0; a < m.size(); ++a)  // (an automaton a grip holds does not fall)
    if (m.grip.empty() || m.grip[a] < 0) fall += m.mass[a] * g * std::max(0.0, height(m.position0[a]) - lowest);
  for (const auto& p : m.projectiles)
    if (!p.kinematic) fall += p.mass * g * std::max(0.0, height(p.position) - lowest);
  return std::isfinite(fall) ? fall : 0.0;
}
}  // namespace

Engine::Engine(const SceneDef& scene) : scene_(scene) {
  model_ = build_for_frames(scene_, steps_per_frame_, total_steps_);
  energy_floor_ = breaking_energy(model_);
  fall_energy_ = fall_energy(model_);
  backend_ = start_backend(model_, scene_.solver.backend, scene_.source, initial_state(model_));
  // A run's energy budget starts from its first state (contact springs included, so after the upload
  // that builds the contact lists); a resumed run keeps its checkpoint's.
  backend_->set_initial_energy(energies().total());
}

Engine::Engine(const SceneDef& scene, const State& state, const std::string& source,
               std::optional<std::uint64_t> fingerprint, std::size_t projectiles_in_flight)
    : scene_(scene) {
  model_ = build_for_frames(scene_, steps_per_frame_, total_steps_, projectiles_in_flight);
  // The fingerprint first: when the scene was edited, "another model" is the cause to report, not the
  // first array whose size it changed.
  if (fingerprint) {
    const std::uint64_t rebuilt = model_fingerprint(model_);
    if (rebuilt != *fingerprint) {
      // A mesh object's model comes from its file as well: changed since, it gives another model.
      std::string meshes;
      for (const MeshSummary& ms : model_.meshes) meshes += fmt::format("{}{}", meshes.empty() ? "" : ", ", ms.path);
      throw Error(fmt::format("{}: its embedded scene does not give the model the state was saved from (model "
                              "fingerprint {:016x}, saved {:016x}): {}the file was edited or damaged, or written by "
                              "a version of mca whose model differs (a change of the physics, which refuses every "
                              "checkpoint of that version alike); {}use an earlier checkpoint of this version "
                              "(remove this one) or start the run again",
                              source, rebuilt, *fingerprint,
                              meshes.empty() ? "" : fmt::format("a mesh file it reads ({}) changed since the run, or ", meshes),
                              meshes.empty() ? "" : "put the mesh files back as they were, "));
    }
  }
  check_state(model_, state, source);
  energy_floor_ = breaking_energy(model_);
  fall_energy_ = fall_energy(model_);
  if (!fingerprint) {
    backend_ = start_backend(model_, scene_.solver.backend, scene_.source, state);
    return;
  }
  // A checkpoint: its clock is its run's, and its energy budget is its run's first state's energy (the
  // first constructor's), which the backend computes again from the rebuilt model before it takes the
  // checkpoint's state (an edited budget would have turned the blow-up check off, or tripped it at once).
  check_run_clock(model_, state, source);
  backend_ = start_backend(model_, scene_.solver.backend, scene_.source, initial_state(model_));
  const double first = energies().total();  // (as the first constructor's)
  if (!(std::fabs(state.initial_energy - first) <= 1e-6 * std::fabs(first) + energy_floor_))
    throw Error(fmt::format("{}: the saved state does not fit the model of its scene: its run's starting energy is "
                            "saved as {} J, and the scene's first state holds {} J; the file is damaged or was "
                            "edited: use an earlier checkpoint (remove this one) or start the run again",
                            source, state.initial_energy, first));
  backend_->upload(state);
}

// The energy is checked at every multiple of kEnergyCheckInterval steps of the run, whatever the calls'
// sizes (mca run's and the Python module's follow the wall clock) and wherever a run was resumed: at the
// same steps, so with the same outcome, on every backend and machine. A call is split at those steps
// (how steps are grouped into a backend's calls changes no result).
StepHealth Engine::advance(int steps) {
  if (steps <= 0) return backend_->step(0);  // (no step; a simulation that stopped says so, as on every call)
  StepHealth h;
  while (steps > 0) {
    const std::int64_t next = (step() / kEnergyCheckInterval + 1) * kEnergyCheckInterval;
    const int k = static_cast<int>(std::min<std::int64_t>(steps, next - step()));
    h = backend_->step(k);
    steps -= k;
    if (h.flags != kHealthy) return h;
    if (step() % kEnergyCheckInterval != 0) continue;
    const double initial = backend_->initial_energy();
    const Energies e = backend_->energies();
    // What the bodies hold beyond the start and the work put in (gravity, grips, loads, kinematic
    // projectiles), against 9x the energy the run has dealt in (physics.md sec. 7: 10x what was put in):
    // the start's energy plus every work in magnitude (a body bouncing higher than it fell, from the
    // discrete contact, turns gravity's work negative) and what gravity would give the bodies falling to
    // the lowest point (fall_energy), and at least the energy that breaks one link of the weakest material
    // (heating below it, such as float rounding in an undamped body far from the origin, can harm nothing).
    const double excess = e.total() - e.external_work() - initial;
    const double dealt = std::fabs(initial) + std::fabs(e.gravity_work) + std::fabs(e.grip_work) + std::fabs(e.load_work) +
                         std::fabs(e.projectile_work) + fall_energy_;
    if (excess > 9.0 * std::max(dealt, energy_floor_)) {
      h.flags |= kEnergyGrowth;
      h.step = step();
      h.energy = e.total();
      h.budget = initial + e.external_work();
      return h;
    }
  }
  return h;
}

namespace {
struct Fnv : Fnv1a {
  template <class T>
  void vec(const std::vector<T>& v) {
    pod(v.size());
    bytes(v.data(), v.size() * sizeof(T));
  }
  void history(const ContactHistory& c) {
    bytes(&c.ut, sizeof c.ut);
    bytes(&c.mr, sizeof c.mr);
  }
  // A list of structs: its length, then each element through `each`, field by field.
  template <class T, class F>
  void list(const std::vector<T>& v, F each) {
    pod(v.size());
    for (const auto& e : v) each(e);
  }
};
}  // namespace

std::string instability_message(const Engine& sim, const StepHealth& h) {
  const Model& m = sim.model();
  const State& s = sim.state();
  std::string what;
  if (h.flags & kNonFinite && h.automaton < 0 && h.projectile >= 0 &&
      static_cast<std::size_t>(h.projectile) < s.projectiles.size()) {
    // Its position and motion finite: a spin past what its orientation's integration follows (which its
    // contacts gave it), its orientation perhaps not finite for that.
    const ProjectileState& ps = s.projectiles[static_cast<std::size_t>(h.projectile)];
    const std::string& name = m.projectiles[static_cast<std::size_t>(h.projectile)].name;
    const double spin = projectile_turn(to_vec3(ps.angular_velocity), m.dt);
    if (std::isfinite(spin) && std::isfinite(length(ps.position)) && std::isfinite(length(ps.velocity)))
      what = fmt::format("projectile '{}' spins {} rad per time step, past the {:g} rad its orientation's integration "
                         "follows",
                         name, text::distinct(spin, kLargestProjectileTurn, 3).a, kLargestProjectileTurn);
    else
      what = fmt::format("a non-finite position, velocity or orientation of projectile '{}'", name);
  } else if (h.flags & kNonFinite) {
    what = fmt::format("a non-finite position, velocity or orientation at automaton {}", h.automaton);
  } else
    what = fmt::format("kinetic + elastic energy is {:.3g} J where the start and the work put in since give {:.3g} J",
                       h.energy, h.budget);
  return fmt::format("the run became unstable at step {} (t = {:.6g} s): {}. Likely causes: a time step set by hand "
                     "close to the critical one ({:.4g} s here, set by {}), or extreme values (speeds, materials); "
                     "objects and projectiles that start overlapping or inside the ground are refused before a run. "
                     "Fix: lower solver.safety (now {:g}) or remove solver.time_step, and check the scene's values",
                     h.step >= 0 ? h.step : s.step, s.time, what, m.critical_dt, m.dt_limited_by,
                     sim.scene().solver.safety);
}

std::uint64_t state_hash(const State& s) {
  // Every field, so that two states with equal hashes evolve identically (Determinism.StateHashCovers...
  // perturbs each one). Structs are hashed field by field: padding bytes hold no state.
  Fnv f;
  f.pod(s.step);
  f.pod(s.time);
  f.vec(s.x);
  f.vec(s.v);
  f.vec(s.w);
  f.vec(s.q);
  f.vec(s.s);
  f.vec(s.mean_stress);
  f.vec(s.f);
  f.vec(s.t);
  f.vec(s.intact);
  f.vec(s.link_ut);
  if (!s.link_moment.empty()) f.vec(s.link_moment);  // (a lattice state hashes as before)
  if (!s.link_damage.empty()) f.vec(s.link_damage);    // (as does one without softening)
  f.list(s.contacts, [&](const auto& c) {
    f.pod(c.i);
    f.pod(c.j);
    f.history(c.h);
    if (c.face != ContactPair::kApart) f.pod(c.face);  // (a state without faces hashes as before)
  });
  f.list(s.ground_contacts, [&](const auto& c) {
    f.pod(c.automaton);
    f.history(c.h);
  });
  f.vec(s.x_at_rebuild);
  f.list(s.projectiles, [&](const auto& p) {
    f.bytes(&p.position, sizeof p.position);
    f.bytes(&p.velocity, sizeof p.velocity);
    f.bytes(&p.angular_velocity, sizeof p.angular_velocity);
    f.bytes(&p.orientation, sizeof p.orientation);
    f.bytes(&p.force, sizeof p.force);
    f.list(p.contacts, [&](const auto& c) {
      f.pod(c.automaton);
      f.history(c.h);
    });
    f.history(p.ground);
    f.pod(p.work);
  });
  f.list(s.projectile_contacts, [&](const auto& c) {
    f.pod(c.p);
    f.pod(c.q);
    f.history(c.h);
  });
  f.list(s.breaks, [&](const auto& b) {
    f.pod(b.step);
    f.pod(b.link);
    f.pod(b.criterion);
  });
  f.pod(s.broken_by[0]);
  f.pod(s.broken_by[1]);
  f.pod(s.initial_energy);
  f.vec(s.grip_work);
  f.vec(s.grip_force);
  return f.h;
}

}  // namespace mca
