#pragma once
// One backend interface, several implementations (CPU now; CUDA later). Every backend computes the
// same function with the physics headers in src/physics; the CPU backend is the reference.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <type_traits>

#include "core/model.hpp"
#include "core/state.hpp"
#include "mca/error.hpp"
#include "render/draw_list.hpp"

namespace mca {

// Health flags a step returns (never an exception from inside a step). Each says what to change.
enum HealthFlag : std::uint32_t {
  kHealthy = 0,
  // A position, velocity, spin or orientation became NaN or infinite, or a ball's spin passed what its
  // orientation's integration follows (kLargestProjectileTurn): the time step is too large for the stiffest
  // spring (lower solver.safety or solver.time_step), or a material constant is extreme.
  kNonFinite = 1u << 0,
  // Kinetic + elastic energy grew past 10x the energy the run had at its start plus the work put in
  // since (gravity, grips, loads, kinematic projectiles): a blow-up that is still finite. Raised by
  // Engine::advance, which checks the energy after each call (physics.md sec. 7).
  kEnergyGrowth = 1u << 1,
};

struct StepHealth {
  std::uint32_t flags = kHealthy;
  std::int64_t step = -1;             // first step that raised a flag
  std::int64_t automaton = -1;        // an automaton where a non-finite value was seen
  std::int64_t projectile = -1;       // a projectile where a non-finite value was seen
  double energy = 0, budget = 0;      // kEnergyGrowth: the energy and the budget it exceeded [J]
};

struct Energies {
  double kinetic = 0;             // automata, translation + rotation [J]
  double elastic = 0;             // links (normal, many-body, shear) + contact springs [J]
  double contact = 0;             // the contact springs' part of `elastic` [J]
  double projectile_kinetic = 0;  // [J]
  double gravity_work = 0;        // work gravity did on automata and projectiles since the start [J]
  double grip_work = 0;           // work the grips did [J]
  double load_work = 0;           // work the [[load]] forces did [J]
  double projectile_work = 0;     // work the kinematic projectiles did [J]
  // What the bodies hold, and what was put in from outside since the start.
  double total() const { return kinetic + elastic + projectile_kinetic; }
  double external_work() const { return gravity_work + grip_work + load_work + projectile_work; }
};
class Backend {
 public:
  virtual ~Backend() = default;
  virtual std::string name() const = 0;
  // Takes the state to step from (by value: pass an rvalue to hand it over without a copy).
  virtual void upload(State state) = 0;
  // Advances n steps; stops early at the first step that raises a health flag.
  virtual StepHealth step(int n) = 0;
  virtual void download(State& state) const = 0;
  // Records the run's starting energy in the state (State::initial_energy), which needs the contact lists
  // upload builds: set once, right after the first upload of a new run.
  virtual void set_initial_energy(double energy) = 0;
  // The whole state, brought up to date first where the backend steps its own copy (the CUDA backend: a
  // download of every array; the CPU backend: its arrays gathered into the State).
  virtual const State& state() const = 0;
  // What a caller needs between calls without the whole state: the step, its time and the links broken so
  // far.
  virtual std::int64_t current_step() const = 0;
  virtual double current_time() const = 0;
  // The energies of the current state for Engine's check of the energy, and the run's starting energy
  // (State::initial_energy). The same bits on every backend (check_energies: compute_energies' terms summed
  // by a fixed tree), so the check stops a run at the same step on each; the CUDA backend computes them on
  // the device, without bringing the state up to date.
  virtual Energies energies() const = 0;
  virtual double initial_energy() const = 0;
  virtual std::int64_t broken_links() const = 0;
  // Why the backend stopped, where a step, a read or an upload failed (a GPU whose memory is full): the
  // error every call then raises; empty where none did.
  virtual std::string stopped() const { return {}; }
  // The draw list of the current state (render/draw_list.hpp) where the backend builds it without bringing
  // the whole state up to date (the CUDA backend: on the device); false where it does not (the CPU
  // backend, whose state is at hand; the links mode): render::make_snapshot then builds it from state().
  // With a target (null: none), the cubes and surface modes are written straight into its buffers where
  // the backend can (DrawList::shared_automata, shared_corners), else into the list.
  virtual bool draw_list(const render::SnapshotOptions&, const std::array<double, 3>& /*origin*/, render::DrawList&,
                         render::DrawTarget* /*target*/) const {
    return false;
  }
};

// What every backend's step shares.
// The clock: step x dt for a state on this time step (a new run, a resumed one: the same bits as an
// uninterrupted run), else from the state's own time on (a state from a run at another step: mca view's
// shots rebuild the model, and its step, with each new ball; the time went back by the ratio).
struct StepClock {
  double time0 = 0;
  std::int64_t step0 = 0;
  void start(const State& s, float dt) {
    const bool on_this_step = s.time == static_cast<double>(s.step) * dt;
    time0 = on_this_step ? 0 : s.time;
    step0 = on_this_step ? 0 : s.step;
  }
  double time(std::int64_t step, float dt) const { return time0 + static_cast<double>(step - step0) * dt; }
};
// What the CPU and CUDA backends share: the State they hand out (brought up to date from their own arrays
// when read after a step: sync_state), the clock, and the loop of step().
class StateBackend : public Backend {
 public:
  void download(State& s) const override { s = state(); }
  void set_initial_energy(double energy) override { S_.initial_energy = energy; }
  const State& state() const override {
    check_usable();
    if (stale_) {
      sync_state();
      stale_ = false;
    }
    return S_;
  }
  std::int64_t current_step() const override { return S_.step; }
  double current_time() const override { return S_.time; }
  double initial_energy() const override { return S_.initial_energy; }
  std::int64_t broken_links() const override { return S_.broken_by[0] + S_.broken_by[1]; }
  std::string stopped() const override { return failed_; }
  // one_step() `steps` times, last_step_ set on the last (what is only read between calls, the averaged
  // stress tensor and the applied forces, is written then); stops at the first step whose one_step()
  // returns other than kAllFinite: an automaton (>= 0) or -2 - p for projectile p with a value not finite.
  StepHealth step(int steps) override {
    check_usable();
    StepHealth h;
    for (int k = 0; k < steps; ++k) {
      last_step_ = k + 1 == steps;
      stale_ = true;
      const std::int64_t done = S_.step;
      const double time = S_.time;
      const std::int64_t bad = or_fail([&] { return one_step(); }, [&] {
        S_.step = done;  // (the step it stopped in is not done)
        S_.time = time;
        return "inside step " + std::to_string(done + 1) + ", which left its state part of a step";
      });
      if (bad != kAllFinite) {
        h.flags |= kNonFinite;
        h.step = S_.step;
        if (bad >= 0) h.automaton = bad;
        else h.projectile = -2 - bad;
        break;
      }
    }
    return h;
  }

