#pragma once
// Semi-implicit (symplectic) Euler for translation and rotation (physics.md sec. 7), with Cundall's
// local damping: each force component is reduced by alpha |f| against the direction of motion.
#include "core/math.hpp"

namespace mca {

template <class T>
MCA_HD T local_damped(const T& f, const T& v, float alpha) {
  using std::fabs;
  const T d = alpha * fabs(f);
  return select(v > 0.0f, f - d, select(v < 0.0f, f + d, f));
}

template <class T>
MCA_HD Vec3T<T> local_damped(const Vec3T<T>& f, const Vec3T<T>& v, float alpha) {
  return {local_damped(f.x, v.x, alpha), local_damped(f.y, v.y, alpha), local_damped(f.z, v.z, alpha)};
}

// An automaton's motion; D is double (or double lanes) for the position, the velocity and the angular
// velocity (core/state.hpp), T the float type of the orientation and the forces.
template <class T, class D>
struct BodyT {
  Vec3T<D> x, v, w;
  QuatT<T> q;
};
using Body = BodyT<float, double>;

// f and t come back as applied (after local damping). The increments f dt / m and t dt / J are formed in
// float and added in double, so that a small force (gravity's g dt against a fast body's velocity) is
// kept; the orientation turns by the angular velocity rounded to float.
template <class T, class D>
MCA_HD void integrate_body(BodyT<T, D>& b, Vec3T<T>& f, Vec3T<T>& t, const Scalar<T>& inv_m, const Scalar<T>& inv_j,
                           float dt, float alpha) {
  if (alpha > 0.0f) {
    f = local_damped(f, rounded(b.v), alpha);
    t = local_damped(t, rounded(b.w), alpha);
  }
  b.v += f * (inv_m * dt);
  b.x += b.v * static_cast<double>(dt);
  b.w += t * (inv_j * dt);
  b.q = integrate_orientation(b.q, rounded(b.w), dt);
}

}  // namespace mca
