#pragma once
// The Model: everything the solver needs that does not change during a run (built once from a
// SceneDef by the lattice builder). The State (state.hpp) holds what the step changes.
// Hot data for the step is kept in flat structure-of-arrays form; names and statistics live elsewhere.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/math.hpp"

namespace mca {

// Material constants of one automata group, in the form the step uses (physics.md sec. 3).
struct GroupParams {
  float youngs = 0, poisson = 0, density = 0;
  float shear_modulus = 0;   // G = E / (2 (1 + nu))
  float lame_lambda = 0;     // lambda = E nu / ((1 + nu)(1 - 2 nu)) = D * K / 3
  float tensile_strength = 0, compressive_strength = 0, fracture_strain = 0;
  float friction = 0, restitution = 0;
  int strengthening = 0;     // 0 none, 1 exponential, 2 quadratic (paper eq. 7)
  float strengthening_alpha = 0;
};

struct ProjectileParams {
  std::string name;
  float radius = 0, mass = 0, inertia = 0;
  int group = 0;             // material of the projectile (index into Model::groups)
  bool kinematic = false;
  Vec3 position, velocity, angular_velocity;
};

struct Model {
  // --- automata (n) ---
  std::vector<Vec3> position0;    // initial centres
  std::vector<Vec3> velocity0;    // initial velocities
  std::vector<float> mass, radius, inertia, volume;
  std::vector<std::uint8_t> group;         // index into groups
  std::vector<std::uint8_t> strength_class;  // 1..4
  std::vector<float> class_factor;         // k_c of the automaton's class
  std::vector<std::int16_t> object;        // index of the scene object it came from
  std::vector<std::int16_t> grip;          // index of the grip holding it, -1 if free
  std::vector<Vec3> load;                  // constant external force; empty when the scene has no loads

  // --- links (stored once per pair, i < j) ---
  std::vector<std::uint32_t> link_i, link_j;
  std::vector<float> link_r0, link_area;
  std::vector<std::uint8_t> link_axis;     // lattice axis 0,1,2 of the link (for the volumetric strain)
  // CSR: the links of automaton a are adj_link[adj_begin[a] .. adj_begin[a+1]), in link order.
  std::vector<std::uint32_t> adj_begin, adj_link;

  // --- scene-level ---
  std::vector<GroupParams> groups;
  std::vector<std::string> group_names;
  std::vector<std::string> object_names;
  std::vector<ProjectileParams> projectiles;
  std::vector<Vec3> grip_velocity;
  std::vector<std::string> grip_names;
  bool ground = false;
  float ground_height = 0, ground_friction = 0, ground_restitution = 0;
  Vec3 gravity;
  Vec3 up{0, 0, 1};
  float spacing = 0;             // lattice spacing d
  float dt = 0;                  // time step
  float skin = 0;                // contact search skin [m]
  float link_damping = 0, local_damping = 0, stress_coefficient = 1;
  double total_mass = 0;

  std::size_t size() const { return mass.size(); }
  std::size_t link_count() const { return link_i.size(); }
};

// Bytes the model and its state take, for `mca info` and the memory check.
std::size_t estimate_memory_bytes(std::size_t automata, std::size_t links);

}  // namespace mca
