#pragma once
// Contacts of unlinked automata, projectiles and the ground (physics.md sec. 6), one law for every pair:
//   normal      F_n = max(0, k_n delta - c_n v_n): a spring with a dashpot that never pulls; c_n is
//               calibrated so that this clipped law returns the coefficient of restitution e
//               (restitution_damping_ratio below);
//   tangential  a spring k_t on the accumulated tangential displacement, cut back to mu F_n when sliding
//               (Coulomb), history kept per contact;
//   rolling     an elastic-plastic spring-dashpot on the relative rotation (the "type C" model of Ai,
//   twisting    Chen, Rotter and Ooi, Powder Technology 206 (2011) 269-282): stiffness
//               k_r = 2.25 k_n mu_r^2 R^2, torque capped at mu_r R F_n (twisting: mu_t), viscous part
//               0.3 of critical while below the cap. Without it a loose automaton, a sphere to the
//               contact law, rolls on for ever (measured: debris at 0.6 of its sliding speed).
// Springs: k_n = E_12 L, k_t = k_s G_12 L, with E_12, G_12 the harmonic means (two half-bodies in series;
// the rigid ground is an infinitely stiff half, so E_12 = 2 E) and L = 2 min(r_1, r_2) (d for two
// automata: a link of length d in compression). R = r_1 r_2 / (r_1 + r_2) (r_1 on the ground).
#include <algorithm>
#include <cmath>

#include "core/math.hpp"
#include "core/model.hpp"  // ContactMaterial
#include "physics/link_law.hpp"  // kShearFactor

namespace mca {

// Viscous share of critical damping of the rolling and twisting springs (Ai et al. use 0.3).
inline constexpr float kRollingDampingRatio = 0.3f;

// Restitution of the clipped spring-dashpot m x'' = -(k x + c x') while that force pushes (x > 0 is the
// overlap), for the damping ratio zeta = c / (2 sqrt(k m)). The contact ends when the force reaches zero,
// before the overlap does (it cannot pull), and the body leaves at the velocity it has then. In time
// units of 1 / omega with x(0) = 0, x'(0) = 1 the force vanishes where x + 2 zeta x' = 0 and e = -x'.
// Build-time only (double precision, no need on a device).
inline double clipped_restitution(double zeta) {
  if (zeta <= 0) return 1.0;
  if (zeta < 1) {
    const double b = std::sqrt(1 - zeta * zeta);
    const double phi = std::atan2(2 * zeta * b, 2 * zeta * zeta - 1);  // omega_d t at zero force
    return -std::exp(-zeta * phi / b) * (std::cos(phi) - zeta / b * std::sin(phi));
  }
  if (zeta == 1) return std::exp(-2.0);
  const double g = std::sqrt(zeta * zeta - 1);
  const double t = std::atanh(2 * zeta * g / (2 * zeta * zeta - 1)) / g;
  return -std::exp(-zeta * t) * (std::cosh(g * t) - zeta / g * std::sinh(g * t));
}

// The damping ratio that gives restitution e in (0, 1] under the clipped law (bisection; e falls
// monotonically with zeta, from 1 at zeta = 0 to 0.0093 at zeta = 5). The unclipped textbook ratio
// -ln e / sqrt(pi^2 + ln^2 e) overshoots: for e = 0.2 it gives 0.456, which the clipped law turns into a
// rebound of 0.32 (measured on one automaton dropped on the ground: 0.30).
inline float restitution_damping_ratio(double e) {
  if (e >= 1) return 0.0f;
  double lo = 0, hi = 1;
  while (clipped_restitution(hi) > e) hi *= 2;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (clipped_restitution(mid) > e) lo = mid;
    else hi = mid;
  }
  return static_cast<float>(0.5 * (lo + hi));
}

// The damping ratio that gives restitution e under the clipped law as the step integrates it, for a contact
// of angular frequency omega = sqrt(k_n / m_eff) at the step dt: symplectic Euler with omega dt of 0.1 to
// 0.4 (an automaton on the ground at the default step) returns e + 0.01 to 0.04 with the continuous ratio.
// The 1D contact of contact_force (onset-scaled dashpot, clipping) is integrated from first touch, the
// body entering half a step after the previous one, and zeta found by bisection. Build-time only.
inline double discrete_restitution(double zeta, double omega_dt) {
  const double dt = omega_dt;  // units: omega = k = m = 1
  double gap = 0.5 * dt, v = -1;  // gap > 0: apart; v < 0: approaching
  for (int k = 0; k < 1000000; ++k) {
    const double overlap = -gap;
    if (overlap > 0) {
      double damp = -2 * zeta * v;
      if (v < 0 && overlap < -v * dt) damp *= overlap / (-v * dt);
      v += std::max(0.0, overlap + damp) * dt;
    } else if (v > 0) {
      return v;  // apart and leaving
    }
    gap += v * dt;
  }
  return 0;
}

