#include "core/model.hpp"
#include "core/model_view.hpp"

#include "core/state.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca {

void automaton_damage(const Model& m, const std::uint8_t* intact, const float* link_damage, float* out) {
  const AutomatonLinks links = m.automaton_links();
  for (std::size_t a = 0; a < m.size(); ++a) out[a] = automaton_damage_of(links, a, intact, link_damage);
}

std::size_t estimate_memory_bytes(std::size_t automata, std::size_t explicit_links, std::size_t random_automata) {
  // What a run holds at its peak, counted from the arrays (and checked against the measured peak resident
  // size: Cli.MemoryEstimateMatchesThePeak). Links live in the three slots of each automaton (one per
  // axis, kept whether the link exists or not), so everything is per automaton:
  //   model 88      centre 24, velocity 12, mass, radius, inertia, volume 16, class factor 4, group and
  //                 class 2, object 4, grip 2, neighbour tables 24 (up and down along each axis)
  //   state 179     x 24, v 12, w 12, q 16, averaged stress 24, mean stress 4, force and torque 24,
  //                 rebuild positions 24; per slot intact 1, shear displacement 12 (39)
  //   backend 346   positions and rebuild positions 48, v, w, q 40, inverses and strengths 24, contact
  //                 sums 49, flags 3, block runs 3; per slot shear displacement 12, link direction,
  //                 force, torque, stress trace and many-body term 44, break list 4 (180)
  //   output 60     frame output and fragments
  //   contacts 64   about one unlinked pair of 32 bytes per automaton once it has broken up, two lists
  //                 while the list is rebuilt
  //   slack 50      heap pages the allocator keeps after the build's temporary arrays are freed (the
  //                 resident peak at 100,000 automata is 45 MB above the heap's peak of 74.5 MB, measured
  //                 with valgrind's massif; a run of 100 automata holds 41.8 MB; 30 until 2026-12-08, when
  //                 Cli.MemoryEstimateMatchesThePeak's cubic block peaked at 122.5 MB against 122.7 counted)
  //   fixed 46 MB   program, libraries, thread stacks: 10 MB, and 30 MB of clean pages of the mesh
  //                 libraries mapped at start-up (OpenVDB's symbol tables alone are 27 MB), shared with
  //                 every other process using them (a run of 160 automata peaked at 44.7 MB on 2026-12-08,
  //                 one of 1,728 on the random lattice 49.5 MB against 46.2 MB counted with 42 MB fixed).
  // Explicit links (surface mode) come on top, per link:
  //   model 48      ends 8, rest length 8, cross-section and edge 8, shell normal 12, two entries in the
  //                 per-automaton index 8, plus its offsets per automaton (counted here, per link, as 4)
  //   state 25      intact 1, shear displacement 12, bending moment 12
  //   backend 168   shear displacement and moment 24, constants 32, bending constants and normal 36, the
  //                 kernels' direction, strain, force and torque 40, break list 4, many-body weight and
  //                 gather list 16, padding 16
  constexpr std::size_t per_automaton = 88 + 179 + 346 + 60 + 64 + 50, per_explicit_link = 48 + 25 + 168;
  // A random lattice's automaton adds, on top of its explicit links: its cell's centre 24 (Model::cell0),
  // the boxed and free-face flags 5, and about 280 of what was measured and is not itemised above (its
  // contact lists are longer: a broken link's pair touches at its initial distance), less what its
  // links (about 7.4 per automaton) do not hold of a shell's link counted above (the reference axis, the
  // out-of-plane and twisting constants and the curvature, 28 each: about 207). Measured: blocks of
  // 50,000, 100,000 and 200,000 automata (runs' peaks 170, 299 and 557 MB), which this counts at 173, 306
  // and 573 MB.
  // (2026-12-08: Cli.MemoryEstimateMatchesThePeak's block of 100,000 peaked at 310.6 MB where 100 bytes
  // counted 310.1 MB; 160 now.)
  constexpr std::size_t per_random_automaton = 160;
  return automata * per_automaton + explicit_links * per_explicit_link + random_automata * per_random_automaton +
         46'000'000;
}

