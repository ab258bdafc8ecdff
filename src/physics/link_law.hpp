#pragma once
// The many-body MCA law of a linked pair (physics.md sec. 3; paper eqs. 5, 6, 8-12), written once for
// every backend.
//
// Normal stress.  sigma_ij = 2 G_ij eps_ij + P_i + P_j, where P_i = lambda_i * theta_i / n_a(i) is the
// many-body term of automaton i: theta_i is i's volumetric strain and n_a(i) the number of i's intact
// links along this link's lattice axis a. The strain of i along an axis is the mean strain of its links
// along it; an axis with no intact link is a free surface on both sides, so its strain is the one that
// makes its normal stress vanish, 2 G e_f + lambda theta = 0 (volumetric_strain below). A bar one
// automaton thick thus has Young's modulus E, a plate one automaton thick is in plane stress, and a block
// has Hooke's law with the input E and nu. In an interior automaton P_i + P_j = lambda (theta_i + theta_j) / 2, which is
// the note's D * (sigma_mean_i + sigma_mean_j) / 2 with sigma_mean = K theta / 3 (D K / 3 = lambda), so a
// block returns Hooke's law with the input E and nu. We take sigma_mean from the current volumetric
// strain instead of the previous step's averaged stress: with the one-step lag the lambda part of the
// stiffness acts on a delayed strain, which is a negative damping and makes undamped runs blow up (see
// docs/model-notes.md). This form is the gradient of
//   W = sum_links G_ij eps_ij^2 V + sum_i lambda_i theta_i^2 V / 2,
// so the law conserves energy exactly up to the integrator, and unequal materials need no extra solve.
//
// Shear (paper eq. 10, contact point at mid-distance).  The tangential displacement u_t of j's contact
// point relative to i's is integrated from V_s and kept tangent; F_t = k_s G S u_t / r0 acts on i, -F_t on
// j, and both automata feel the torque (r/2) n x F_t (= (r/2) n x F, since n x n = 0).
#include "core/math.hpp"

namespace mca {

// Shear stiffness factor of the link: a free-rotating cubic lattice in simple shear gives each pair half
// the engineering shear strain, so k_s = 2 returns G (checked by the shear-modulus test).
inline constexpr float kShearFactor = 2.0f;

// E(e) / E0 of paper eq. 7: 0 none, 1 exponential E0 exp(alpha e), 2 quadratic E0 (1 + alpha e^2).
MCA_HD float strengthening_factor(int law, float alpha, float e) {
  if (law == 1) return std::exp(alpha * e);
  if (law == 2) return 1.0f + alpha * e * e;
  return 1.0f;
}

// 1 / n for the link counts of one axis (at most 2 in a lattice): a multiply instead of a division.
MCA_HD float inverse_count(int n) { return n == 1 ? 1.0f : (n == 2 ? 0.5f : 1.0f / static_cast<float>(n)); }

// free_factor[f] = 1 / (1 + f lambda / (2 G)) of the automaton's group, for f = 0..3 free axes.
MCA_HD void free_axis_factors(float lambda, float shear_modulus, float free_factor[4]) {
  for (int f = 0; f < 4; ++f) free_factor[f] = 1.0f / (1.0f + static_cast<float>(f) * lambda / (2.0f * shear_modulus));
}

// Volumetric strain of an automaton from, per lattice axis, the summed strain and count of its intact
// links along it. Axes without links are free: e_f = -lambda theta / (2 G) each, so
// theta = sum_linked / (1 + n_free lambda / (2 G)).
MCA_HD float volumetric_strain(const float sum[3], const int cnt[3], const float free_factor[4]) {
  float linked = 0.0f;
  int free_axes = 0;
  for (int a = 0; a < 3; ++a) {
    if (cnt[a]) linked += sum[a] * inverse_count(cnt[a]);
    else ++free_axes;
  }
  return linked * free_factor[free_axes];
}

// Link direction and strain; inv_r0 = 1 / r0 (precomputed: no division per link).
struct LinkGeometry {
  Vec3 n;     // unit vector from i to j
  float r;    // current distance
  float eps;  // pair strain h / r0, positive in tension
};

MCA_HD LinkGeometry link_geometry(DVec3 xi, DVec3 xj, float r0, float inv_r0) {
  const Vec3 d = delta(xi, xj);
  const float r = length(d);
  const float inv = r > 0.0f ? 1.0f / r : 0.0f;
  return {d * inv, r, (r - r0) * inv_r0};  // r - r0 is exact (Sterbenz): eps keeps its relative precision
}

struct LinkInput {
  LinkGeometry g;
  float area;
  float two_g;              // 2 G_ij of the pair, strengthening applied
  float kt;                 // tangential spring k_s G_ij S / r0 [N/m], strengthening applied
  float many_body;          // P_i + P_j, strengthening applied
  float damping;            // viscous coefficient [N s/m] of relative motion (0: none)
  Vec3 vi, vj, wi, wj;
  Vec3 ut;                  // tangential displacement of the previous step
  float dt;
};

struct LinkOutput {
  Vec3 force_i;   // force on i (on j: the opposite); the torque on both is (r/2) n x force_i
  Vec3 ut;        // updated tangential displacement
  float sigma;    // normal stress (tension > 0)
  float tau2;     // shear stress squared, (kt |ut| / S)^2
};

MCA_HD LinkOutput link_force(const LinkInput& in) {
  const Vec3 n = in.g.n;
  LinkOutput out;
  out.sigma = in.two_g * in.g.eps + in.many_body;  // paper eq. 5, phi = 2G
  // Relative velocity of j's contact point with respect to i's (paper eq. 10).
  const Vec3 vrel = (in.vj - in.vi) - (0.5f * in.g.r) * cross(in.wi + in.wj, n);
  const float vn = dot(vrel, n);
  const Vec3 vs = vrel - vn * n;
  // The stored displacement turns with the pair: its normal part is dropped (a second-order loss of
  // length under rotation, which only dissipates).
  out.ut = (in.ut - dot(in.ut, n) * n) + vs * in.dt;
  const Vec3 ft = in.kt * out.ut + in.damping * vs;
  const float tau_s = in.kt / in.area;
  out.tau2 = tau_s * tau_s * dot(out.ut, out.ut);
  out.force_i = (out.sigma * in.area + in.damping * vn) * n + ft;  // paper eqs. 11, 12
  return out;
}

}  // namespace mca