inline float discrete_damping_ratio(double e, double omega_dt) {
  if (e >= 1) return 0.0f;
  // e falls with zeta until the explicit dashpot overshoots (2 zeta omega dt near 1 and above, where the
  // discrete e climbs again): scan up from 0 for the first ratio at or below e, then bisect. A target
  // out of reach (a very low e at a coarse step) gets the lowest restitution found.
  const double top = 0.5 / omega_dt, step = std::min(0.05, top / 20);
  double lo = 0, hi = -1, best = 0, best_e = 1;
  for (double z = step; z <= top; z += step) {
    const double ez = discrete_restitution(z, omega_dt);
    if (ez < best_e) {
      best_e = ez;
      best = z;
    }
    if (ez <= e) {
      hi = z;
      break;
    }
    lo = z;
  }
  if (hi < 0) return static_cast<float>(best);
  for (int it = 0; it < 50; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (discrete_restitution(mid, omega_dt) > e) lo = mid;
    else hi = mid;
  }
  return static_cast<float>(0.5 * (lo + hi));
}

// The springs and dashpots of one contact. length = 2 min(r_1, r_2); radius = r_1 r_2 / (r_1 + r_2);
// m_eff, j_eff: reduced mass and moment of inertia (the body's own against the ground, a kinematic
// projectile or an automaton a grip holds).
struct ContactSprings {
  float kn, kt, cn, mu;
  float kr, cr, roll_limit;   // rolling spring, its dashpot, mu_r R (times F_n: the torque cap)
  float kw, cw, twist_limit;  // twisting
};

MCA_HD ContactSprings contact_springs(const ContactMaterial& c, float zeta, float length, float radius, float m_eff,
                                      float j_eff) {
  ContactSprings s;
  s.kn = c.youngs * length;
  s.kt = kShearFactor * c.shear * length;
  s.cn = 2.0f * zeta * product_root(s.kn, m_eff);  // (product_root: bodies of a kilometre)
  s.mu = c.friction;
  s.kr = 2.25f * s.kn * c.rolling * c.rolling * radius * radius;
  s.cr = 2.0f * kRollingDampingRatio * product_root(s.kr, j_eff);
  s.roll_limit = c.rolling * radius;
  s.kw = 2.25f * s.kn * c.twisting * c.twisting * radius * radius;
  s.cw = 2.0f * kRollingDampingRatio * product_root(s.kw, j_eff);
  s.twist_limit = c.twisting * radius;
  return s;
}

// The springs of a contact that holds the share w (0 to 1) of a contact's area (two faces,
// ModelView::face_pair): the springs times w, the dashpots times sqrt(w) (the damping ratio of the same
// masses); the limits are shares of the normal force, which w scales.
MCA_HD ContactSprings weighted(ContactSprings s, float w) {
  const float root = std::sqrt(w);
  s.kn *= w;
  s.kt *= w;
  s.kr *= w;
  s.kw *= w;
  s.cn *= root;
  s.cr *= root;
  s.cw *= root;
  return s;
}

// The springs of a contact between bodies of radii ra and rb (rb = INFINITY: the ground), with the
// reduced mass and moment of inertia of the pair (the body's own against the ground or a kinematic body).
// zeta: the damping ratio of the normal dashpot (Model's tables, calibrated for the step).
MCA_HD ContactSprings body_contact_springs(const ContactMaterial& c, float zeta, float ra, float rb, float m_eff,
                                           float j_eff) {
  return contact_springs(c, zeta, 2.0f * std::fmin(ra, rb), rb == INFINITY ? ra : ra * rb / (ra + rb), m_eff, j_eff);
}

// a b / (a + b), in float as it always was; where a b leaves float (masses of 1.8e19 kg, moments of inertia
// of bodies of a kilometre), from the double product (product_root's reason).
MCA_HD float reduced(float a, float b) {
  const float p = a * b;
  if (p <= kFloatMax) return p / (a + b);
  return static_cast<float>(static_cast<double>(a) * b / (static_cast<double>(a) + b));
}

