#pragma once
// What every backend works out from the model once, before the first step: per automaton its inverses and
// strengths, per pair of groups the links' and contacts' constants, per explicit link (surface mode, the
// random lattice) its constants and bending spring, and the lists the passes walk (the automata with
// explicit links, each one's links with the end it is, the grips' members). The CPU backend steps with
// these arrays; the CUDA backend copies them to the device. One text, so both start from the same bits.
#include <array>
#include <cstdint>
#include <vector>

#include "backend/cpu/aligned.hpp"
#include "backend/cpu/lattice_kernels.hpp"
#include "backend/step_kernels.hpp"  // kSecondEndBit
#include "core/model.hpp"
#include "core/state.hpp"
#include "physics/contact_law.hpp"

namespace mca {

struct StepConstants {
  template <class T>
  using Array = cpu::LineArray<T>;

  // Per automaton: inverses, and the strengths times the class factor (a link takes the weaker end's).
  Array<float> inv_mass, inv_inertia, inv_volume, tensile, compressive, break_strain;
  // Per pair of groups (g * groups + h): the lattice links' constants; per group: the free-axis factors
  // (volumetric_strain) and lambda / (2 G) (random_many_body).
  std::vector<cpu::PairConstants> pairs;
  std::vector<std::array<float, 4>> free_factor;
  std::vector<float> lambda_over_2g;
  bool strengthening = false;  // some group has a strengthening law
  bool one_group = false;      // every automaton is of one group

  // Explicit links (Model::ExplicitLinks), structure of arrays (cpu::ExplicitView).
  Array<float> ex_r0f, ex_inv_r0, ex_area, ex_to_stress, ex_G, ex_kt, ex_damp_n, ex_damp_t;
  Array<float> ex_soft;  // softening constants (empty: no link softens)
  Array<float> ex_k_twist, ex_k_in, ex_s_in;
  // What only a shell's link reads (its reference axis, out-of-plane and twisting constants): held only when
  // the model has shells (shells_any).
  Array<float> ex_k_out, ex_s_out, ex_s_twist, ex_m0x, ex_m0y, ex_m0z;
  bool shells_any = false;
  Array<std::uint8_t> ex_bends;  // 1: a shell's bending spring, 2: a random link's, 0: none
  std::vector<float> ex_area_r0;  // per explicit link: area r0 (the random lattice's many-body sum)
  Array<float> ex_tensile, ex_compressive, ex_strain;  // cpu::ExplicitView::tensile, ...
  // The automata that have explicit links, and per automaton (as E.of, from E.first) its explicit links
  // with kSecondEnd set where it is the link's j.
  static constexpr std::uint32_t kSecondEnd = kSecondEndBit;
  std::vector<std::uint32_t> explicit_automata;
  std::vector<std::uint32_t> ex_ends;
  std::vector<float> bend_c;  // per automaton: a shell's bending many-body constant D nu A (else 0)

  // Contact springs per pair of groups (and per group on the ground), when every automaton of a group has
  // the group's radius, mass and moment of inertia (uniform_bodies; lattices: always).
  bool uniform_bodies = false;
  std::vector<ContactSprings> pair_springs, ground_springs;

  std::vector<std::vector<std::uint32_t>> grip_members;  // per grip, its automata in order
  float r_max = 0;                                       // the largest automaton radius
  // Per projectile: (R + r_max)^2, a little widened (LatticeView::proj_reach2).
  std::vector<float> proj_reach2;
};

// Throws mca::Error for a model the step cannot hold (too many explicit links).
StepConstants build_step_constants(const Model& m);

// A LatticeView with its numbers from the model and the constants (sizes, the one material's body values,
// spacing, step, damping, gravity, flags): each backend adds its arrays, its lanes and the step's flags.
cpu::LatticeView lattice_view_numbers(const Model& m, const StepConstants& K);

// Per automaton, its sound links (intact and undamaged) as the contact search counts them, from a state:
// 6 stands for boxed in (a cubic automaton with its six links, an interior automaton of the random lattice
// with all of its own); any other holds its count, at most 5.
void sound_link_counts(const Model& m, const State& s, std::uint8_t* count);

// The springs of a contact between automata i and j (l: Model::random_link_at_start(i, j)), and of
// automaton a on the ground.
ContactSprings automaton_pair_springs(const Model& m, std::uint32_t i, std::uint32_t j, std::int64_t l);
ContactSprings automaton_ground_springs(const Model& m, std::uint32_t a);

}  // namespace mca
