#pragma once
// Turns a SceneDef into a Model: simple-cubic lattice fill of each object (physics.md sec. 1, volume
// mode), face-neighbour links, material groups by region, strength classes, projectiles, grips and the
// stable time step. Never calls the solver.
#include <cstdint>

#include "core/model.hpp"
#include "mca/scene.hpp"

namespace mca::lattice {

// Number of automata the scene's objects give at spacing d (no allocation of the model).
std::int64_t count_automata(const SceneDef& scene, double spacing);
// Spacing that puts the automata count within 2 % of target; throws mca::Error when no spacing can.
double spacing_for_target(const SceneDef& scene, std::int64_t target);
// The spacing a scene asks for (target_automata wins over spacing when given).
double scene_spacing(const SceneDef& scene);

// Stable time step of a built model (physics.md sec. 7): min(C d / c_p, C sqrt(m_min / k_max)).
double stable_time_step(const Model& model, double safety);

// Builds the model. Throws mca::Error for scenes that cannot be built (projectile inside an object,
// empty grip, memory estimate over the limit, ...).
Model build_model(const SceneDef& scene);

}  // namespace mca::lattice