// The overlap of two spheres of radii summing to r_sum at centres a and b, and the unit normal from a to
// b, formed in double: the overlap of a resting contact, m g / k_n (1e-9 m for a 5 cm concrete
// automaton), is below the float resolution of a 5 cm distance (4e-9 m), and a float distance made the
// normal force of a resting automaton jump between 0 and several times its weight.
struct SphereGap {
  Vec3 n;
  float overlap;
  bool valid;  // false when the centres coincide (no normal)
};

MCA_HD SphereGap sphere_gap(DVec3 a, DVec3 b, double r_sum) {
  const DVec3 d = ddelta(a, b);
  const double dist = std::sqrt(dot(d, d));
  if (!(dist > 0)) return {Vec3{}, 0.0f, false};
  const double inv = 1.0 / dist;
  return {Vec3{static_cast<float>(d.x * inv), static_cast<float>(d.y * inv), static_cast<float>(d.z * inv)},
          static_cast<float>(r_sum - dist), true};
}

// The overlap of a sphere of radius r at x with the ground plane of height h along up (double, as above: a
// ground far from the origin keeps the positions' precision).
MCA_HD float ground_overlap(DVec3 x, Vec3 up, double h, float r) {
  return static_cast<float>(static_cast<double>(r) - (x.x * up.x + x.y * up.y + x.z * up.z - h));
}

// The velocity of body j's contact point relative to body i's, from their velocities v, angular
// velocities w and the arms r from each centre to the contact point: the velocities' difference is
// formed in double and rounded (a fast pair's relative velocity keeps its digits), the spins' parts in
// float. Also the angular velocity of j relative to i. A missing body (the ground) is zero.
struct RelativeMotion {
  Vec3 v, w;
};
MCA_HD RelativeMotion relative_motion(const DVec3& vi, const DVec3& wi, const Vec3& ri, const DVec3& vj, const DVec3& wj,
                                      const Vec3& rj) {
  return {delta(vi, vj) + (cross(to_vec3(wj), rj) - cross(to_vec3(wi), ri)), delta(wi, wj)};
}

struct ContactInput {
  Vec3 n;          // unit normal from i to j (for a body: from the automaton to the body)
  float overlap;   // r_i + r_j - distance, > 0 when touching
  Vec3 vrel;       // velocity of j's contact point relative to i's
  Vec3 wrel;       // angular velocity of j relative to i
  ContactSprings s;
  Vec3 ut;         // tangential history
  Vec3 mr;         // rolling (tangential part) and twisting (normal part) spring torque on i
  float dt;
};

struct ContactOutput {
  Vec3 force_i;    // force on i; j gets the opposite
  Vec3 ft;         // tangential part (for the torques r_i n x ft on i, r_j n x ft on j)
  Vec3 torque_i;   // rolling and twisting torque on i; j gets the opposite
  Vec3 ut, mr;     // updated histories (zero when apart)
  float fn;        // normal force magnitude (>= 0)
};

// Caps a spring torque at `limit` (then no viscous part, as in Ai et al.'s full mobilisation), else adds
// the dashpot. Returns the torque to apply; `spring` is cut back in place.
MCA_HD Vec3 capped_torque(Vec3& spring, Vec3 rate, float c, float limit) {
  const float m2 = dot(spring, spring);
  if (m2 > limit * limit) {
    spring = spring * (limit / std::sqrt(m2));
    return spring;
  }
  return spring + c * rate;
}

