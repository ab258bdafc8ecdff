#pragma once
// The mutable state of a run (physics.md sec. 2). Checkpoints save exactly this, plus the scene.
#include <cstdint>
#include <vector>

#include "core/math.hpp"

namespace mca {

enum class BreakCriterion : std::uint8_t { displacement = 0, stress = 1 };

struct BreakRecord {
  std::int64_t step;
  std::uint32_t link;
  BreakCriterion criterion;
};

// Spring histories of a contact (physics/contact_law.hpp): zero while the pair is apart.
struct ContactHistory {
  Vec3 ut;  // accumulated tangential displacement
  Vec3 mr;  // rolling (tangential part) and twisting (normal part) spring torque on the first body
};

// An unlinked pair within contact range (physics.md sec. 6).
struct ContactPair {
  std::uint32_t i, j;  // i < j
  ContactHistory h;
  // How the pair touches, for two automata with free sides (Model::face): kApart, kAsSpheres, or as faces,
  // kAsFaces + 6 s_i + s_j by the sides s_i of i and s_j of j it began on (ModelView::face_start); a
  // contact keeps its way until the pair parts (step_kernels.hpp, pair_contact). 0 for the others.
  std::uint8_t face = 0;
  static constexpr std::uint8_t kApart = 0, kAsSpheres = 1, kAsFaces = 2;
};

// A contact of a projectile or the ground with one automaton (the automaton is the first body).
struct BodyContact {
  std::uint32_t automaton;
  ContactHistory h;
};

// A contact between two projectiles p < q (p is the first body).
struct ProjectilePair {
  std::uint32_t p, q;
  ContactHistory h;
};

struct ProjectileState {
  DVec3 position;
  DVec3 velocity, angular_velocity;  // double, as the automata's (State::v)
  Quat orientation;
  Vec3 force;                         // force the automata put on it in the last step (for statistics)
  std::vector<BodyContact> contacts;  // sorted by automaton
  ContactHistory ground;              // its contact with the ground
  double work = 0;                    // work a kinematic projectile did on the automata since the start [J]
};

struct State {
  std::int64_t step = 0;
  double time = 0;

  // automata
  std::vector<DVec3> x;         // positions (double: see math.hpp)
  // Velocities and angular velocities, double: a float32 velocity of 100 m/s resolves 7.6e-6 m/s, and
  // gravity's g dt of a step of 1e-6 s (9.8e-6 m/s) was rounded to one ulp or to nothing (a free body
  // fell at 0 to 1.8 g). The forces use their differences rounded to float (math.hpp, delta).
  std::vector<DVec3> v, w;
  std::vector<Quat> q;
  std::vector<Sym3> s;          // averaged (Love) stress, written on the last step of each Backend::step call
  // trace(s) / 3 of the last step (the fracture criterion's p, formed every step; a random-lattice
  // automaton's, which no criterion reads, only on the last step of a Backend::step call).
  std::vector<float> mean_stress;
  // Force and torque applied in the last step, at the positions x - dt v. With them a state gives the
  // velocities in step with those positions (velocity Verlet's v_n = v_{n+1/2} - dt/2 a_n), which the
  // energy bookkeeping needs: the stored v is the half-step velocity of the symplectic Euler update.
  std::vector<Vec3> f, t;

  // links
  std::vector<std::uint8_t> intact;
  std::vector<Vec3> link_ut;    // tangential displacement in the pair's frame
  // Per explicit link (Model::ExplicitLinks; empty without): a shell's link, the moment of its bending and
  // twisting spring on its first end, as components about the link, the shell's normal and their cross
  // product (physics/link_law.hpp, link_bending); a random-lattice link, its ends' relative rotation
  // (world, rad; volume_link_bending), 0 at link_bending = 0.
  std::vector<Vec3> link_moment;
  // Per link slot, when the model softens (Model::softening; empty otherwise): the link's damage, 0 to 1
  // (physics/fracture.hpp, link_softening_test), 0 at the start.
  std::vector<float> link_damage;

  std::vector<ContactPair> contacts;        // sorted by (i, j)
  std::vector<BodyContact> ground_contacts;  // automata within reach of the ground, sorted by automaton
  std::vector<DVec3> x_at_rebuild;           // positions when the contact lists were last rebuilt

  std::vector<ProjectileState> projectiles;
  std::vector<ProjectilePair> projectile_contacts;  // sorted by (p, q)

  std::vector<BreakRecord> breaks;
  std::int64_t broken_by[2] = {0, 0};       // by BreakCriterion
  // Total energy of the run's start (kinetic + elastic, frame 0): with the external work it is the
  // budget the blow-up check compares the energy with, kept across checkpoints.
  double initial_energy = 0;
  std::vector<double> grip_work;            // work done by each grip [J]
  std::vector<Vec3> grip_force;             // force each grip exerts on the body in the last step [N]
};

}  // namespace mca
