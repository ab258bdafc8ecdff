#pragma once
// Contacts of unlinked automata, and of automata with projectiles and the ground (physics.md sec. 6):
// a normal spring with a damper set by the coefficient of restitution, never pulling, and Coulomb
// friction with a tangential spring whose history is kept per contact.
#include "core/math.hpp"
#include "core/model.hpp"
#include "physics/link_law.hpp"  // kShearFactor

namespace mca {

// Two springs in series of equal length: 2 a b / (a + b) (pair moduli, contact stiffnesses).
MCA_HD float harmonic(float a, float b) { return a + b > 0.0f ? 2.0f * a * b / (a + b) : 0.0f; }

// Damping ratio that gives restitution e for a linear spring-dashpot: zeta = -ln e / sqrt(pi^2 + ln^2 e).
MCA_HD float restitution_damping_ratio(float e) {
  if (e >= 1.0f) return 0.0f;
  const float l = std::log(e);
  return -l / std::sqrt(9.8696044f + l * l);
}

// Contact parameters of two automata (or an automaton and a body): springs of a link in compression over
// the pair's size `length`, damping from the restitution (physics.md sec. 6). Used by the backends and by
// the energy bookkeeping, so both see the same springs.
struct PairContact {
  float kn, kt, cn, mu;
};

MCA_HD PairContact contact_params(const GroupParams& a, const GroupParams& b, float length, float m_eff) {
  PairContact c;
  c.kn = harmonic(a.youngs, b.youngs) * length;
  c.kt = kShearFactor * harmonic(a.shear_modulus, b.shear_modulus) * length;
  const float zeta = restitution_damping_ratio(0.5f * (a.restitution + b.restitution));
  c.cn = 2.0f * zeta * std::sqrt(c.kn * m_eff);
  c.mu = 0.5f * (a.friction + b.friction);
  return c;
}

struct ContactInput {
  Vec3 n;          // unit normal from i to j (for a body: from the automaton to the body)
  float overlap;   // r_i + r_j - distance, > 0 when touching
  Vec3 vrel;       // velocity of j's contact point relative to i's
  float kn, kt;    // normal and tangential stiffness [N/m]
  float cn;        // normal damping coefficient [N s/m]
  float mu;        // friction coefficient
  Vec3 ut;         // tangential history
  float dt;
};

struct ContactOutput {
  Vec3 force_i;    // force on i; j gets the opposite
  Vec3 ft;         // tangential part (for the torques r_i n x ft on i, r_j n x ft on j)
  Vec3 ut;         // updated history (zero when apart)
  float fn;        // normal force magnitude (>= 0)
};

MCA_HD ContactOutput contact_force(const ContactInput& in) {
  ContactOutput out{};
  if (in.overlap <= 0.0f) return out;
  const float vn = dot(in.vrel, in.n);
  out.fn = in.kn * in.overlap - in.cn * vn;  // approach (vn < 0) adds to the repulsion
  if (out.fn < 0.0f) out.fn = 0.0f;          // unlinked pairs never pull
  const Vec3 vs = in.vrel - vn * in.n;
  Vec3 p = in.ut - dot(in.ut, in.n) * in.n;
  p += vs * in.dt;
  Vec3 ft = in.kt * p;
  const float limit = in.mu * out.fn;
  const float ftl = length(ft);
  if (ftl > limit) {  // sliding: the spring is cut back to the Coulomb limit
    const float s = ftl > 0.0f ? limit / ftl : 0.0f;
    p = p * s;
    ft = ft * s;
  }
  out.ut = p;
  out.ft = ft;
  out.force_i = ft - out.fn * in.n;
  return out;
}

}  // namespace mca
