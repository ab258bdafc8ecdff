#pragma once
// Turns a SceneDef into a Model: simple-cubic lattice fill of each object (physics.md sec. 1, volume
// mode), face-neighbour links, material groups by region, strength classes, projectiles, grips and the
// stable time step. Never calls the solver.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/environment.hpp"
#include "core/model.hpp"
#include "mca/scene.hpp"

namespace mca::lattice {

// Number of automata the scene's objects give at spacing d (no allocation of the model).
std::int64_t count_automata(const SceneDef& scene, double spacing);
// Spacing that puts the automata count within 2 % of target; throws mca::Error when no spacing can.
double spacing_for_target(const SceneDef& scene, std::int64_t target);
// The spacing a scene asks for (target_automata wins over spacing when given).
double scene_spacing(const SceneDef& scene);

// The spacings a scene's lattice can take: solver.spacing's range (SolverDef::kMinSpacing..kMaxSpacing),
// narrowed so that an automaton's mass (rho d^3) and moment of inertia (rho d^5 / 6) are normal float32
// numbers for every material that fills lattice automata (with room for the random lattice's cells, larger
// and smaller than d^3), for advice that can be followed. For concrete (2,400 kg/m^3): 1.2e-8 to 1.1e7 m.
struct SpacingRange {
  double lo = SolverDef::kMinSpacing, hi = SolverDef::kMaxSpacing;
  bool lo_float32 = false, hi_float32 = false;  // whether float32 sets the bound (else solver.spacing's range)
};
SpacingRange spacing_range(const SceneDef& scene);
SpacingRange spacing_range(double density);
// "the least spacing (7.9e-09 m: ...)" for a message: the bound and what sets it.
std::string spacing_bound(const SpacingRange& r, bool least);
// For messages: "about S m gives 10,000 automata" for objects of `volume` m^3 (S = cbrt(volume / 1e4)),
// or, where S lies outside `range`, that no spacing does and the objects must be scaled.
std::string ten_thousand_spacing(double volume, const SpacingRange& range);

// The memory a run of `scene` may take (mca::memory_limit of its solver.max_memory_gb).
using mca::MemoryLimit;
MemoryLimit memory_limit(const SceneDef& scene);

// Model::lattice_stiffness of a lattice of jitter a (SolverDef::lattice_jitter): the factor on its moduli
// that gives a block of it the input Young's modulus.
float jitter_stiffness(double a);

// Critical time step of a built model (time_step.cpp, physics.md sec. 7): above it symplectic Euler is
// unstable; `limited_by` names what sets it (for messages). `ranges`: how many ranges of automata the
// random lattice's power iteration runs in parallel (0: at least 4,096 automata each, about four per
// thread); every count gives the same bits (a test's knob).
struct TimeStepBound {
  double dt = 0;
  std::string limited_by;
  double objects_dt = 0;  // the automata's own bound, before the projectiles'
};
TimeStepBound critical_time_step(const Model& model, std::size_t ranges = 0);
// Per automaton of explicit links (a surface-mode object's or the random lattice's): the critical step of
// its own rows of the Gershgorin bound (its explicit links, contacts, many-body term and dashpots);
// infinite for the cubic lattice's automata. critical_time_step's surface part is at most the smallest of
// these.
std::vector<double> surface_automaton_steps(const Model& model);

// Sets the model's time step and calibrates the contact dashpots for it (Model::zeta_pair): called by
// build_model and again by whoever shortens the step (the Engine fits a whole number of steps in a frame).
// Returns how many damping ratios it calibrated by simulating a contact (discrete_damping_ratio).
std::size_t set_time_step(Model& model, float dt);

// Progress of a long model build on stderr, as `mca run` shows a run's: while one is alive, build_model
// names its stages to it (BuildProgress::stage); once a build has taken 2 s, the stage in progress is
// shown (rewritten in place on a terminal, a line per stage at most every 10 s otherwise), and the time
// the build took when it ends. Commands that print progress hold one around the build (not with
// --quiet); without one, stage() does nothing. One per thread.
class BuildProgress {
 public:
  BuildProgress();
  ~BuildProgress();
  BuildProgress(const BuildProgress&) = delete;
  BuildProgress& operator=(const BuildProgress&) = delete;
  // The stage the build of this thread enters (a no-op when none is alive).
  static void stage(const std::string& what);

 private:
  struct Shared;
  std::unique_ptr<Shared> shared_;
  BuildProgress* outer_;
};

// Builds the model. Throws mca::Error for scenes that cannot be built (projectile inside an object,
// empty grip, memory estimate over the limit, ...). `placed`: the first `placed` projectiles are in flight
// in a state the run continues from (the viewer's earlier shots and the scene's own): their positions are
// where the state has them, so they are not checked against the objects' starting positions, the ground
// or each other; every later one is checked against all of these.
Model build_model(const SceneDef& scene, std::size_t placed = 0);

}  // namespace mca::lattice
