#pragma once
// The public C++ entry point: build a scene, step it, read frames. Only the standard library and the
// definition structs of scene.hpp appear here; the solver's own types stay inside the library.
//
//   mca::SceneDef scene = ...;              // fill it, or read a TOML file with the io library
//   mca::Simulation sim(scene);             // throws mca::Error for a scene that cannot be built
//   while (sim.time() < 0.05) {
//     if (sim.advance(sim.steps_per_frame()) != mca::StepStatus::ok) break;
//     const mca::Frame f = sim.frame();     // positions, velocities, fragments, ...
//   }
#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "mca/scene.hpp"

namespace mca {

// A snapshot of the automata and projectiles, for renderers and analysis. Per-automaton arrays are in
// the model's automaton order (objects in scene order, each in lattice order).
struct Frame {
  std::int64_t step = 0;
  double time = 0;                                   // [s]
  std::vector<std::array<float, 3>> position;        // centres [m]
  std::vector<std::array<float, 3>> velocity;        // [m/s]
  std::vector<std::array<float, 4>> orientation;     // unit quaternions (w, x, y, z)
  std::vector<std::int32_t> fragment;                // connected components of intact links, 0 = heaviest
  std::vector<float> damage;                         // share of the automaton's links that broke
  std::vector<std::array<float, 3>> projectile_position;
  std::int64_t broken_links = 0;
  std::int32_t fragments = 0;
};

enum class StepStatus {
  ok,
  // A position or velocity became non-finite: the time step is too large for the stiffest spring
  // (lower solver.safety, remove solver.time_step, or reduce a strengthening alpha).
  unstable,
};

class Simulation {
 public:
  explicit Simulation(const SceneDef& scene);
  ~Simulation();
  Simulation(Simulation&&) noexcept;
  Simulation& operator=(Simulation&&) noexcept;

  std::size_t automata() const;
  std::size_t links() const;
  double time_step() const;         // [s]
  int steps_per_frame() const;      // steps in one output frame of the scene's frame rate
  double time() const;              // simulated time so far [s]

  // Advances n steps; stops at the first unstable one.
  StepStatus advance(int steps);
  Frame frame() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mca