MCA_HD ContactOutput contact_force(const ContactInput& in) {
  ContactOutput out{};
  if (in.overlap <= 0.0f) return out;
  const ContactSprings& s = in.s;
  const float vn = dot(in.vrel, in.n);
  // The dashpot's force jumps to c v at first touch; a step that began apart touched for only the part
  // overlap / (-v_n dt) of it, and the full jump would add a random impulse of up to c v dt (the
  // restitution of one automaton on the ground scattered by +-0.03 with the phase of its arrival).
  float damp = -s.cn * vn;  // approach (vn < 0) adds to the repulsion
  if (vn < 0.0f && in.overlap < -vn * in.dt) damp *= in.overlap / (-vn * in.dt);
  out.fn = s.kn * in.overlap + damp;
  if (out.fn < 0.0f) out.fn = 0.0f;        // unlinked pairs never pull
  const Vec3 vs = in.vrel - vn * in.n;
  Vec3 p = in.ut - dot(in.ut, in.n) * in.n;
  p += vs * in.dt;
  Vec3 ft = s.kt * p;
  const float limit = s.mu * out.fn;
  const float ftl = length(ft);
  if (ftl > limit) {  // sliding: the spring is cut back to the Coulomb limit
    const float k = ftl > 0.0f ? limit / ftl : 0.0f;
    p = p * k;
    ft = ft * k;
  }
  out.ut = p;
  out.ft = ft;
  out.force_i = ft - out.fn * in.n;
  if (s.kr > 0.0f || s.kw > 0.0f) {
    // The stored torque turns with the contact: its normal part is the twist, the rest the rolling.
    const float wn = dot(in.wrel, in.n), mn = dot(in.mr, in.n);
    const Vec3 wt = in.wrel - wn * in.n;
    Vec3 roll = (in.mr - mn * in.n) + (s.kr * in.dt) * wt;
    Vec3 twist = (mn + s.kw * in.dt * wn) * in.n;
    const Vec3 tr = capped_torque(roll, wt, s.cr, s.roll_limit * out.fn);
    const Vec3 tw = capped_torque(twist, wn * in.n, s.cw, s.twist_limit * out.fn);
    out.mr = roll + twist;
    out.torque_i = tr + tw;
  }
  return out;
}

// A contact between bodies i and j as every pass sets it up (automaton pairs, the ground, projectiles):
// the motion of j's contact point relative to i's from the bodies' velocities, spins and arms (from each
// centre to the contact point; the ground is a body with zero motion and arm), the springs' response,
// and the torque on each body: arm x ft plus the rolling and twisting torque on i, -arm x ft minus it on j.
struct ContactResult {
  ContactOutput o;
  Vec3 torque_i, torque_j;
};
MCA_HD ContactResult contact_between(Vec3 n, float overlap, const DVec3& vi, const DVec3& wi, Vec3 arm_i, const DVec3& vj,
                                    const DVec3& wj, Vec3 arm_j, const ContactSprings& s, Vec3 ut, Vec3 mr, float dt) {
  ContactInput in;
  in.n = n;
  in.overlap = overlap;
  const RelativeMotion rm = relative_motion(vi, wi, arm_i, vj, wj, arm_j);
  in.vrel = rm.v;
  in.wrel = rm.w;
  in.s = s;
  in.ut = ut;
  in.mr = mr;
  in.dt = dt;
  ContactResult r;
  r.o = contact_force(in);
  r.torque_i = cross(arm_i, r.o.ft) + r.o.torque_i;
  r.torque_j = cross(-arm_j, r.o.ft) - r.o.torque_i;
  return r;
}

// The mass (or moment of inertia) a contact moves: the pair's reduced one, or a body's own against a
// kinematic partner, which nothing moves (a driven projectile). Both kinematic: no contact is made.
MCA_HD float contact_reduced(float a, bool a_kinematic, float b, bool b_kinematic) {
  return a_kinematic ? b : (b_kinematic ? a : reduced(a, b));
}

// Elastic energy stored in a contact's springs [J], for the energy bookkeeping.
MCA_HD double contact_energy(const ContactSprings& s, double overlap, Vec3 ut, Vec3 mr, Vec3 n) {
  double e = 0;
  if (overlap > 0) e += 0.5 * s.kn * overlap * overlap;
  // The squares in float as they always were; where one leaves float (a rolling moment past 1.8e19 N m:
  // bodies of tens of kilometres on the ground, whose energy check read inf and stopped the run), in double.
  const float uu = dot(ut, ut), mm = dot(mr, mr);
  const bool in_float = uu <= kFloatMax && mm <= kFloatMax;
  const DVec3 dut = to_dvec3(ut), dmr = to_dvec3(mr);
  e += 0.5 * s.kt * (in_float ? static_cast<double>(uu) : dot(dut, dut));
  const double mn = in_float ? static_cast<double>(dot(mr, n)) : dot(dmr, to_dvec3(n));
  const double mt2 = (in_float ? static_cast<double>(mm) : dot(dmr, dmr)) - mn * mn;
  if (s.kr > 0) e += 0.5 * mt2 / s.kr;
  if (s.kw > 0) e += 0.5 * mn * mn / s.kw;
  return e;
}

}  // namespace mca
