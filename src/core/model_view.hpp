#pragma once
// The parts of a Model that a step's per-pair rules read (which link joined two automata at the start,
// how far apart they touch, the springs of their contact), over plain pointers: the same functions run on
// the host (Model's own methods call them) and on a CUDA thread over device copies of the arrays.
#include <cstddef>
#include <cstdint>

#include "core/math.hpp"
#include "physics/contact_law.hpp"

namespace mca {

struct ModelView {
  std::size_t n = 0;
  std::size_t groups = 0;
  const std::uint8_t* group = nullptr;
  const std::int32_t* object = nullptr;
  const std::uint8_t* object_random = nullptr;  // null: no object is of the random lattice
  const float *radius = nullptr, *mass = nullptr, *inertia = nullptr;
  const DVec3* position0 = nullptr;
  // Explicit links (Model::ExplicitLinks); first null when there are none.
  const std::uint32_t *first = nullptr, *of = nullptr, *ei = nullptr, *ej = nullptr;
  const double* r0 = nullptr;
  const float* area = nullptr;
  const GroupParams* group_params = nullptr;
  const ContactMaterial* contact = nullptr;  // contact[a * groups + b]
  const std::int16_t* grip = nullptr;        // Model::grip; null: no grips
  float lattice_stiffness = 1, lattice_lambda = 1;

  MCA_HD bool random_automaton(std::size_t a) const { return object_random && object_random[object[a]] != 0; }
  // Held by a grip: it moves with the grip and does not turn, whatever acts on it.
  MCA_HD bool held(std::size_t a) const { return grip && grip[a] >= 0; }
  // The explicit link that joined automata i and j at the start, or -1.
  MCA_HD std::int64_t link_at_start(std::size_t i, std::size_t j) const {
    if (!first) return -1;
    for (std::uint32_t k = first[i]; k < first[i + 1]; ++k) {
      const std::uint32_t l = of[k];
      if (ei[l] == j || ej[l] == j) return l;
    }
    return -1;
  }
  MCA_HD std::int64_t random_link_at_start(std::size_t i, std::size_t j) const {
    return random_automaton(i) && random_automaton(j) ? link_at_start(i, j) : -1;
  }
  MCA_HD double contact_reach(std::size_t i, std::size_t j, std::int64_t l) const {
    const double r = static_cast<double>(radius[i]) + radius[j];
    if (!random_automaton(i) || !random_automaton(j)) return r;
    if (l >= 0) return r0[l];  // (its rest length: this distance, formed the same way)
    const DVec3 d = ddelta(position0[i], position0[j]);
    const double dist = sqrt(dot(d, d));
    return dist < r ? dist : r;  // std::min(r, dist)
  }
  MCA_HD const ContactMaterial& contact_material(std::size_t a, std::size_t b) const { return contact[a * groups + b]; }
  MCA_HD float contact_length(std::size_t i, std::size_t j, std::int64_t l) const {
    if (l < 0) return 2.0f * fminf(radius[i], radius[j]);
    const GroupParams &gi = group_params[group[i]], &gj = group_params[group[j]];
    const float s = lattice_stiffness, sl = lattice_lambda;
    const float k = link_normal_stiffness(s * harmonic(gi.shear_modulus, gj.shear_modulus), sl * gi.lame_lambda,
                                          sl * gj.lame_lambda, area[l], static_cast<float>(r0[l]));
    return k / contact_material(group[i], group[j]).youngs;
  }
  MCA_HD ContactSprings pair_contact_springs(std::size_t i, std::size_t j, std::int64_t l, float zeta) const {
    return contact_springs(contact_material(group[i], group[j]), zeta, contact_length(i, j, l),
                           reduced(radius[i], radius[j]), reduced(mass[i], mass[j]), reduced(inertia[i], inertia[j]));
  }
  // Where one of the pair is held (held(i) != held(j)): the free one's mass and moment of inertia move
  // alone, as against the ground or a kinematic ball (the pair's reduced ones gave an automaton bouncing
  // off a held one a restitution of 0.275 for the pair's 0.20); zeta_held: Model::zeta_pair_held.
  MCA_HD ContactSprings held_pair_contact_springs(std::size_t i, std::size_t j, std::int64_t l,
                                                  const float* zeta_held) const {
    const std::size_t f = held(i) ? j : i, h = held(i) ? i : j;
    return contact_springs(contact_material(group[i], group[j]), zeta_held[group[f] * groups + group[h]],
                           contact_length(i, j, l), reduced(radius[i], radius[j]), mass[f], inertia[f]);
  }
};

}  // namespace mca
