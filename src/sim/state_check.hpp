#pragma once
// A State from outside the program (a checkpoint file) is untrusted input: a backend indexes its arrays
// with the model's counts and the state's own indices without checking them, so a damaged or edited
// state must be refused before it reaches one.
#include <cstdint>
#include <string>

#include "core/model.hpp"
#include "core/state.hpp"

namespace mca {

// FNV-1a over what the model's automata, links and projectiles are (counts, initial positions and
// velocities, masses, radii, materials, strength classes, objects, grips, links, time step, spacing,
// projectile parameters, ...). A checkpoint stores it, so that a resume can tell whether its embedded
// scene still builds the model its state was saved from. Equal for equal models on one build of mca.
std::uint64_t model_fingerprint(const Model& model);

// Checks the state against the model: every array size, every index, the link and break bookkeeping,
// the sort orders the backend relies on, and that every number is finite. Throws mca::Error starting
// with `source` (e.g. "checkpoint 'run/checkpoints/frame_000010.mcack'") that says what is wrong.
void check_state(const Model& model, const State& state, const std::string& source);

// What a checkpoint of a run holds beyond what check_state asks of every state (a state taken from a running
// simulation, as mca view's shots are, keeps its time while the model's step changes): its time is its step
// count times the model's step. Throws as check_state does.
void check_run_clock(const Model& model, const State& state, const std::string& source);

}  // namespace mca
