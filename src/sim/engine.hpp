#pragma once
// A run of one scene: the model built from the SceneDef, a backend stepping it, and the frame clock.
// The command line, tests and benchmarks use it directly; C++ users get mca::Simulation
// (include/mca/simulation.hpp), which wraps it without exposing the model and state types.
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "backend/backend.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "mca/scene.hpp"

namespace mca {

class Engine {
 public:
  // Builds the model (throws mca::Error for scenes that cannot be built). The time step is the
  // stable one, shortened so that a whole number of steps fills each output frame.
  explicit Engine(const SceneDef& scene);
  // Continues from a saved state (checkpoint) of the same scene. The state is untrusted: it is checked
  // against the rebuilt model (check_state) before the backend sees it and, when `fingerprint` is given,
  // the model must be the one the state was saved from (model_fingerprint). Both throw mca::Error
  // starting with `source`, which names where the state came from. `projectiles_in_flight`: the first
  // that many projectiles' scene positions are where the state has them now (lattice::build_model's
  // `placed`), so a projectile added to a running scene is checked against where the others are.
  Engine(const SceneDef& scene, const State& state, const std::string& source = "the saved state",
         std::optional<std::uint64_t> fingerprint = std::nullopt, std::size_t projectiles_in_flight = 0);
  // The backend keeps a reference to the model member: an Engine stays where it was built.
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  const SceneDef& scene() const { return scene_; }
  const Model& model() const { return model_; }
  // The backend's current state: a reference to the backend's own State, no copy for the caller. The CPU
  // backend steps its structure-of-arrays copy, so the first call after a step gathers the velocities,
  // orientations and link histories back into that State (O(automata + links)); the CUDA backend
  // downloads every array. Calls until the next step return it as it is. Between calls that need no
  // more, step() and broken_links() below cost nothing.
  const State& state() const { return backend_->state(); }
  // The step and the links broken so far, without bringing the whole state up to date.
  std::int64_t step() const { return backend_->current_step(); }
  double time() const { return backend_->current_time(); }
  std::int64_t broken_links() const { return backend_->broken_links(); }
  Backend& backend() { return *backend_; }
  const Backend& backend() const { return *backend_; }

  // Advances n steps. Stops at the first step with a non-finite value (kNonFinite), and flags
  // kEnergyGrowth when kinetic + elastic energy, less the work put in since the start, has grown past
  // 9x the energy the run has dealt in (the start's plus every work, at least one link's breaking
  // energy); checked at every multiple of kEnergyCheckInterval steps of the run, where it stops.
  StepHealth advance(int steps);
  Energies energies() const { return compute_energies(model_, state()); }

  int steps_per_frame() const { return steps_per_frame_; }
  double frame_interval() const { return steps_per_frame_ * static_cast<double>(model_.dt); }
  // Steps in the scene's duration: round(duration / dt), at least 1; the last frame is shorter when
  // the duration is not a whole number of frames.
  std::int64_t total_steps() const { return total_steps_; }
  // Frames in the scene's duration (at least 1).
  std::int64_t frame_count() const { return (total_steps_ + steps_per_frame_ - 1) / steps_per_frame_; }

  // Checks what the environment asks of the backend (MCA_SIMD: an instruction set this processor runs;
  // MCA_BACKEND: a backend; MCA_CUDA_LATTICE: fused, fused:2, fused:3, fused:4 or split;
  // MCA_EMULATED_GPU_MEMORY_MB: a number of MB; MCA_PROFILE, MCA_CUDA_SYNC: 0 or 1), so that a command can refuse a
  // bad setting before it writes anything. Throws mca::Error.
  static void check_environment();

  static constexpr std::int64_t kEnergyCheckInterval = 256;
  // More steps than any run can take (1e15: a year at 3e7 steps per second), and few enough that step and
  // frame arithmetic stays far from overflowing 64 bits.
  static constexpr std::int64_t kMaxSteps = 1'000'000'000'000'000;

 private:
  SceneDef scene_;
  Model model_;
  std::unique_ptr<Backend> backend_;
  int steps_per_frame_ = 1;
  std::int64_t total_steps_ = 1;
  double energy_floor_ = 0;      // the blow-up check's least reference energy (engine.cpp)
  double fall_energy_ = 0;       // and gravity's part of it: the bodies' fall to the lowest point (engine.cpp)
};

// The backend a scene asks for (SolverDef::backend), with `state` uploaded. auto: what MCA_BACKEND names,
// else the GPU where there is one this build can use and that takes the model and state, else the CPU.
// cuda without a GPU is an mca::Error naming `source` and the fix.
std::unique_ptr<Backend> start_backend(const Model& model, SolverDef::Backend kind, const std::string& source,
                                       State state);
// What backend auto stands for where the environment variable MCA_BACKEND names one (cpu, cuda,
// cuda-emulation); nullopt where it is unset, empty or auto. An mca::Error naming the variable and the
// choices for a value that is none.
std::optional<SolverDef::Backend> backend_from_environment();
// The backend named by `name` (auto, cpu, cuda, cuda-emulation), for the --backend option; an mca::Error
// naming `option` and the choices otherwise.
SolverDef::Backend backend_from_name(const std::string& name, const std::string& option);

// The energy that breaks one link of the weakest material in use: the blow-up check's least reference
// energy (Engine::advance).
double breaking_energy(const Model& m);

// What a step whose health is not kHealthy found, its likely causes and the fix, beginning "the run became
// unstable at step ..." (the message of `mca run` and of the Python module).
std::string instability_message(const Engine& sim, const StepHealth& h);

// FNV-1a hash over every field of the state: equal hashes mean bitwise equal states (determinism and
// checkpoint tests, summary.json).
std::uint64_t state_hash(const State& state);

}  // namespace mca