std::size_t estimate_rubble_bytes(std::size_t automata, std::size_t random_automata) {
  // What a run holds above estimate_memory_bytes once its objects have broken down to single automata:
  // the contact pairs, counted there at one an automaton. Rubble of the random lattice keeps about 5.9
  // pairs an automaton (a broken link's pair touches at its initial distance), of the cubic lattice 2.6;
  // each pair holds 32 bytes in the list, 60 in the contact pass's output (kept at up to twice the list's
  // length) and, while the list is rebuilt, the old list and the chunks' lists; the rubble on the ground
  // adds its ground contacts. Measured: 0.4 m glass cubes at 1 cm (64,000 automata) thrown on the ground at
  // 80 m/s, 1.5 ms, 2 threads, peaked at 305 MB (random lattice, 387,404 of 468,007 links broken) and 145
  // MB (cubic) against 210 and 91 MB from estimate_memory_bytes: 1,480 and 838 bytes an automaton more. With
  // every link broken (a random block of 12,350 automata at 4 cm, all 86,451 links) 1,990 more. A box of
  // 29,791 automata at 2 cm dropped on the ground at 300 m/s, every automaton its own fragment: 2,249 more
  // (random) and 1,071 (cubic): counted at 2,300 and 1,100.
  constexpr std::size_t per_random_automaton = 2300, per_automaton = 1100;
  return (automata - random_automata) * per_automaton + random_automata * per_random_automaton;
}

ModelView Model::view() const {
  ModelView v;
  v.n = size();
  v.groups = groups.size();
  v.group = group.data();
  v.object = object.data();
  v.object_random = object_random.empty() ? nullptr : object_random.data();
  v.radius = radius.data();
  v.mass = mass.data();
  v.inertia = inertia.data();
  v.position0 = position0.data();
  if (!explicit_links.first.empty()) {
    v.first = explicit_links.first.data();
    v.of = explicit_links.of.data();
  }
  v.ei = explicit_links.i.data();
  v.ej = explicit_links.j.data();
  v.r0 = explicit_links.r0.data();
  v.area = explicit_links.area.data();
  v.group_params = groups.data();
  v.contact = contact.data();
  v.grip = grip_velocity.empty() ? nullptr : grip.data();
  v.lattice_stiffness = lattice_stiffness;
  v.lattice_lambda = lattice_lambda;
  if (!face.empty()) {
    v.face = face.data();
    v.axes = object_axes.front().data();
  }
  return v;
}

double Model::contact_reach(std::size_t i, std::size_t j, std::int64_t l) const { return view().contact_reach(i, j, l); }
std::int64_t Model::random_link_at_start(std::size_t i, std::size_t j) const { return view().random_link_at_start(i, j); }
std::int64_t Model::link_at_start(std::size_t i, std::size_t j) const { return view().link_at_start(i, j); }
float Model::contact_length(std::size_t i, std::size_t j, std::int64_t l) const { return view().contact_length(i, j, l); }

LinkBendingConstants Model::explicit_bending(std::size_t k) const {
  const std::uint32_t i = explicit_links.i[k], j = explicit_links.j[k];
  const GroupParams &gi = groups[group[i]], &gj = groups[group[j]];
  const auto& E = explicit_links;
  if (!random_automaton(i))
    return link_bending_constants(harmonic(gi.youngs, gj.youngs), 0.5 * (gi.poisson + gj.poisson), E.r0[k], E.edge[k],
                                  E.area[k] / E.edge[k]);
  if (!(lattice_bending > 0.0f)) return {};
  const float s = lattice_stiffness;
  return volume_bending_constants(s * harmonic(gi.youngs, gj.youngs), s * harmonic(gi.shear_modulus, gj.shear_modulus),
                                  E.r0[k], E.edge[k], lattice_bending);
}

ContactSprings Model::pair_contact_springs(std::size_t i, std::size_t j, std::int64_t l, float zeta) const {
  return view().pair_contact_springs(i, j, l, zeta);
}

}  // namespace mca
