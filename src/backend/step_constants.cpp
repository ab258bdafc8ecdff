#include "backend/step_constants.hpp"

#include <algorithm>
#include <string>

#include "mca/error.hpp"
#include "physics/fracture.hpp"
#include "physics/link_law.hpp"

namespace mca {

ContactSprings automaton_pair_springs(const Model& m, std::uint32_t i, std::uint32_t j, std::int64_t l) {
  // (Model::contact_length: a random-lattice pair that a link joined presses with that link's stiffness.)
  return m.pair_contact_springs(i, j, l, m.zeta_pair[m.group[i] * m.groups.size() + m.group[j]]);
}

ContactSprings automaton_ground_springs(const Model& m, std::uint32_t a) {
  return body_contact_springs(m.ground_contact[m.group[a]], m.zeta_ground[m.group[a]], m.radius[a], INFINITY, m.mass[a],
                              m.inertia[a]);
}

void sound_link_counts(const Model& m, const State& s, std::uint8_t* count) {
  for (std::size_t a = 0; a < m.size(); ++a) {
    std::uint32_t c = 0, all = 0;
    m.for_each_link_of(a, [&](std::size_t l) {
      c += s.intact[l] && !(!s.link_damage.empty() && s.link_damage[l] > 0);
      ++all;
    });
    count[a] = static_cast<std::uint8_t>(m.boxed.empty() ? c : m.boxed[a] && c == all ? 6 : std::min(c, 5u));
  }
}

cpu::LatticeView lattice_view_numbers(const Model& m, const StepConstants& K) {
  cpu::LatticeView v;
  v.n = m.size();
  v.ns = cpu::scratch_stride(m.size());
  if (K.one_group) {
    v.uniform_bodies = K.uniform_bodies;
    v.body[0] = m.mass[0];
    v.body[1] = K.inv_mass[0];
    v.body[2] = K.inv_inertia[0];
    v.body[3] = K.inv_volume[0];
  }
  v.group_count = static_cast<int>(m.groups.size());
  v.one_group = K.one_group;
  v.strengthening = K.strengthening;
  v.stiffness = m.lattice_stiffness;
  v.r0 = m.spacing;
  v.inv_r0 = 1.0f / m.spacing;
  v.area = m.spacing * m.spacing;
  v.dt = m.dt;
  v.stress_coefficient = m.stress_coefficient;
  v.local_damping = m.local_damping;
  v.gravity = m.gravity;
  return v;
}

StepConstants build_step_constants(const Model& m) {
  StepConstants K;
  const std::size_t n = m.size(), G = m.groups.size();
  for (auto* v : {&K.inv_mass, &K.inv_inertia, &K.inv_volume, &K.tensile, &K.compressive, &K.break_strain}) v->resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    K.inv_mass[a] = 1.0f / m.mass[a];
    K.inv_inertia[a] = 1.0f / m.inertia[a];
    K.inv_volume[a] = 1.0f / m.volume[a];
    const GroupParams& g = m.groups[m.group[a]];
    // (The random lattice's strengths carry its strength factor: lattice::kRandomStrength.)
    const float k = m.random_automaton(a) ? m.class_factor[a] * m.lattice_strength : m.class_factor[a];
    K.tensile[a] = k * g.tensile_strength;
    K.compressive[a] = k * g.compressive_strength;
    K.break_strain[a] = k * g.fracture_strain;
  }
  // Per pair of groups: the link constants (every lattice link has length d and area d^2 and joins two
  // automata of mass Model::lattice_mass).
  const float r0 = m.spacing, area = r0 * r0;
  K.pairs.resize(G * G);
  K.free_factor.resize(G);
  K.lambda_over_2g.resize(G);
  for (std::size_t g = 0; g < G; ++g) {
    free_axis_factors(m.groups[g].lame_lambda, m.groups[g].shear_modulus, K.free_factor[g].data());
    K.lambda_over_2g[g] = m.groups[g].lame_lambda / (2.0f * m.groups[g].shear_modulus);
    K.strengthening = K.strengthening || m.groups[g].strengthening.law != 0;
    for (std::size_t h = 0; h < G; ++h) {
      const GroupParams &gi = m.groups[g], &gj = m.groups[h];
      cpu::PairConstants& p = K.pairs[g * G + h];
      // (A jittered lattice's moduli are raised by Model::lattice_stiffness; the cubic one's factor is 1.)
      const float s = m.lattice_stiffness;
      p.G = link_shear_modulus(s, gi.shear_modulus, gj.shear_modulus);
      p.kt = kShearFactor * p.G * area / r0;
      const float k = link_normal_stiffness(p.G, s * gi.lame_lambda, s * gj.lame_lambda, area, r0);
      p.damping = link_dashpots(k, m.lattice_mass(g), m.lattice_mass(h), 0.5f * (gi.damping_time + gj.damping_time),
                                m.link_damping);
      p.soft = softening_constant(gi.fracture_energy, gj.fracture_energy, gi.youngs, gj.youngs, r0);
    }
  }
  // Explicit links (surface mode): each its own length, cross-section and masses.
  const auto& E = m.explicit_links;
  const std::size_t ne = E.size();
  constexpr std::uint32_t kSecondEnd = StepConstants::kSecondEnd;
  if (ne >= kSecondEnd)  // (ex_ends below)
    throw Error(std::to_string(ne) + " explicit links: at most " + std::to_string(kSecondEnd - 1) + " are supported");
  for (auto* v : {&K.ex_r0f, &K.ex_inv_r0, &K.ex_area, &K.ex_to_stress, &K.ex_G, &K.ex_kt, &K.ex_damp_n, &K.ex_damp_t,
                  &K.ex_k_twist, &K.ex_k_in, &K.ex_s_in, &K.ex_tensile, &K.ex_compressive, &K.ex_strain})
    v->resize(ne);
  // What only a shell's link reads (its reference axis, its out-of-plane and twisting constants, its
  // curvature): held only when the model has shells; a block of random links never reads them.
  for (std::size_t k = 0; k < ne && !K.shells_any; ++k) K.shells_any = !m.random_automaton(E.i[k]);
  if (K.shells_any)
    for (auto* v : {&K.ex_k_out, &K.ex_s_out, &K.ex_s_twist, &K.ex_m0x, &K.ex_m0y, &K.ex_m0z}) v->resize(ne);
  K.ex_bends.resize(ne);
  K.ex_area_r0.resize(ne);
  const bool soft_any = m.softening();
  if (soft_any) K.ex_soft.resize(ne);
  for (std::size_t k = 0; k < ne; ++k) {
    const std::uint32_t i = E.i[k], j = E.j[k];
    const GroupParams &gi = m.groups[m.group[i]], &gj = m.groups[m.group[j]];
    // A link of the random lattice (volume law): its ends' weights are their many-body stresses (the
    // backends' explicit link pass), its moduli carry the lattice's factor, and its bending spring is a beam
    // of its own section (volume_bending_constants; none at link_bending = 0).
    const bool volume = m.random_automaton(i);
    const float s = volume ? m.lattice_stiffness : 1.0f, sl = volume ? m.lattice_lambda : 1.0f;
    K.ex_r0f[k] = static_cast<float>(E.r0[k]);
    K.ex_inv_r0[k] = static_cast<float>(1.0 / E.r0[k]);
    K.ex_area[k] = E.area[k];
    K.ex_area_r0[k] = K.ex_area[k] * K.ex_r0f[k];
    // Its strengths: its weaker end's, times its own factor (cpu::ExplicitView::tensile).
    const auto weaker = [&](const StepConstants::Array<float>& x) { return x[j] < x[i] ? x[j] : x[i]; };
    K.ex_tensile[k] = weaker(K.tensile);
    K.ex_compressive[k] = weaker(K.compressive);
    K.ex_strain[k] = weaker(K.break_strain);
    if (!m.link_strength.empty()) {
      const float w = m.link_strength[3 * n + k];
      K.ex_tensile[k] *= w;
      K.ex_compressive[k] *= w;
      K.ex_strain[k] *= w;
    }
    K.ex_to_stress[k] = volume ? 1.0f : static_cast<float>(1.0 / (E.r0[k] * static_cast<double>(E.area[k])));
    K.ex_G[k] = link_shear_modulus(s, gi.shear_modulus, gj.shear_modulus);
    K.ex_kt[k] = kShearFactor * K.ex_G[k] * K.ex_area[k] * K.ex_inv_r0[k];
    const float k_n = link_normal_stiffness(K.ex_G[k], sl * gi.lame_lambda, sl * gj.lame_lambda, K.ex_area[k], K.ex_r0f[k]);
    const LinkDashpots c = explicit_link_dashpots(k_n, m.mass[i], m.mass[j], 0.5f * (gi.damping_time + gj.damping_time),
                                                  m.link_damping);
    K.ex_damp_n[k] = c.normal;
    K.ex_damp_t[k] = c.tangential;
    // A random-lattice link softens as a lattice link does (2 G_f E / r0 of its own length, E with the
    // lattice's stiffness factor: the link then takes G_f times its cross-section); a shell's does not.
    if (soft_any)
      K.ex_soft[k] =
          volume ? s * softening_constant(gi.fracture_energy, gj.fracture_energy, gi.youngs, gj.youngs, K.ex_r0f[k]) : 0.0f;
    // 1: a shell's spring; 2: a random-lattice link's (volume_bending_constants); 0: none.
    K.ex_bends[k] = !volume ? 1 : m.lattice_bending > 0.0f ? 2 : 0;
    const LinkBendingConstants bc = m.explicit_bending(k);
    K.ex_k_twist[k] = bc.k_twist;
    K.ex_k_in[k] = bc.k_in;
    K.ex_s_in[k] = bc.s_in;
    if (K.shells_any) {
      K.ex_m0x[k] = E.normal[k].x;
      K.ex_m0y[k] = E.normal[k].y;
      K.ex_m0z[k] = E.normal[k].z;
      K.ex_k_out[k] = bc.k_out;
      K.ex_s_out[k] = bc.s_out;
      K.ex_s_twist[k] = bc.s_twist;
    }
  }
  for (std::size_t a = 0; a < n && !E.first.empty(); ++a)
    if (E.first[a + 1] > E.first[a]) K.explicit_automata.push_back(static_cast<std::uint32_t>(a));
  // Each automaton's links (E.of) with the end it is, read in order by the passes.
  K.ex_ends.resize(E.of.size());
  for (const std::uint32_t a : K.explicit_automata)
    for (std::uint32_t x = E.first[a]; x < E.first[a + 1]; ++x)
      K.ex_ends[x] = E.of[x] | (E.i[E.of[x]] == a ? 0u : kSecondEnd);
  K.bend_c.assign(n, 0.0f);
  for (const std::uint32_t a : K.explicit_automata) {
    if (m.random_automaton(a)) continue;  // no shell's many-body bending
    const GroupParams& g = m.groups[m.group[a]];
    const std::uint32_t l = E.of[E.first[a]];
    K.bend_c[a] = static_cast<float>(bending_many_body_constant(g.youngs, g.poisson, E.area[l] / E.edge[l], m.volume[a]));
  }
  // Contact springs per pair of groups (and per group on the ground) when every automaton of a group
  // has the group's radius, mass and moment of inertia (lattices: always): the same numbers
  // body_contact_springs gives for each pair, worked out once.
  std::vector<std::uint32_t> first(G, UINT32_MAX);
  K.uniform_bodies = true;
  for (std::size_t a = 0; a < n; ++a) {
    std::uint32_t& f = first[m.group[a]];
    if (f == UINT32_MAX) f = static_cast<std::uint32_t>(a);
    K.uniform_bodies = K.uniform_bodies && m.radius[a] == m.radius[f] && m.mass[a] == m.mass[f] &&
                       m.inertia[a] == m.inertia[f] && m.volume[a] == m.volume[f];
  }
  if (K.uniform_bodies) {
    K.pair_springs.resize(G * G);
    K.ground_springs.resize(G);
    for (std::size_t g = 0; g < G; ++g) {
      if (first[g] == UINT32_MAX) continue;
      const std::uint32_t i = first[g];
      K.ground_springs[g] = automaton_ground_springs(m, i);
      for (std::size_t h = 0; h < G; ++h)
        if (first[h] != UINT32_MAX)
          K.pair_springs[g * G + h] = automaton_pair_springs(m, i, first[h], m.random_link_at_start(i, first[h]));
    }
  }
  K.one_group = n > 0 && std::all_of(m.group.begin(), m.group.end(), [&](std::uint8_t g) { return g == m.group[0]; });
  K.grip_members.resize(m.grip_velocity.size());
  for (std::size_t a = 0; a < n; ++a)
    if (m.grip[a] >= 0) K.grip_members[m.grip[a]].push_back(static_cast<std::uint32_t>(a));
  K.r_max = 0;
  for (float r : m.radius) K.r_max = std::max(K.r_max, r);
  const std::size_t np = m.projectiles.size();
  K.proj_reach2.resize(np);
  for (std::size_t p = 0; p < np; ++p) {
    // The projectile pass takes automaton a when |d|^2 < (R + r_a)^2, d and the sum rounded to float:
    // with the largest radius (and a little more) for every automaton, the marks hold all it takes.
    const float reach = (m.projectiles[p].radius + K.r_max) * 1.001f;
    K.proj_reach2[p] = reach * reach;
  }
  return K;
}

}  // namespace mca
