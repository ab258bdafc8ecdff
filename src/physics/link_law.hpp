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
//   W = sum_links G_ij eps_ij^2 V + sum_i (lambda_i theta_i L_i / 2) V,
// L_i the sum over linked axes of i's mean strains and theta_i = L_i / (1 + n_free lambda_i / (2 G_i)):
// the free-axis strains minimise W, so lambda theta^2 / 2 + G sum_free e_f^2 = lambda theta L / 2. The law
// conserves energy up to the integrator, and unequal materials need no extra solve.
//
// Shear (paper eq. 10, contact point at mid-distance).  The tangential displacement u_t of j's contact
// point relative to i's is integrated from V_s and kept tangent; F_t = k_s G S u_t / r0 acts on i, -F_t on
// j, and both automata feel the torque (r/2) n x F_t (= (r/2) n x F, since n x n = 0).
#include <type_traits>

#include "core/exp.hpp"
#include "core/math.hpp"
#include "core/model.hpp"  // Strengthening

namespace mca {

// Two springs in series of equal length: 2 a b / (a + b) (pair moduli). An infinite b gives 2 a.
MCA_HD float harmonic(float a, float b) {
  if (b == INFINITY) return 2.0f * a;
  return a + b > 0.0f ? 2.0f * a * b / (a + b) : 0.0f;
}

// Shear stiffness factor of the link: a free-rotating cubic lattice in simple shear gives each pair half
// the engineering shear strain, so k_s = 2 returns G (checked by the shear-modulus test).
inline constexpr float kShearFactor = 2.0f;

// Strengthening (paper eq. 7): the moduli of a material at pair strain e are E0 f(|e|), f = exp(alpha e)
// (law 1) or 1 + alpha e^2 (law 2), held at f(cap) beyond |e| = cap (the material's largest breaking
// strain: the displacement criterion ends a link in tension there; in compression the modulus stops
// growing there). For the force to be the gradient of an energy, a pair law sigma = f(e) (2 G e + ...)
// is written through the strengthened strain s(e) = sign(e) sqrt(2 F(|e|)), F(e) = int_0^e t f(t) dt:
// the linear law's energy in s instead of e. Its derivative is g(e) = ds/de = e f(e) / s(e), and a
// one-automaton bar, where everything is linear in s, gets the secant modulus E0 f(e) of eq. 7 exactly.
MCA_HD float strengthening_factor(const Strengthening& s, float e) {
  e = std::fmin(std::fabs(e), s.cap);
  if (s.law == 1) return exp_rn(s.alpha * e);
  if (s.law == 2) return 1.0f + s.alpha * e * e;
  return 1.0f;
}

// df/de at |e| (0 beyond the cap), sign(e) included: the derivative with respect to e itself.
MCA_HD float strengthening_slope(const Strengthening& s, float e) {
  const float a = std::fabs(e);
  if (a >= s.cap || s.law == 0) return 0.0f;
  const float d = s.law == 1 ? s.alpha * exp_rn(s.alpha * a) : 2.0f * s.alpha * a;
  return e < 0.0f ? -d : d;
}

// F(|e|) = int_0^|e| t f(t) dt, in double: the exponential form cancels for small alpha e.
MCA_HD double strengthening_energy(const Strengthening& s, double e) {
  e = std::fabs(e);
  const double c = std::fmin(e, static_cast<double>(s.cap));
  double F;
  if (s.law == 1 && s.alpha > 0) {
    const double a = s.alpha, x = a * c;
    // int_0^c t e^(a t) dt = (x e^x - (e^x - 1)) / a^2, with the difference formed by a series for small x
    // (from |x| = 1e-3 on, e^x - 1 from e^x loses 3 of double's 16 digits: exp_rn has no expm1).
    const double ex = exp_rn(x);
    F = std::fabs(x) < 1e-3 ? c * c * (0.5 + x / 3.0 + x * x / 8.0) : (x * ex - (ex - 1.0)) / (a * a);
  } else if (s.law == 2) {
    F = 0.5 * c * c + 0.25 * s.alpha * c * c * c * c;
  } else {
    F = 0.5 * c * c;
  }
  if (e > c) F += 0.5 * static_cast<double>(strengthening_factor(s, static_cast<float>(c))) * (e * e - c * c);
  return F;
}

struct StrengthenedStrain {
  float s;  // sign(e) sqrt(2 F(|e|))
  float g;  // ds/de = |e| f(|e|) / |s|
  float f;  // f(|e|)
};

MCA_HD StrengthenedStrain strengthened_strain(const Strengthening& st, float e) {
  if (st.law == 0) return {e, 1.0f, 1.0f};
  const float f = strengthening_factor(st, e);
  const float a = static_cast<float>(std::sqrt(2.0 * strengthening_energy(st, e)));
  if (a == 0.0f) return {0.0f, 1.0f, f};
  return {e < 0.0f ? -a : a, std::fabs(e) * f / a, f};
}

// free_factor[f] = 1 / (1 + f lambda / (2 G)) of the automaton's group, for f = 0..3 free axes.
MCA_HD void free_axis_factors(float lambda, float shear_modulus, float free_factor[4]) {
  for (int f = 0; f < 4; ++f) free_factor[f] = 1.0f / (1.0f + static_cast<float>(f) * lambda / (2.0f * shear_modulus));
}

// Volumetric strain of an automaton from, per lattice axis, the summed strain and count of its intact
// links along it (a count of 0, 1 or 2, as a number of type T). Axes without links are free:
// e_f = -lambda theta / (2 G) each, so theta = sum_linked / (1 + n_free lambda / (2 G)).
// free_factor: the group's factors (float), or per lane.
template <class T, class F>
MCA_HD T volumetric_strain(const T sum[3], const T cnt[3], const F free_factor[4]) {
  T linked = 0.0f;
  T free_axes = 0.0f;
  for (int a = 0; a < 3; ++a) {
    const auto has = cnt[a] > 0.0f;
    linked = select(has, linked + sum[a] * select(cnt[a] == 1.0f, T(1.0f), T(0.5f)), linked);
    free_axes = select(has, free_axes, free_axes + 1.0f);
  }
  const T factor = select(free_axes == 0.0f, T(free_factor[0]),
                          select(free_axes == 1.0f, T(free_factor[1]),
                                 select(free_axes == 2.0f, T(free_factor[2]), T(free_factor[3]))));
  return linked * factor;
}

// The many-body term of an automaton with explicit links (surface mode: a shell one automaton thick),
// from the sum of the (strengthened) strains of its `count` intact explicit links. Its links lie in the
// shell, so its strain has `dims` = min(count, 2) linked directions: the mean of a strain field over the
// directions of a plane is half its in-plane trace, so L = dims * sum / count, and the directions out of
// it are free, theta = L / (1 + (3 - dims) lambda / (2 G)), as volumetric_strain does for a lattice. The
// energy is lambda theta L V / 2 (V the automaton's volume); its derivative along one link's strain is
// lambda theta V dims / count: the value returned, which a link turns into a stress by dividing by its
// r0 S (link_normal_stress's P). One link gives a bar (modulus E), two or more a plate in plane stress.
struct ExplicitManyBody {
  float L;       // linked strain sum
  float theta;   // volumetric strain
  float weight;  // lambda theta V dims / count [N m]: per link, divided by r0 S, the stress P
};

MCA_HD ExplicitManyBody explicit_many_body(float lambda, const float free_factor[4], float volume, float sum, int count) {
  if (count <= 0) return {0.0f, 0.0f, 0.0f};
  const int dims = count < 2 ? count : 2;
  const float share = static_cast<float>(dims) / static_cast<float>(count);
  const float L = sum * share;
  const float theta = L * free_factor[3 - dims];
  return {L, theta, lambda * theta * volume * share};
}

// The many-body term of an automaton of the random lattice (lattice/random_lattice.hpp): its volumetric
// strain by the divergence theorem over its Voronoi cell, sum_faces A (r / 2) e_nn / V (A the face's area,
// r the distance to the site beyond it), each face's normal strain e_nn its link's strengthened strain s
// (the cubic lattice's sum is this with A r = V = d^3). A face without an intact link (toward a ghost,
// at the object's surface, or a broken link's) is free: its normal strain is the traction-free one,
// 2 G e_nn + lambda theta = 0, as the cubic lattice's free axes take theirs (volumetric_strain), so
// theta = S / (2 V + F lambda / (2 G)), S = sum_intact A r s, F = sum_free A r. Its energy is
// lambda theta S / 4 (lambda theta^2 V / 2 inside, F = 0), whose derivative puts the stress
// lambda theta / 2 on each of its links (added to 2 G eps and the other end's share, the cubic law's
// interior form). lambda: with the lattice's factor; lambda_over_2g: the group's lambda / (2 G).
struct RandomManyBody {
  float theta, stress;
};
MCA_HD RandomManyBody random_many_body(float lambda, float lambda_over_2g, float volume, float sum, float free) {
  const float theta = sum / (2.0f * volume + free * lambda_over_2g);
  return {theta, 0.5f * lambda * theta};
}

// Bending and twisting of an explicit link (surface mode; the random lattice's links take the same spring
// with their own constants, volume_bending_constants below). A shell one automaton thick has no bending
// stiffness from pair forces alone (each automaton turns with its links and the chain folds freely), nor
// enough in-plane shear stiffness (its links form a honeycomb), so an explicit link also resists the
// relative rotation of its ends, as the bonds of bonded-particle models do: about the link (twist) and
// about n x m (bending of the shell), both D (1 - nu) e / r0, e the shared edge's length, D the plate's
// rigidity, and about the shell's normal m (in-plane bending, E t e^3 / (12 r0), t the thickness); with
// the automata's many-body part (explicit_bending_many_body: `extra` below) the shell is a Kirchhoff
// plate (link_bending_constants). The spring's moment is kept incrementally as its three
// components on the pair's current frame (n, m, n x m): each step each grows by its stiffness times the
// relative rotation of the step about its axis, so the moment turns with the pair, and its energy
// sum M_k^2 / (2 k_k) changes by exactly the work of the torque. (Kept as a vector in the world and
// re-projected on each step's frame, which float rounding leaves a little off unit length, it grew by
// about 1e-7 a step: a cantilever at rest rose against gravity.) It acts as +M on the first end and -M on
// the second. The bending moments load the
// section's outer fibres, sigma = M_m e / (2 I_in) + M_b t / (2 I_out), and the twist its shear
// tau = M_n b / J, which the fracture criteria see with the pair's own stresses.
template <class T>
struct LinkBendingInputT {
  Vec3T<T> n, m;           // link direction; the shell's normal at the link, orthogonal to n (unit vectors)
  Vec3T<T> wi, wj;         // angular velocities of the ends
  Vec3T<T> moment;         // the spring's moment on the first end about (n, m, n x m), from the previous step
  T k_twist, k_in, k_out;  // [N m / rad]
  T s_in, s_out, s_twist;  // outer-fibre stress per unit moment [1 / m^3]: e / (2 I_in), t / (2 I_out), b / J
  T extra;                 // the automata's many-body moment about n x m (explicit_bending_many_body), not state
  float dt;
};

template <class T>
struct LinkBendingOutputT {
  Vec3T<T> moment;  // updated components about (n, m, n x m)
  Vec3T<T> torque;  // the moment in the world: the torque on the first end (the second gets -torque)
  T sigma;          // largest bending stress of the section's outer fibres (>= 0)
  T tau;            // twisting shear stress (>= 0)
};

template <class T>
MCA_HD LinkBendingOutputT<T> link_bending(const LinkBendingInputT<T>& in) {
  const Vec3T<T> b = cross(in.n, in.m);
  const Vec3T<T> wrel = in.wj - in.wi;
  const T mn = in.moment.x + in.k_twist * in.dt * dot(wrel, in.n);
  const T mm = in.moment.y + in.k_in * in.dt * dot(wrel, in.m);
  const T mb = in.moment.z + in.k_out * in.dt * dot(wrel, b);
  LinkBendingOutputT<T> out;
  out.moment = {mn, mm, mb};
  const T mb_all = mb + in.extra;
  out.torque = mn * in.n + mm * in.m + mb_all * b;
  using std::fabs;
  out.sigma = fabs(mm) * in.s_in + fabs(mb_all) * in.s_out;
  out.tau = fabs(mn) * in.s_twist;
  return out;
}

// The bending spring's constants of an explicit link of rest length r0 between materials of Young's
// modulus E and Poisson's ratio nu (the pair's), its shared edge `edge` long and the shell `thickness`
// thick. A plate of curvature K turns a link's ends (direction n, t its in-plane perpendicular) by
// r0 kappa_nn about b = n x m and r0 kappa_nt about n, so a link with k_out = B e / r0 about b and
// k_twist = T e / r0 about n, over its share e r0 / 2 of the shell, holds on average over directions
// spread evenly (three at 60 degrees suffice) the energy density (3B + T) / 8 (kxx^2 + kyy^2) +
// (B - T) / 4 kxx kyy + (B + T) / 2 kxy^2. Kirchhoff's plate, D / 2 [(1 - nu) (kxx^2 + kyy^2 + 2 kxy^2) +
// nu (kxx + kyy)^2] with D = E t^3 / (12 (1 - nu^2)), is its (1 - nu) part for B = T = D (1 - nu) (= G t^3 / 6),
// and the nu part is the automata's (explicit_bending_many_body). B = D (1 + nu), T = D (1 - 3 nu) would
// give the plate from the links alone, but with B != T the relative rotations of neighbouring automata
// (up and down triangles) shift against each other, which no shear spring resists: measured, such a
// shell bent 2.8 times too easily at nu = 0.3 (docs/model-notes.md, "Surface mode"). The in-plane spring
// about m is a beam's, E t e^3 / (12 r0). The fibre stresses are the section's: a moment about b on the
// edge's e x t section loads its outer fibre with 6 M / (e t^2) (t / (2 I_out)), one about m with
// 6 M / (t e^2), and the twist its shear M b / J (J = a b^3 / 3 of the a x b section, b the smaller side).
struct LinkBendingConstants {
  float k_twist, k_in, k_out, s_in, s_out, s_twist;
};

inline LinkBendingConstants link_bending_constants(double E, double nu, double r0, double edge, double thickness) {
  const double a = edge > thickness ? edge : thickness, b = edge > thickness ? thickness : edge;
  const double J = a * b * b * b / 3.0;
  const double I_in = thickness * edge * edge * edge / 12.0, I_out = edge * thickness * thickness * thickness / 12.0;
  const double k = E * thickness * thickness * thickness / (12.0 * (1.0 + nu)) * edge / r0;  // D (1 - nu) e / r0
  return {static_cast<float>(k),                     static_cast<float>(E * I_in / r0),
          static_cast<float>(k),                     static_cast<float>(0.5 * edge / I_in),
          static_cast<float>(0.5 * thickness / I_out), static_cast<float>(b / J)};
}

// The bending and twisting spring of a random-lattice link (volume law; Model::lattice_bending = beta),
// the parallel bond of bonded-particle models: the link is a beam of its Voronoi face's area A, taken as a
// circular section (I = A^2 / (4 pi) about every axis across the link, J = 2 I about it, the outer fibre
// at c = sqrt(A / pi)), E and G the pair's (with the lattice's stiffness factor): across the link
// k = beta E I / r0, about it k = beta G J / r0. The fibre's stress per unit moment is c / I across the
// link, the twist's shear c / J = half that. A round section has no axes of its own, so the spring needs
// no reference axis (volume_link_bending). Without it a line of intact links
// is a hinge: two ends turning opposite ways about an axis across the link stretch no spring (link_force
// sees only the sum of their rotations), and a cracked body stayed one piece, swinging on the few links
// its crack had left (docs/model-notes.md, "The random lattice", Bending).
// (Here k_in = k_out is the bending stiffness, s_in = s_out the fibre's stress per unit moment,
// s_twist = s_in / 2 exactly.)
inline LinkBendingConstants volume_bending_constants(double E, double G, double r0, double edge, double beta) {
  constexpr double pi = 3.14159265358979323846;
  const double A = edge * edge, I = A * A / (4.0 * pi), c = std::sqrt(A / pi);
  const double k_bend = beta * E * I / r0, k_twist = beta * G * 2.0 * I / r0;
  const float s = static_cast<float>(c / I);
  return {static_cast<float>(k_twist), static_cast<float>(k_bend), static_cast<float>(k_bend), s, s, 0.5f * s};
}

// A random-lattice link's bending and twisting spring (volume_bending_constants) on its ends' relative
// rotation phi (a vector in the world: axis times angle), kept as the link's state and grown each step by
// the step's relative rotation dt (w_j - w_i), after turning it with the pair by dt times the mean of the
// ends' angular velocities (to second order: its length changes by O((w dt)^4)). So it follows the
// angular velocities, which are double, not the orientations, which are float: the orientations'
// rounding turned two automata spinning together against each other by about 1e-5 rad in 0.3 s, which a
// spring on them took for a bend and turned into energy (a hostile review, 2026-12-03). The moment is
// k_twist phi_n about the link's current direction n and k_bend phi_b across it, +M on the first end and
// -M on the second; its energy k_twist phi_n^2 / 2 + k_bend |phi_b|^2 / 2 (energies()). The criteria see
// the fibre's stress |M_b| c / I and the twist's shear |M_n| c / J (s and s / 2).
template <class T>
struct VolumeBendingInputT {
  Vec3T<T> n;       // link direction (unit)
  Vec3T<T> wi, wj;  // angular velocities of the ends
  Vec3T<T> phi;     // relative rotation after the previous step
  T k_bend, k_twist, s;
  float dt;
};

template <class T>
struct VolumeBendingT {
  Vec3T<T> phi;     // relative rotation after this step
  Vec3T<T> torque;  // on the first end (the second gets -torque)
  T sigma;          // the outer fibre's bending stress (>= 0)
  T tau;            // the twist's largest shear stress (>= 0)
};

template <class T>
MCA_HD VolumeBendingT<T> volume_link_bending(const VolumeBendingInputT<T>& in) {
  const Vec3T<T> w = (in.wi + in.wj) * 0.5f;
  const Vec3T<T> turn = cross(w, in.phi) * in.dt;
  VolumeBendingT<T> out;
  out.phi = in.phi + turn + cross(w, turn) * (0.5f * in.dt) + (in.wj - in.wi) * in.dt;
  const T phi_n = dot(out.phi, in.n);
  const Vec3T<T> mb = (out.phi - phi_n * in.n) * in.k_bend;
  const T mn = in.k_twist * phi_n;
  using std::fabs;
  using std::sqrt;
  out.torque = mb + mn * in.n;
  out.sigma = sqrt(dot(mb, mb)) * in.s;
  out.tau = fabs(mn) * (0.5f * in.s);
  return out;
}

// The energy M^2 / (2 k) of one axis of the spring (0 for a spring of no stiffness, whose moment stays 0).
MCA_HD double bending_energy(double M, double k) { return k > 0 ? 0.5 * M * M / k : 0.0; }

// The nu part of a shell's bending (surface mode), per automaton as the membrane's many-body term:
// D nu A (tr K)^2 / 2 with A the automaton's share of the shell (its volume over the thickness) and tr K
// from the relative rotations phi_l about b of its `count` intact links, r0 kappa_nn each: the mean of
// kappa_nn over the directions of the plane is tr K / 2, so tr K = dims sum / count with sum = sum_l
// phi_l / r0_l and dims = min(count, 2) (one link: a beam, tr K = kappa_nn). Its derivative along one
// link's phi is c tr K (dims / count) / r0_l, c = D nu A: `weight` is c tr K dims / count [N m^2], which the
// link divides by its r0 and adds, from both ends, to its moment about b.
struct ExplicitBending {
  float trace;   // tr K [1/m]
  float weight;  // [N m^2]
};

// c = D nu A = E nu t^2 V / (12 (1 - nu^2)) of an automaton of volume V in a shell t thick.
inline double bending_many_body_constant(double E, double nu, double thickness, double volume) {
  return E * nu * thickness * thickness * volume / (12.0 * (1.0 - nu * nu));
}

MCA_HD ExplicitBending explicit_bending_many_body(float c, float sum, int count) {
  if (count <= 0) return {0.0f, 0.0f};
  const int dims = count < 2 ? count : 2;
  const float share = static_cast<float>(dims) / static_cast<float>(count);
  const float trace = sum * share;
  return {trace, c * trace * share};
}

// The shell's normal at a link from its ends' orientations: the rest normal m0 turned by each end's
// rotation, the mean of the two, made orthogonal to the link's direction n and of unit length.
template <class T>
MCA_HD Vec3T<T> shell_normal(const QuatT<T>& qi, const QuatT<T>& qj, const Vec3T<T>& m0, const Vec3T<T>& n) {
  Vec3T<T> m = rotated(qi, m0) + rotated(qj, m0);
  m = m - dot(m, n) * n;
  using std::sqrt;
  const T len = sqrt(dot(m, m));
  return m * select(len > 0.0f, 1.0f / len, T(0.0f));
}

// Viscous coefficients [N s/m] of a link's dashpots on the relative velocity of its ends. Normal: the
// materials' viscosity, Kelvin-Voigt c = tau k (tau the mean of the two materials' damping_time, k the
// pair's normal stiffness: a stiffness-proportional damping that gives a mode of angular frequency omega
// the ratio tau omega / 2), plus solver.link_damping, a share of the critical damping of that spring.
// Tangential: the share alone. The viscosity damps the lattice-scale ringing of a sudden load (the
// highest modes, omega ~ 3 c_p / d) the more the finer the lattice, and the vibrations of a body hardly
// (see docs/model-notes.md on drops); on the normal motion alone it does as well as on both in the drop
// tests and leaves the step alone for the highest mode (the uniform rotation, which has no normal motion).
struct LinkDashpots {
  float normal, tangential;
};

// A dashpot's root of a stiffness times a mass, in float as it always was; where the product leaves float
// (automata of a kilometre: k m_i m_j passes 3.4e38 at a spacing of 1.1 km in concrete, which made the
// links' dashpots NaN and a body at rest NaN at its first step), from the double product. sqrt(a b):
MCA_HD float product_root(float a, float b) {
  const float p = a * b;
  if (p <= kFloatMax) return std::sqrt(p);
  return static_cast<float>(std::sqrt(static_cast<double>(a) * b));
}
// and sqrt(k m_i m_j / (m_i + m_j)):
MCA_HD float reduced_root(float k, float m_i, float m_j) {
  const float p = k * m_i * m_j;
  if (p <= kFloatMax) return std::sqrt(p / (m_i + m_j));
  return static_cast<float>(std::sqrt(static_cast<double>(k) * m_i * m_j / (static_cast<double>(m_i) + m_j)));
}

MCA_HD LinkDashpots link_dashpots(float k_normal, float m_i, float m_j, float tau, float share) {
  const float critical = 2.0f * share * reduced_root(k_normal, m_i, m_j);
  return {tau * k_normal + critical, critical};
}

// The same for an explicit link (surface mode), whose viscous part is capped at the critical damping of
// the link's own spring, 2 sqrt(k m_i m_j / (m_i + m_j)): a mesh's short links between light automata
// have modes far above 2 / tau, which the viscosity overdamps; beyond critical a dashpot only slows such a
// mode down, and its coefficient would set a step tens of times smaller (measured on the paper's cow).
MCA_HD LinkDashpots explicit_link_dashpots(float k_normal, float m_i, float m_j, float tau, float share) {
  const float critical = 2.0f * reduced_root(k_normal, m_i, m_j);
  return {std::fmin(tau * k_normal, critical) + share * critical, share * critical};
}

// Normal stiffness of a link [N/m] for the dashpot and the time step: (2 G_ij + (lambda_i + lambda_j) / 2) S / r0.
MCA_HD float link_normal_stiffness(float G_ij, float lambda_i, float lambda_j, float area, float r0) {
  return (2.0f * G_ij + 0.5f * (lambda_i + lambda_j)) * area / r0;
}

// Link direction and strain; inv_r0 = 1 / r0 (precomputed: no division per link).
template <class T>
struct LinkGeometryT {
  Vec3T<T> n;  // unit vector from i to j
  T r;         // current distance
  T eps;       // pair strain h / r0, positive in tension
};
using LinkGeometry = LinkGeometryT<float>;

// The strain is formed in double before anything is rounded: h = r - r0 = (r^2 - r0^2) / (r + r0), with
// r^2 - r0^2 taken from the double centres (exact to 1e-16 of r0^2 near the origin, 1e-12 at 1 km).
// Rounding the centre difference to float first, as a float32 pipeline does, leaves a strain noise of
// 6e-8 that changes as the automata move: a force noise of E * 6e-8 * d^2 per link that heats a block
// at rest without bound (measured: 1e-5 J to 5e-4 J in 15,000 steps of a 0.4 m concrete cube).
// Only the quotient's denominator and the direction use the float r, where relative precision is enough.
// D: double (or double lanes); the result is in the matching float type.
// R: float for the lattice's rest length, double (or double lanes) for an explicit link's, whose ends
// are not laid out at a float distance (its float r0 enters only the denominator); I: float or lanes.
template <class D, class R, class I>
MCA_HD auto link_geometry(const Vec3T<D>& xi, const Vec3T<D>& xj, R r0, I inv_r0) {
  using T = decltype(to_float(D{}));
  const Vec3T<D> d = ddelta(xi, xj);
  const D r2 = dot(d, d);
  const auto r0d = [&] {
    if constexpr (std::is_floating_point_v<R>) return static_cast<double>(r0);
    else return r0;
  }();
  const auto r0f = [&] {
    if constexpr (std::is_floating_point_v<R>) return static_cast<float>(r0);
    else return to_float(r0);
  }();
  using std::sqrt;
  const T r = sqrt(to_float(r2));
  const T h = to_float(r2 - r0d * r0d) / (r + r0f);
  const T inv = select(r > 0.0f, 1.0f / r, T(0.0f));
  return LinkGeometryT<T>{Vec3T<T>{to_float(d.x), to_float(d.y), to_float(d.z)} * inv, r, h * inv_r0};
}

// A link's shear modulus G_ij: the harmonic mean of its ends' (two half-links in series), times the
// lattice's stiffness factor s (Model::lattice_stiffness of a jittered or random lattice; 1 for the cubic
// lattice and the shells: 1 x = x, the same bits).
MCA_HD float link_shear_modulus(float s, float G_i, float G_j) { return s * harmonic(G_i, G_j); }

// Normal stress of the pair law (paper eq. 5 with phi = 2G): sigma = 2 G_ij e (f_i + f_j) / 2 + g_i P_i +
// g_j P_j, with P the many-body terms of the two ends (from strengthened strains) and f, g of each end's
// material (strengthened_strain), per lane for a SIMD T. Without strengthening (f = g = 1, exact): 2 G_ij e +
// P_i + P_j, the same bits as the general form.
template <class T>
MCA_HD T link_normal_stress(T G_ij, T eps, T f_i, T f_j, T g_i, T g_j, T p_i, T p_j) {
  return G_ij * eps * (f_i + f_j) + g_i * p_i + g_j * p_j;
}
template <class T>
MCA_HD T link_normal_stress(T G_ij, T eps, T p_i, T p_j) {
  return G_ij * eps * 2.0f + p_i + p_j;
}

template <class T>
struct LinkInputT {
  LinkGeometryT<T> g;
  T area;
  T sigma;                  // normal stress of the law (link_normal_stress), without the shear coupling
  T kt;                     // tangential spring k_s G_ij S / r0 [N/m], strengthening applied
  T kt_slope;               // d kt / dr [N/m^2] under strengthening (0 without): the normal force the
                            // strain dependence of kt adds, so the pair keeps its energy
  T damp_normal, damp_tangential;  // viscous coefficients [N s/m] of the relative motion (LinkDashpots)
  Vec3T<T> dv;              // v_j - v_i, formed in double and rounded (delta)
  Vec3T<T> wi, wj;          // the ends' angular velocities, rounded to float
  Vec3T<T> ut;              // tangential displacement of the previous step
  float dt;
};

template <class T>
struct LinkOutputT {
  Vec3T<T> force_i;  // force on i (on j: the opposite); the torque on both is (r/2) n x force_i
  Vec3T<T> ut;       // updated tangential displacement
  T sigma;           // normal stress (tension > 0)
  T tau2;            // shear stress squared, (kt |ut| / S)^2
  T vn;              // normal and tangential relative velocity (softened_force)
  Vec3T<T> vs;
};

template <class T>
MCA_HD LinkOutputT<T> link_force(const LinkInputT<T>& in) {
  const Vec3T<T> n = in.g.n;
  LinkOutputT<T> out;
  // The velocities are the last step's (x_n - x_{n-1}) / dt, so the relative motion they give is split
  // into normal and tangential parts along the pair's direction in the middle of that step,
  // r_n - (dt / 2) dv, not along the end's n: taken along n, a pair turning rigidly at omega showed a
  // tangential velocity of order dt omega^2 r (and a normal one of dt omega^2 r / 2), which the shear
  // spring summed without end. A free body of the random lattice spinning at 50 rad/s stretched its
  // links by 7e-7 more every millisecond, at a rate proportional to the step, until they broke
  // (docs/model-notes.md, "Turning pairs"); along the mid-step direction the error is of order dt^2.
  using std::sqrt;
  const Vec3T<T> rm = in.g.r * n - (0.5f * in.dt) * in.dv;
  const T rm2 = dot(rm, rm);
  const Vec3T<T> nm = select(rm2 > 0.0f, rm * (1.0f / sqrt(rm2)), n);
  // Relative velocity of j's contact point with respect to i's (paper eq. 10).
  const Vec3T<T> vrel = in.dv - (0.5f * in.g.r) * cross(in.wi + in.wj, nm);
  const T vn = dot(vrel, nm);
  const Vec3T<T> vs = vrel - vn * nm;
  // The stored displacement turns with the pair: its part along the new n is dropped (a second-order
  // loss of length under rotation, which only dissipates).
  const Vec3T<T> u = in.ut + vs * in.dt;
  out.ut = u - dot(u, n) * n;
  const Vec3T<T> ft = in.kt * out.ut + in.damp_tangential * vs;
  const T tau_s = in.kt / in.area;
  const T ut2 = dot(out.ut, out.ut);
  out.tau2 = tau_s * tau_s * ut2;
  // d/dr (kt |u_t|^2 / 2): zero unless strengthening makes kt depend on the strain.
  out.sigma = in.sigma + 0.5f * in.kt_slope * ut2 / in.area;
  out.force_i = (out.sigma * in.area + in.damp_normal * vn) * n + ft;  // paper eqs. 11, 12
  out.vn = vn;
  out.vs = vs;
  return out;
}

// The force of a link of damage D (physics/fracture.hpp, link_softening_test): link_force's with its
// normal stress, while the link is stretched (in.g.eps > 0: the crack is open), and its shear spring kept
// by the share 1 - D; the dashpots, and the normal stress of a compressed link, are carried whole. (The
// many-body sums and the energy bookkeeping take the same test: the strain's sign.)
template <class T>
MCA_HD Vec3T<T> softened_force(const LinkInputT<T>& in, const LinkOutputT<T>& o, const T& damage) {
  const T keep = 1.0f - damage;
  const T sigma = select(in.g.eps > 0.0f, keep * o.sigma, o.sigma);
  return (sigma * in.area + in.damp_normal * o.vn) * in.g.n + ((keep * in.kt) * o.ut + in.damp_tangential * o.vs);
}

}  // namespace mca
