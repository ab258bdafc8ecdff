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

// Which criterion breaks a link (both false: it stays linked). Displacement first: a link past its
// breaking elongation breaks by it whatever its stress.
template <class T>
struct BreakTest {
  decltype(T{} > T{}) displacement, stress;
};

template <class T, class R>
MCA_HD BreakTest<T> link_break_test(const T& h, const R& r0, const T& sigma, const T& tau2, const T& p, const T& tensile,
                                    const T& ratio, const T& strain, float stress_coefficient) {
  BreakTest<T> b;
  b.displacement = h > r0 * strain;
  b.stress = !b.displacement && equivalent_stress(sigma, tau2, p, ratio) >= stress_coefficient * tensile;
  return b;
}


}  // namespace mca