 protected:
  static constexpr std::int64_t kAllFinite = -1;
  virtual std::int64_t one_step() = 0;
  // f(), where an error (a GPU whose memory is full, a host out of memory) can leave the device's arrays or
  // the state incomplete: it is thrown on as it came, and from then on check_usable() throws an mca::Error
  // that says so, and where (`where()`, called then: "inside step 12, which left ..."). step(), the state's
  // reads and the CUDA backend's energies, drawing and upload check.
  template <class F, class Where>
  std::invoke_result_t<F&> or_fail(F&& f, Where&& where) {
    try {
      return f();
    } catch (const std::exception& e) {
      failed_ = "this simulation stopped " + where() +
                ": it cannot step further or be read (start again from the scene or from a checkpoint saved "
                "before); the cause: " + e.what();
      throw;
    }
  }
  void check_usable() const {
    if (!failed_.empty()) throw Error(failed_);
  }
  // Brings S_'s arrays up to date with the backend's own (called by state() after a step).
  virtual void sync_state() const = 0;
  mutable State S_;
  mutable bool stale_ = false;  // S_'s arrays are behind the backend's own
  std::string failed_;          // why a step failed (empty: none did)
  bool last_step_ = true;
  StepClock clock_;
};

std::unique_ptr<Backend> make_cpu_backend(const Model& model);
// The CUDA backend's step run on the host, thread by thread in order (src/backend/cuda/host_device.hpp):
// the same bits as the CUDA backend and, by construction and test, as the CPU backend. Slow (one core,
// no SIMD): for tests of the GPU algorithm on machines without a GPU.
std::unique_ptr<Backend> make_cuda_emulation_backend(const Model& model);
// How the CUDA backend (and its emulation) runs a step's links and automata on a lattice without explicit
// links, as the environment variable MCA_CUDA_LATTICE says: in one kernel, each automaton computing its six
// links (fused, the default), or in two, the links' results through memory (split). "fused:B" asks the
// compiler to keep the fused kernel's registers to what B blocks of 256 threads on a multiprocessor leave
// (B = 2, 3 or 4; fused is fused:3), for measuring occupancy against spills on a GPU. The same bits every
// way (docs/benchmarks.md compares their speed). An mca::Error naming the variable for another value.
struct CudaLattice {
  bool fused = true;
  int blocks = 3;  // the fused kernel's blocks per multiprocessor
};
CudaLattice cuda_lattice();
// The GPU the CUDA backend would run on (its name, memory and compute capability), or "" with the reason in
// *why: a build without CUDA device code, no driver, no device.
std::string cuda_device(std::string* why = nullptr);
// Why a CUDA runtime of version `runtime` cannot start on a driver of version `driver` (both as CUDA gives them,
// 1000 * major + 10 * minor; a driver of 0: none installed, -1: its version not read), for cuda_device's
// reason: which driver it needs (a runtime of CUDA 12 or 13 runs on the driver series of that major version or
// later: 525 and 580) and the ways out.
std::string cuda_driver_problem(int driver, int runtime);
// The CUDA backend on that GPU; throws mca::Error with the reason when there is none.
std::unique_ptr<Backend> make_cuda_backend(const Model& model);
// The CUDA device's own primitives against their serial twins (the emulation's, host_device.hpp) on random
// inputs: stable sorts (one block up to 1,024 elements, CUB above; ties, 32- and 64-bit keys), scans (one
// block up to 4,096, CUB above) and one-block launches of several phases. "" where all agree, else the
// first difference (a CudaDevice test; throws mca::Error without a GPU).
std::string cuda_primitives_check();
// A device array larger than the GPU: "" where it is refused with the full GPU's mca::Error, nothing
// counted as held, and the device then goes on (an array of 1 MB made and read back); else what went
// wrong (a CudaDevice test; throws mca::Error without a GPU).
std::string cuda_memory_check();

// Initial state of a model: automata at rest in the lattice (with their object's velocity), all links
// intact, projectiles at their start.
State initial_state(const Model& model);

// Reference (serial, double accumulation) energies of a state, taken at the positions of the last
// force evaluation with velocities in step with them (see energy.cpp).
Energies compute_energies(const Model& model, const State& state);
// Energies of exactly the positions and velocities given.
Energies compute_energies_at(const Model& model, const State& state);
// compute_energies' energies as Engine's check of the energy takes them on every backend (Backend::energies):
// the same terms, summed by chunk_sum's fixed tree (energy_terms.hpp) as the CUDA backend sums them on the
// device, so that a run stops or goes on at the same step on each (equal to compute_energies' to rounding).
Energies check_energies(const Model& model, const State& state);

}  // namespace mca
