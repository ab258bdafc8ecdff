#pragma once
// Fracture criteria of a link (paper sec. 4.4, physics.md sec. 4). Decided for all links from one
// step's state, so the result does not depend on the order links are visited.
#include "core/math.hpp"

namespace mca {

// Equivalent stress of a pair from its own normal and shear stress (q = sqrt(sigma^2 + 3 tau^2)) and the
// mean stress p of its two automata, in the Drucker-Prager form sigma_eq = A q + B p, compared with the
// tensile strength. A, B make uniaxial tension fail at sigma_t and uniaxial compression at sigma_c:
// A + B/3 = 1, A - B/3 = sigma_t / sigma_c. Equal strengths give A = 1, B = 0 (von Mises).
template <class T>
MCA_HD T equivalent_stress(const T& sigma, const T& tau2, const T& p, const T& ratio) {
  using std::sqrt;
  const T q = sqrt(sigma * sigma + 3.0f * tau2);
  return 0.5f * (1.0f + ratio) * q + 1.5f * (1.0f - ratio) * p;
}

// The random lattice's links (SolverDef::Lattice::random) are not held to equivalent_stress. Its p is the
// automata's smooth mean stress, which a link's own stresses overshoot: in a 6 x 6 x 16 block pressed
// along its length the links' shear stresses reached 1.8 (inside) to 3.4 times (at a free face) the
// continuum's largest, and sqrt(3) tau set against 1.35 p broke the first of them at a tenth of the
// compressive strength (the cubic lattice's first break, lateral, by displacement: 0.54), the block
// giving way at 0.454. So a random link is held to its own stresses, as rigid-body-spring networks are: a
// tension cut-off at its tensile limit f (c sigma_t), a Mohr-Coulomb limit on its shear, kRandomCohesion f
// plus kRandomFriction times its compression, and crushing at its compressive limit (c sigma_c). The effort,
// 1 at the limit, is the largest of the three ratios. The cohesion is the lattice's calibration, as
// lattice::kRandomStrength is: with 4 (friction 1) the pressed block peaks at 0.652 of sigma_c (the cubic
// lattice's 0.620), the pulled one at 0.924 of sigma_t (0.913), with the links' bending springs (0.597 and
// 0.915 without); docs/model-notes.md, "The random lattice", Strength.
inline constexpr float kRandomCohesion = 4.0f;
inline constexpr float kRandomFriction = 1.0f;
template <class T>
MCA_HD T random_link_effort(const T& sigma, const T& tau, const T& tensile_limit, const T& compressive_limit) {
  // Tension does not lower the shear limit below the cohesion: a softening link is stretched far past
  // its tensile limit, and a limit falling to zero there would cut its softening short.
  const T pressed = select(sigma < 0.0f, -sigma, T(0.0f));
  const T s = tau / (kRandomCohesion * tensile_limit + kRandomFriction * pressed);
  const T a = sigma / tensile_limit, c = -sigma / compressive_limit;
  const T m = select(a > c, a, c);
  return select(s > m, s, m);
}

// Which criterion breaks a link (both false: it stays linked). Displacement first: a link past its
// breaking elongation breaks by it whatever its stress.
template <class T>
struct BreakTest {
  decltype(T{} > T{}) displacement, stress;
};

// effort: the stress criterion's, 1 at the limit (equivalent_stress over c sigma_t, or random_link_effort).
template <class T, class R>
MCA_HD BreakTest<T> link_break_test_at(const T& h, const R& r0, const T& effort, const T& strain) {
  BreakTest<T> b;
  b.displacement = h > r0 * strain;
  b.stress = !b.displacement && effort >= 1.0f;
  return b;
}
template <class T, class R>
MCA_HD BreakTest<T> link_break_test(const T& h, const R& r0, const T& sigma, const T& tau2, const T& p, const T& tensile,
                                    const T& ratio, const T& strain, float stress_coefficient) {
  BreakTest<T> b;
  b.displacement = h > r0 * strain;
  b.stress = !b.displacement && equivalent_stress(sigma, tau2, p, ratio) >= stress_coefficient * tensile;
  return b;
}

// Softening (MaterialDef::fracture_energy; docs/model-notes.md, "Softening"). A link's effort is its
// equivalent stress over its strength, sigma_eq / (c sigma_t): the instant law breaks it at 1. Beyond 1 the
// link is damaged: its damage D (state, 0 at the start, never decreasing) takes the share D of its normal
// stress while it is stretched and of its shear spring (link_law.hpp, softened_force), and the strain its
// ends' many-body sums see in tension is (1 - D) e, so that an opening crack does not load the automata's
// other links through their volumetric strain; compression is carried whole (a crack closes). D at effort e > 1 is 1 - (ku - e) / ((ku - 1) e): in uniaxial tension the stress
// falls linearly from the strength at effort 1 to zero at effort ku, and unloading and reloading follow
// the secant. The energy that takes per unit volume is f^2 ku / (2 E), so per unit of cross-section, over
// the link's length r0, f^2 ku r0 / (2 E) = G_f for ku = 2 G_f E / (f^2 r0) = soft / f^2, f = c sigma_t
// (c: solver.stress_coefficient)
// (softening_constant). The link breaks when its effort reaches ku. With ku <= 1 (a fracture energy too
// small for the link's length: the law would have to snap back) it breaks at effort 1, as without
// softening. The breaking elongation of the displacement criterion grows by the same factor ku: it stays
// a limit beyond the softening's end instead of cutting it short.

// The share of its pair stress and shear spring a link keeps at effort e, ku = soft / f^2 (1 up to effort
// 1; past ku the link breaks, and the value is not used).
template <class T>
MCA_HD T softening_keep(const T& effort, const T& ku) {
  const T k = select(effort > 1.0f, effort, T(1.0f));
  const T share = (ku - k) / (select(ku > 1.0f, ku - 1.0f, T(1.0f)) * k);
  return select(effort > 1.0f, share, T(1.0f));
}

template <class T>
struct SofteningTest {
  decltype(T{} > T{}) displacement, stress;
  T damage;  // the link's damage after this step (1 when it breaks)
};

// The test at a given effort (the criterion's, 1 at the strength f = c sigma_t; equivalent_stress / f, or
// random_link_effort for the random lattice's links).
template <class T, class R>
MCA_HD SofteningTest<T> link_softening_test_at(const T& h, const R& r0, const T& effort, const T& f, const T& strain,
                                               const T& soft, const T& damage) {
  SofteningTest<T> s;
  const T ku = soft / (f * f);
  const T end = select(ku > 1.0f, ku, T(1.0f));
  s.displacement = h > r0 * strain * end;
  s.stress = !s.displacement && effort >= end;
  const T d = 1.0f - softening_keep(effort, ku);
  s.damage = select(s.displacement || s.stress, T(1.0f), select(d > damage, d, damage));
  return s;
}

// soft: softening_constant of the pair (0: no softening); damage: the link's damage so far. sigma and tau2
// are the link's undamaged stresses (its pair stress whole, its shear spring whole); p the automata's mean
// stress as the forces give it (the link's own damage is added back to it in tension, below).
template <class T, class R>
MCA_HD SofteningTest<T> link_softening_test(const T& h, const R& r0, const T& sigma, const T& tau2, const T& p,
                                            const T& tensile, const T& ratio, const T& strain,
                                            float stress_coefficient, const T& soft, const T& damage) {
  const T f = stress_coefficient * tensile;
  // The mean stress p of the two automata comes from their forces, which the damage has lowered: of a
  // link stretched by sigma alone (uniaxial tension, its ends' links in series carrying the same force)
  // they get (1 - D) sigma / 3 where the undamaged link would give sigma / 3. Taken as it is, p would hold
  // the effort back as the link softens, and where the criterion weighs p heavily (concrete: sigma_t /
  // sigma_c = 0.1 gives 1.35 p against 0.55 q) a pulled block took 5 times G_f per unit of crack area. So
  // the link adds back what its own damage took from p, D sigma / 3 while it is stretched (h > 0: where
  // softened_force takes the share D of sigma; compressed, it is carried whole): exact in uniaxial
  // tension, and bounded by the link's own stress whatever else loads its ends.
  const T p_link = p + damage * select(h > 0.0f, sigma, T(0.0f)) * (1.0f / 3.0f);
  return link_softening_test_at(h, r0, equivalent_stress(sigma, tau2, p_link, ratio) / f, f, strain, soft, damage);
}

// The pair's soft = 2 G_f E / r0 of link_softening_test for a link of length r0 between materials of
// fracture energies gf_i, gf_j and Young's moduli E_i, E_j: harmonic means, so an end without
// softening (G_f = 0) gives a link without.
inline float softening_constant(float gf_i, float gf_j, float E_i, float E_j, float r0) {
  if (!(gf_i > 0 && gf_j > 0)) return 0.0f;
  const double gf = 2.0 * gf_i * gf_j / (static_cast<double>(gf_i) + gf_j);
  const double E = 2.0 * static_cast<double>(E_i) * E_j / (static_cast<double>(E_i) + E_j);
  return static_cast<float>(2.0 * gf * E / r0);
}


}  // namespace mca
