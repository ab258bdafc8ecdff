// The critical time step of a model (physics.md sec. 7, docs/model-notes.md "Time step").
//
// Symplectic Euler is stable while omega dt < 2 (sqrt(1 + zeta^2) - zeta) for every mode of the linearised
// system M x'' = -K x - C x', zeta = c / (2 omega). The step is bounded from Omega^2 >= the largest
// eigenvalue of M^-1 K and C_d >= that of M^-1 C as dt = (sqrt(4 Omega^2 + C_d^2) - C_d) / Omega^2, with
// Omega^2 the sum (Weyl's inequality) of:
//   - the links and face contacts, by comparison with the periodic lattice whose every face has the
//     stiffest normal and shear spring and every automaton the least mass (its largest eigenvalue, from
//     a plane-wave analysis, is max(2 k_S d^2 / J, (4 k_N + 8 k_S) / m)), plus the rolling springs;
//   - the many-body term, by Gershgorin automaton by automaton (surfaces raise it);
//   - one-sided contacts (the ground, projectiles) by the Gershgorin rows of their own elements (Rows below).
// Projectiles get their own bound. Measured thresholds lie 1.1-2x above the bound, so C = 1 is stable for
// the linear system; contacts and large rotations are not linear, hence the default safety below 1.
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <numbers>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "core/rng.hpp"
#include "lattice/lattice.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca::lattice {
namespace {

// Row sums of one body's translation (u) and rotation (w) rows: the largest eigenvalue of its diagonal
// block per lattice axis, plus the coupling norms, in mass-normalised units; and the same for dashpots.
struct Rows {
  double diag_u[3] = {0, 0, 0}, diag_w[3] = {0, 0, 0};  // per lattice axis (diagonal blocks)
  double off_u = 0, off_w = 0;                         // sums of coupling norms
  double damp_u = 0, damp_w = 0;                       // damping row sums (diagonal and coupling)
  double omega2() const {
    const double du = std::max({diag_u[0], diag_u[1], diag_u[2]}), dw = std::max({diag_w[0], diag_w[1], diag_w[2]});
    return std::max(du + off_u, dw + off_w);
  }
  // Critical step of this body alone, with its dashpots.
  double critical() const {
    const double du = std::max({diag_u[0], diag_u[1], diag_u[2]}) + off_u;
    const double dw = std::max({diag_w[0], diag_w[1], diag_w[2]}) + off_w;
    double best = std::numeric_limits<double>::infinity();
    for (auto [w2, c] : {std::pair{du, damp_u}, std::pair{dw, damp_w}}) {
      if (!(w2 > 0)) continue;
      const double w = std::sqrt(w2), zeta = c / (2 * w);
      best = std::min(best, 2.0 / w * (std::sqrt(1 + zeta * zeta) - zeta));
    }
    return best;
  }
};

// Adds a two-body spring set (normal k_n, tangential k_t with levers ra, rb to the rotations, a rotational
// spring kr and a twisting spring kw) to body a's rows, seen from a: a's mass ma, inertia ja; the other
// body's mb, jb (infinite for the ground). `axis` is the lattice axis of the normal for links (-1: any
// direction, which bounds the diagonal block by the largest of k_n and k_t on every axis).
void add_pair(Rows& r, int axis, double kn, double kt, double ra, double rb, double kr, double ma, double ja,
              double mb, double jb, double cn, double ct, double cr) {
  const bool rigid = !std::isfinite(mb);
  for (int c = 0; c < 3; ++c) {
    const double k_u = axis < 0 ? std::max(kn, kt) : (c == axis ? kn : kt);
    const double k_w = axis < 0 ? kt * ra * ra + kr : (c == axis ? kr : kt * ra * ra + kr);
    r.diag_u[c] += k_u / ma;
    r.diag_w[c] += k_w / ja;
  }
  const double mu = std::sqrt(ma), muj = std::sqrt(ja);
  // Own rotation from the shear lever.
  r.off_u += kt * ra / (mu * muj);
  r.off_w += kt * ra / (mu * muj);
  if (!rigid) {
    const double sb = std::sqrt(mb), sjb = std::sqrt(jb);
    r.off_u += std::max(kn, kt) / (mu * sb) + kt * rb / (mu * sjb);
    r.off_w += kt * ra / (muj * sb) + (kt * ra * rb + kr) / (muj * sjb);
  }
  // Dashpots: the normal one acts along n, the tangential one (link damping) across, the rotational one
  // on the relative rotation.
  const double c_u = std::max(cn, ct);
  r.damp_u += c_u / ma + (rigid ? 0.0 : c_u / (mu * std::sqrt(mb)));
  r.damp_w += cr / ja + ct * ra * ra / ja + (rigid ? 0.0 : (cr + ct * ra * rb) / (muj * std::sqrt(jb)));
}

// A contact's springs with the damping ratio of continuous time (the bound does not depend on the step).
ContactSprings springs(const ContactMaterial& c, float ra, float rb, double m_eff, double j_eff) {
  return body_contact_springs(c, c.zeta, ra, rb, static_cast<float>(m_eff), static_cast<float>(j_eff));
}

// r += e with every row times k.
void add_scaled(Rows& r, const Rows& e, double k) {
  for (int a = 0; a < 3; ++a) {
    r.diag_u[a] += e.diag_u[a] * k;
    r.diag_w[a] += e.diag_w[a] * k;
  }
  r.off_u += e.off_u * k;
  r.off_w += e.off_w * k;
  r.damp_u += e.damp_u * k;
  r.damp_w += e.damp_w * k;
}

// r = e with every row times k.
void set_scaled(Rows& r, const Rows& e, double k) {
  r = Rows{};
  add_scaled(r, e, k);
}

double critical_step(double w2, double c) { return w2 > 0 ? (std::sqrt(4 * w2 + c * c) - c) / w2 : INFINITY; }

// The step of stiffness w2 and damping c, named: where the dashpots shorten it by half again or more, they
// are named with the factor (a material's damping_time is a time, so at a small spacing, whose modes are
// fast, it overdamps them: the step falls with the square of the spacing, 20 times shorter at 1 mm).
void set_step(TimeStepBound& out, double w2, double c, const std::string& springs) {
  out.dt = critical_step(w2, c);
  out.limited_by = springs;
  const double undamped = critical_step(w2, 0);
  if (undamped > 1.5 * out.dt)
    out.limited_by += fmt::format(", shortened {:.3g} times by their dashpots (the materials' damping_time, "
                                  "solver.link_damping)",
                                  undamped / out.dt);
}

// The automata of surface-mode objects: no lattice, each link its own length, cross-section and masses,
// so the bound is Gershgorin's, automaton by automaton: the rows of its explicit links (normal and shear
// springs with levers r0 / 2 to the rotations, strengthened to the largest factor, and the bending
// spring on the relative rotation at its stiffest), of six face contacts
// with automata like itself (as many faces as a lattice automaton has) and of the ground; the shell's
// many-body term (a rank-one term lambda V ff g g^T per automaton, g the gradient of its L) as for the
// lattice. Dashpots likewise.
struct SurfaceBound {
  double omega2 = 0, damping = 0;
  std::int64_t lightest = -1;  // the lightest surface-mode automaton (for the projectiles' bound)
  std::size_t automata = 0;
};

// Adds to r the one-sided contacts an automaton of group ga (mass ma, inertia ja, radius ra) may come to
// hold: the ground, and each projectile's element twice (see the lattice's one-sided contacts).
void add_one_sided(Rows& r, const Model& M, std::size_t ga, double ma, double ja, double ra) {
  if (M.ground) {
    const ContactSprings c = springs(M.ground_contact[ga], static_cast<float>(ra), INFINITY, ma, ja);
    add_pair(r, -1, c.kn, c.kt, ra, 0, c.kr + c.kw, ma, ja, INFINITY, INFINITY, c.cn / 3, 0, 0);
  }
  for (std::size_t p = 0; p < M.projectiles.size(); ++p) {
    const ProjectileParams& P = M.projectiles[p];
    const ContactSprings c = springs(M.projectile_contact(p, ga), static_cast<float>(ra), P.radius,
                                     P.kinematic ? ma : reduced(ma, P.mass), P.kinematic ? ja : reduced(ja, P.inertia));
    Rows e;
    add_pair(e, -1, c.kn, c.kt, ra, 0, c.kr + c.kw, ma, ja, INFINITY, INFINITY, c.cn / 3, 0, 0);
    add_scaled(r, e, 2);
  }
}

// Per automaton of a surface-mode object: its Gershgorin rows (omega2: the largest of its translation
// and rotation rows plus its many-body row, normalised by its mass and, for the coupling, the lightest
// surface automaton's; damping: its dashpot rows); zero for lattice automata. The scene's bound is the
// largest of each over the automata (surface_bound).
struct SurfaceRows {
  std::vector<double> omega2, damping;
  std::int64_t lightest = -1;
  std::size_t automata = 0;
};

// Automata joined by explicit links: of surface-mode objects and of the random lattice (their rows are
// the surface automata's, with the random lattice's many-body term and without its bending springs: of a
// random automaton only an unlinked one's rows are used, random_lattice_bound bounds the others).
bool explicit_automaton(const Model& M, std::size_t a) { return M.object_surface[M.object[a]] || M.random_automaton(a); }

const char* explicit_bound_name(const Model& M) {
  return M.object_random.empty() ? "the explicit links and contacts of the surface-mode automata"
                                 : "the links and contacts of the random lattice's automata";
}

SurfaceRows surface_rows(const Model& M, const std::vector<double>& fmax) {
  SurfaceRows b;
  const auto& E = M.explicit_links;
  const std::size_t n = M.size();
  if (M.object_surface.empty()) return b;
  // The gradient of automaton a's many-body strain by the stretch of its link l: the shell's
  // (dims / count) / r0, the random lattice's A / (2 V) (random_many_body).
  const auto grad = [&](std::size_t a, std::uint32_t l) {
    if (M.random_automaton(a)) return static_cast<double>(E.area[l]) / (2.0 * M.volume[a]);
    const int count = static_cast<int>(E.first[a + 1] - E.first[a]), dims = std::min(count, 2);
    return static_cast<double>(dims) / count / E.r0[l];
  };
  b.omega2.assign(n, 0.0);
  b.damping.assign(n, 0.0);
  std::vector<double> mb_scale(n, 0.0), mb_total(n, 0.0), mb_row(n, 0.0);
  double m_min = INFINITY;
  for (std::size_t a = 0; a < n; ++a) {
    if (!explicit_automaton(M, a)) continue;
    ++b.automata;
    if (M.mass[a] < m_min) {
      m_min = M.mass[a];
      b.lightest = static_cast<std::int64_t>(a);
    }
    const GroupParams& g = M.groups[M.group[a]];
    const std::uint32_t first = E.first.empty() ? 0 : E.first[a], last = E.first.empty() ? 0 : E.first[a + 1];
    const int count = static_cast<int>(last - first), dims = std::min(count, 2);
    if (count > 0) {
      // |g| over the stencil: the automaton's own displacement (at most the sum) and each neighbour's.
      double s = 0;
      for (std::uint32_t k = first; k < last; ++k) s += grad(a, E.of[k]);
      // Sum of |g| / sqrt(m) over the stencil, for the mass-normalised rows.
      mb_total[a] = s / std::sqrt(static_cast<double>(M.mass[a]));
      for (std::uint32_t k = first; k < last; ++k) {
        const std::uint32_t l = E.of[k], o = E.i[l] == a ? E.j[l] : E.i[l];
        mb_total[a] += grad(a, l) / std::sqrt(static_cast<double>(M.mass[o]));
      }
      // (The shell's plane-stress factor; the random lattice's lambda carries its factor.)
      const double ff = M.random_automaton(a) ? M.lattice_lambda
                                              : 1.0 / (1.0 + (3 - dims) * g.lame_lambda / (2.0 * g.shear_modulus));
      mb_scale[a] = std::max(0.0, static_cast<double>(g.lame_lambda)) * fmax[M.group[a]] * M.volume[a] * ff;
      mb_row[a] += mb_scale[a] * s * mb_total[a];
    }
  }
  if (b.automata == 0) return b;
  for (std::size_t l = 0; l < E.size(); ++l)
    for (int end = 0; end < 2; ++end) {
      const std::uint32_t c = end ? E.j[l] : E.i[l], a = end ? E.i[l] : E.j[l];
      mb_row[a] += mb_scale[c] * grad(c, l) * mb_total[c];
    }
  for (std::size_t a = 0; a < n; ++a) {
    if (!explicit_automaton(M, a)) continue;
    const std::size_t ga = M.group[a];
    const GroupParams& A = M.groups[ga];
    const double ma = M.mass[a], ja = M.inertia[a], ra = M.radius[a];
    Rows r;
    for (std::uint32_t k = E.first.empty() ? 0 : E.first[a]; k < (E.first.empty() ? 0 : E.first[a + 1]); ++k) {
      const std::uint32_t l = E.of[k], o = E.i[l] == a ? E.j[l] : E.i[l];
      const GroupParams& B = M.groups[M.group[o]];
      const bool random = M.random_automaton(a);
      const double s = random ? M.lattice_stiffness : 1.0, sl = random ? M.lattice_lambda : 1.0;
      const double G = s * harmonic(A.shear_modulus, B.shear_modulus), f = std::max(fmax[ga], fmax[M.group[o]]);
      const double r0 = E.r0[l], area = E.area[l];
      const double kn = (2 * G + 0.5 * sl * (A.lame_lambda + B.lame_lambda)) * area / r0 * f;
      const double kt = kShearFactor * G * area / r0 * f;
      const LinkDashpots c = explicit_link_dashpots(static_cast<float>(kn), M.mass[a], M.mass[o],
                                           0.5f * (A.damping_time + B.damping_time), M.link_damping);
      // The bending and twisting spring on the relative rotation (link_bending): its stiffest axis.
      const LinkBendingConstants bc = link_bending_constants(harmonic(A.youngs, B.youngs), 0.5 * (A.poisson + B.poisson), r0,
                                                             E.edge[l], area / E.edge[l]);
      // With the bending's many-body part (explicit_bending_many_body): its couplings of this link's
      // rotation about n x m with every link of either end, c (dims / count)^2 / (r0 r0'), c = D nu A.
      const auto many_body = [&](std::uint32_t x) {
        const GroupParams& X = M.groups[M.group[x]];
        const std::uint32_t first = E.first[x], count = E.first[x + 1] - first;
        double inv = 0;
        for (std::uint32_t y = first; y < first + count; ++y) inv += 1.0 / E.r0[E.of[y]];
        const double share = static_cast<double>(std::min(count, 2u)) / count;
        const std::uint32_t l0 = E.of[first];
        return std::fabs(bending_many_body_constant(X.youngs, X.poisson, E.area[l0] / E.edge[l0], M.volume[x])) *
               share * share * inv / r0;
      };
      const double kr = random ? 0.0
                               : std::max({static_cast<double>(bc.k_twist), static_cast<double>(bc.k_in),
                                           bc.k_out + many_body(a) + many_body(o)});
      add_pair(r, -1, kn, kt, 0.5 * r0, 0.5 * r0, kr, ma, ja, M.mass[o], M.inertia[o], c.normal, c.tangential, 0);
    }
    const ContactSprings cs = springs(M.contact_material(ga, ga), static_cast<float>(ra), static_cast<float>(ra),
                                      0.5 * ma, 0.5 * ja);
    for (int k = 0; k < 6; ++k)
      add_pair(r, -1, cs.kn, cs.kt, ra, ra, cs.kr + cs.kw, ma, ja, ma, ja, cs.cn / 3, 0, 0);
    add_one_sided(r, M, ga, ma, ja, ra);
    // Row a of M^-1/2 K M^-1/2 for the many-body term: sum over the stencils c holding a of
    // s_c |g_ca| sum_b |g_cb| / sqrt(m_a m_b).
    b.omega2[a] = r.omega2() + mb_row[a] / std::sqrt(ma);
    b.damping[a] = std::max(r.damp_u, r.damp_w);
  }
  return b;
}

// The random lattice's automata: the largest eigenvalue of M^-1/2 K M^-1/2, by power iteration, with each
// Voronoi neighbour pair holding the stiffer of its link and its contact (a link that breaks leaves its
// pair touching, with the link's normal stiffness: Model::contact_length, as the backend's contacts take
// it; until 2026-12-03 the contact law's E d here, up to 50 times stiffer for a small face, which halved
// the step of a free block), the link's springs at the largest strengthening, and the many-body term's
// rank-one terms lambda V g g^T, and each automaton's one-sided contacts (the ground, projectiles) on the
// diagonal.
// Gershgorin's rows (surface_rows) bound it too, but for a network of triangles they are loose: each
// automaton's rows add the norms of about 12 couplings that do not all push one way. The iteration's
// Rayleigh quotient converges from below; a 10 % margin covers what it has not reached (on the default
// wall it is within 2e-4 of its final value after 75 of its 150 rounds). The dashpots' part likewise.
struct RandomBound {
  double omega2 = 0, damping = 0;
  std::size_t automata = 0;
};

// The pairs' springs (or dashpots) of the random lattice's links: normal kn, tangential kt on the relative
// motion of the contact point (levers r0 / 2), rotational kr on the relative rotation.
struct RandomPair {
  std::uint32_t i, j;
  double kn, kt, kr, lever, area;
  DVec3 n;
};

// The pairs that touch each of `ranges` consecutive ranges of automata (range r: the automata a with
// a * ranges / n == r), in pair order, each with which of its ends lie in the range (kEndI, kEndJ). A range
// that applies only its own ends' terms, pair by pair in this order, adds to each of its automata the
// terms the serial loop over all pairs adds, in the same order: the same bits for any number of ranges.
constexpr std::uint32_t kEndI = 1u << 31, kEndJ = 1u << 30, kPairIndex = kEndJ - 1;
std::vector<std::vector<std::uint32_t>> pairs_by_range(const std::vector<RandomPair>& pairs, std::size_t n,
                                                       std::size_t ranges) {
  std::vector<std::vector<std::uint32_t>> touch(ranges);
  for (std::size_t q = 0; q < pairs.size(); ++q) {
    const std::size_t ri = pairs[q].i * ranges / n, rj = pairs[q].j * ranges / n;
    const auto index = static_cast<std::uint32_t>(q);
    if (ri == rj) {
      touch[ri].push_back(index | kEndI | kEndJ);
    } else {
      touch[ri].push_back(index | kEndI);
      touch[rj].push_back(index | kEndJ);
    }
  }
  return touch;
}

// The largest eigenvalue of M^-1/2 K M^-1/2 for the pairs' springs and, where mb is not empty, the many-body
// term's rank-one terms mb_c g_c g_c^T (mb_c = lambda V of automaton c, g_c the gradient of its theta),
// over translations and rotations (150 rounds of power iteration from a fixed start), plus `diag` (per
// automaton, mass-normalised: a bound on the one-sided contacts' own elements) on its diagonal. The
// products run over `ranges` ranges of automata in parallel (pairs_by_range; 0: ranges of at least 4,096
// automata, about four per thread), the sums over all automata in their order: the same bits for any
// count of ranges and threads.
double largest_eigenvalue(const Model& M, const std::vector<RandomPair>& pairs, const std::vector<double>& mb,
                          const std::vector<double>& diag, std::size_t ranges) {
  const std::size_t n = M.size();
  std::vector<double> inv_m(n, 0.0), inv_j(n, 0.0);
  std::vector<DVec3> x(2 * n), y(2 * n);
  std::vector<double> theta(n, 0.0);
  for (std::size_t a = 0; a < n; ++a) {
    if (!M.random_automaton(a)) continue;
    inv_m[a] = 1.0 / std::sqrt(static_cast<double>(M.mass[a]));
    inv_j[a] = 1.0 / std::sqrt(static_cast<double>(M.inertia[a]));
    for (std::size_t h = 0; h < 2; ++h) {
      double c[3];
      for (std::uint64_t k = 0; k < 3; ++k) c[k] = 2.0 * unit_from_hash(hash_keys(0x706f776572ull, a, 3 * h + k)) - 1.0;
      x[2 * a + h] = {c[0], c[1], c[2]};
    }
  }
  if (ranges == 0) {
    const std::size_t threads = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
    ranges = std::clamp<std::size_t>(n / 4096, 1, 4 * threads);
  }
  // One range, or pairs too many for their indices to fit beside the flags: the serial loop.
  if (pairs.size() > kPairIndex) ranges = 1;
  const auto touch = ranges > 1 ? pairs_by_range(pairs, n, ranges) : std::vector<std::vector<std::uint32_t>>{};
  const auto each_range = [&](const auto& body) {
    if (ranges == 1) {
      for (const RandomPair& p : pairs) body(p, true, true);
      return;
    }
    tbb::parallel_for(std::size_t{0}, ranges, [&](std::size_t r) {
      for (const std::uint32_t e : touch[r]) body(pairs[e & kPairIndex], (e & kEndI) != 0, (e & kEndJ) != 0);
    });
  };
  const auto each_automaton = [&](const auto& body) {
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4096), [&](const tbb::blocked_range<std::size_t>& b) {
      for (std::size_t a = b.begin(); a < b.end(); ++a) body(a);
    });
  };
  double lambda = 0;
  for (int round = 0; round < 150; ++round) {
    double norm = 0;
    for (const DVec3& v : x) norm += dot(v, v);
    norm = std::sqrt(norm);
    if (!(norm > 0)) break;
    each_automaton([&](std::size_t a) {
      x[2 * a] = x[2 * a] * (1.0 / norm);
      x[2 * a + 1] = x[2 * a + 1] * (1.0 / norm);
      y[2 * a] = x[2 * a] * diag[a];
      y[2 * a + 1] = x[2 * a + 1] * diag[a];
      theta[a] = 0.0;
    });
    each_range([&](const RandomPair& p, bool own_i, bool own_j) {
      const std::uint32_t i = p.i, j = p.j;
      const DVec3 ui = x[2 * i] * inv_m[i], uj = x[2 * j] * inv_m[j];
      const DVec3 ti = x[2 * i + 1] * inv_j[i], tj = x[2 * j + 1] * inv_j[j];
      // The contact point's relative displacement; the springs' force and torque on i (j takes -f and the
      // same lever torque, and the opposite rotational spring's).
      const DVec3 rel = uj - ui - cross(ti + tj, p.n) * p.lever;
      const double along = dot(rel, p.n);
      const DVec3 f = p.n * (p.kn * along) + (rel - p.n * along) * p.kt;
      const DVec3 lever = cross(p.n, f) * p.lever, spin = (tj - ti) * p.kr;
      // y = M^-1/2 K M^-1/2 x, K u the force's negative.
      if (own_i) {
        y[2 * i] -= f * inv_m[i];
        y[2 * i + 1] -= (lever + spin) * inv_j[i];
      }
      if (own_j) {
        y[2 * j] += f * inv_m[j];
        y[2 * j + 1] -= (lever - spin) * inv_j[j];
      }
      // The many-body strains: theta_c = sum A r eps / (2 V), eps = n (u_j - u_i) / r.
      if (!mb.empty()) {
        const double e = dot(p.n, uj - ui) * p.area / 2.0;
        if (own_i) theta[i] += e / M.volume[i];
        if (own_j) theta[j] += e / M.volume[j];
      }
    });
    if (!mb.empty())
      each_range([&](const RandomPair& p, bool own_i, bool own_j) {
        // The many-body energy's gradient lambda V theta d(theta)/du, on both ends of each link.
        const double t = (mb[p.i] * theta[p.i] / M.volume[p.i] + mb[p.j] * theta[p.j] / M.volume[p.j]) * p.area / 2.0;
        if (own_i) y[2 * p.i] -= p.n * (t * inv_m[p.i]);
        if (own_j) y[2 * p.j] += p.n * (t * inv_m[p.j]);
      });
    double rq = 0;
    for (std::size_t q = 0; q < x.size(); ++q) rq += dot(x[q], y[q]);
    lambda = std::max(lambda, rq);
    x.swap(y);
  }
  return lambda;
}

RandomBound random_lattice_bound(const Model& M, const std::vector<double>& fmax, std::size_t ranges) {
  RandomBound b;
  const auto& E = M.explicit_links;
  const std::size_t n = M.size();
  std::vector<RandomPair> springs_of, dashpots_of;
  for (std::size_t l = 0; l < E.size(); ++l) {
    const std::uint32_t i = E.i[l], j = E.j[l];
    if (!M.random_automaton(i)) continue;
    const GroupParams &A = M.groups[M.group[i]], &B = M.groups[M.group[j]];
    const double f = std::max(fmax[M.group[i]], fmax[M.group[j]]), s = M.lattice_stiffness;
    const double G = s * harmonic(A.shear_modulus, B.shear_modulus), r0 = E.r0[l], area = E.area[l];
    const ContactSprings cs = M.pair_contact_springs(i, j, static_cast<std::int64_t>(l),
                                                     M.contact_material(M.group[i], M.group[j]).zeta);
    const DVec3 d = ddelta(M.position0[i], M.position0[j]);
    const DVec3 u{d.x / r0, d.y / r0, d.z / r0};
    // The link's bending and twisting spring (volume_bending_constants), as an isotropic one of its
    // stiffer axis, or the contact's rolling and twisting springs, whichever is stiffer.
    double k_rot = static_cast<double>(cs.kr) + cs.kw;
    if (M.lattice_bending > 0.0f) {
      const LinkBendingConstants bc = M.explicit_bending(l);  // the backend's constants
      k_rot = std::max({k_rot, static_cast<double>(bc.k_in), static_cast<double>(bc.k_twist)});
    }
    springs_of.push_back({i, j, std::max(2.0 * G * area / r0 * f, static_cast<double>(cs.kn)),
                          std::max(kShearFactor * G * area / r0 * f, static_cast<double>(cs.kt)), k_rot, 0.5 * r0,
                          area, u});
    // The link's dashpots at the largest strengthening (the backend's are set from the unstrengthened
    // stiffness; this is the larger) and a contact's normal one at a third, without the rolling and
    // twisting dashpots, as the cubic lattice's bound takes them (below: a clipped contact dashpot damps
    // the high modes far less than a linear one, and those modes have no relative rotation).
    const double sl = M.lattice_lambda;
    const float k_n = link_normal_stiffness(static_cast<float>(G * f), static_cast<float>(sl * f * A.lame_lambda),
                                            static_cast<float>(sl * f * B.lame_lambda), E.area[l], static_cast<float>(r0));
    const LinkDashpots c = explicit_link_dashpots(k_n, M.mass[i], M.mass[j], 0.5f * (A.damping_time + B.damping_time),
                                                  M.link_damping);
    dashpots_of.push_back({i, j, c.normal + cs.cn / 3.0, c.tangential, 0.0, 0.5 * r0, area, u});
  }
  std::vector<double> mb(n, 0.0), one_sided(n, 0.0), one_sided_c(n, 0.0);
  for (std::size_t a = 0; a < n; ++a) {
    if (!M.random_automaton(a)) continue;
    ++b.automata;
    const std::size_t ga = M.group[a];
    const GroupParams& g = M.groups[ga];
    mb[a] = std::max(0.0, M.lattice_lambda * static_cast<double>(g.lame_lambda)) * fmax[ga] * M.volume[a];
    // The one-sided contacts any automaton may come to hold, the ground and each projectile (its element
    // twice, as the lattice's: a sphere touching many automata at once): their own elements' rows bound
    // them, on the automaton's diagonal.
    const double ma = M.mass[a], ja = M.inertia[a], ra = M.radius[a];
    Rows e;
    add_one_sided(e, M, ga, ma, ja, ra);
    one_sided[a] = e.omega2();
    one_sided_c[a] = std::max(e.damp_u, e.damp_w);
  }
  if (springs_of.empty()) return b;
  b.omega2 = 1.1 * largest_eigenvalue(M, springs_of, mb, one_sided, ranges);
  b.damping = 1.1 * largest_eigenvalue(M, dashpots_of, {}, one_sided_c, ranges);
  return b;
}

// The surface automata's part of the bound: the rows of the automaton whose own critical step (its
// stiffness rows with its own dashpots) is the smallest, as an explicit finite-element code takes the
// smallest of its elements' steps, each with its own damping. (Until the mass scaling of uneven meshes it
// paired the largest stiffness row of one automaton with the largest dashpot row of another; on the cow
// both came from the same sliver triangles, and the measured threshold lies 2-3x above either.)
SurfaceBound surface_bound(const Model& M, const std::vector<double>& fmax, std::size_t ranges) {
  const SurfaceRows rows = surface_rows(M, fmax);
  SurfaceBound b;
  b.lightest = rows.lightest;
  b.automata = rows.automata;
  // The random lattice's automata: the power iteration's bound over those with links; one without any (an
  // object of one automaton), which the iteration sees only on its diagonal, by its Gershgorin rows, which
  // hold its contacts.
  const RandomBound r = M.object_random.empty() ? RandomBound{} : random_lattice_bound(M, fmax, ranges);
  const auto& E = M.explicit_links;
  const auto unlinked = [&](std::size_t a) { return E.first.empty() || E.first[a + 1] == E.first[a]; };
  double least = INFINITY;
  for (std::size_t a = 0; a < rows.omega2.size(); ++a) {
    if (!M.object_surface[M.object[a]] && !(M.random_automaton(a) && unlinked(a))) continue;
    const double dt = critical_step(rows.omega2[a], rows.damping[a]);
    if (dt < least) {
      least = dt;
      b.omega2 = rows.omega2[a];
      b.damping = rows.damping[a];
    }
  }
  if (r.omega2 > 0 && critical_step(r.omega2, r.damping) < least) {
    b.omega2 = r.omega2;
    b.damping = r.damping;
  }
  return b;
}

std::vector<double> max_strengthening(const Model& M) {
  std::vector<double> fmax(M.groups.size(), 1.0);
  for (std::size_t g = 0; g < M.groups.size(); ++g)
    fmax[g] = strengthening_factor(M.groups[g].strengthening, M.groups[g].strengthening.cap);
  return fmax;
}

void projectile_bounds(const Model& M, const std::vector<char>& used, TimeStepBound& out, const SurfaceBound& surface);

}  // namespace

std::vector<double> surface_automaton_steps(const Model& M) {
  const SurfaceRows rows = surface_rows(M, max_strengthening(M));
  std::vector<double> dt(M.size(), INFINITY);
  for (std::size_t a = 0; a < rows.omega2.size(); ++a)
    if (explicit_automaton(M, a)) dt[a] = critical_step(rows.omega2[a], rows.damping[a]);
  return dt;
}

TimeStepBound critical_time_step(const Model& M, std::size_t ranges) {
  const std::size_t n = M.size(), G = M.groups.size();
  TimeStepBound out;
  out.dt = std::numeric_limits<double>::infinity();
  if (n == 0) return out;
  const double d = M.spacing;
  const std::vector<double> fmax = max_strengthening(M);
  // The automata of surface-mode objects (explicit links) get their own bound (surface_bound); the
  // lattice bound below is over the others.
  auto on_lattice = [&](std::size_t a) { return M.object_surface.empty() || !explicit_automaton(M, a); };
  double m_min = INFINITY, j_min = INFINITY;
  std::vector<char> used(G, 0);
  for (std::size_t a = 0; a < n; ++a) {
    if (!on_lattice(a)) continue;
    used[M.group[a]] = 1;
    m_min = std::min<double>(m_min, M.mass[a]);
    j_min = std::min<double>(j_min, M.inertia[a]);
  }
  const SurfaceBound surface = surface_bound(M, fmax, ranges);
  if (!std::isfinite(m_min)) {  // no lattice automata
    set_step(out, surface.omega2, surface.damping, explicit_bound_name(M));
    out.objects_dt = out.dt;
    projectile_bounds(M, used, out, surface);
    return out;
  }

  // (1) Links and face contacts. Every face of an automaton holds a link (normal 2 G S / r0, shear
  // k_s G S / r0, both times the strengthening factor) or a contact (normal E_12 d, the same shear). The
  // model's K is at most that of the periodic lattice where every face has the largest normal and shear
  // stiffness and every automaton the smallest mass and inertia (K only grows and M only shrinks, so the
  // largest eigenvalue can only grow; a finite lattice's K is a restriction of the periodic one). A
  // plane-wave analysis of that lattice (tools/ not needed: its maximum is at k = 0 for the rotation and
  // at the checkerboard for the translation) gives
  //   omega^2 = max(2 k_S d^2 / J, (4 k_N + 8 k_S) / m),
  // the uniform rotation (every face sheared by d theta) and the checkerboard translation; for nu = 0
  // it is 24 G / (rho d^2), and a power iteration on a 6^3 block gives 23.2 G / (rho d^2).
  double kN = 0, kS = 0, kr = 0, kw = 0;
  for (std::size_t g = 0; g < G; ++g) {
    if (!used[g]) continue;
    const GroupParams& A = M.groups[g];
    kN = std::max(kN, 2.0 * A.shear_modulus * fmax[g] * d);
    kS = std::max(kS, kShearFactor * A.shear_modulus * fmax[g] * d);
    for (std::size_t h = 0; h < G; ++h) {
      if (!used[h]) continue;
      const ContactSprings c = springs(M.contact_material(g, h), 0.5f * d, 0.5f * d, 1.0f, 1.0f);
      kN = std::max<double>(kN, c.kn);
      kS = std::max<double>(kS, c.kt);
      kr = std::max<double>(kr, c.kr);
      kw = std::max<double>(kw, c.kw);
    }
  }
  double omega2 = std::max(2 * kS * d * d / j_min, (4 * kN + 8 * kS) / m_min);
  // Rolling and twisting springs of face contacts (Gershgorin on the rotations: 2 k per contact, four
  // rolling and two twisting faces about any axis).
  omega2 += (8 * kr + 4 * kw) / j_min;

  // (2) The many-body term, lambda V theta L / 2 per automaton: a sum of rank-one terms lambda V ff g g^T
  // over each automaton's stencil (g the gradient of L). Its largest eigenvalue is bounded by Gershgorin,
  // automaton by automaton, since surfaces (axes with one link, where the automaton's own displacement
  // enters L with 1 / d) raise it above the interior's 9 lambda / (rho d^2). Weyl's inequality adds it
  // to (1). A negative lambda (nu < 0) makes the term negative and is left out.
  {
    std::vector<std::array<int, 3>> count(n, {0, 0, 0});
    M.for_each_link([&](std::size_t, std::uint32_t i, std::uint32_t j, int axis) {
      if (axis < 0) return;
      ++count[i][axis];
      ++count[j][axis];
    });
    std::vector<double> self(n, 0.0), total(n, 0.0), scale(n, 0.0), row(n, 0.0);
    for (std::size_t a = 0; a < n; ++a) {
      if (!on_lattice(a)) continue;
      const GroupParams& g = M.groups[M.group[a]];
      int single = 0, linked = 0, free_axes = 0;
      for (int ax = 0; ax < 3; ++ax) {
        single += count[a][ax] == 1;
        linked += count[a][ax] > 0;
        free_axes += count[a][ax] == 0;
      }
      self[a] = std::sqrt(static_cast<double>(single)) / d;  // the automaton's own displacement in L
      total[a] = linked / d + self[a];                          // sum of |g| over the stencil
      const double ff = 1.0 / (1.0 + free_axes * g.lame_lambda / (2.0 * g.shear_modulus));
      scale[a] = std::max(0.0, static_cast<double>(g.lame_lambda)) * fmax[M.group[a]] * M.volume[a] * ff;
      row[a] += scale[a] * self[a] * total[a];
    }
    M.for_each_link([&](std::size_t, std::uint32_t i, std::uint32_t j, int axis) {
      if (axis < 0) return;
      for (int end = 0; end < 2; ++end) {
        const std::uint32_t c = end ? j : i, a = end ? i : j;
        row[a] += scale[c] / (count[c][axis] * d) * total[c];
      }
    });
    double mb = 0;
    for (std::size_t a = 0; a < n; ++a)
      if (on_lattice(a)) mb = std::max(mb, row[a] / std::sqrt(M.mass[a] * m_min));
    omega2 += mb;
  }

  // (3) One-sided contacts of an automaton: the ground, a projectile (Weyl again: the largest eigenvalue
  // of the contact's own element, by Gershgorin over its rows).
  double damping = 0;  // the same bounds for the dashpots: the largest eigenvalue of M^-1 C
  {
    double one_sided = 0, one_sided_c = 0;
    for (std::size_t g = 0; g < G; ++g) {
      if (!used[g]) continue;
      const double m = M.groups[g].density * d * d * d, j = m * d * d / 6, r = 0.5 * d;
      if (M.ground) {
        Rows e;
        const ContactSprings c = springs(M.ground_contact[g], r, INFINITY, m, j);
        add_pair(e, -1, c.kn, c.kt, r, 0, c.kr + c.kw, m, j, INFINITY, INFINITY, c.cn / 3, 0, 0);
        one_sided = std::max(one_sided, e.omega2());
        one_sided_c = std::max(one_sided_c, std::max(e.damp_u, e.damp_w));
      }
      // A projectile contact couples a light automaton to a heavy sphere touching many of them at once.
      // Each contact's matrix [H X; X^T L] (H on the projectile, L on the automaton) is at most
      // 2 diag(H, L); summed over the contacts, the automata get 2 L each and the projectile 2 sum H.
      for (std::size_t p = 0; p < M.projectiles.size(); ++p) {
        const ProjectileParams& P = M.projectiles[p];
        Rows e;
        const ContactSprings c = springs(M.projectile_contact(p, g), r, P.radius, P.kinematic ? m : reduced(m, P.mass),
                                         P.kinematic ? j : reduced(j, P.inertia));
        add_pair(e, -1, c.kn, c.kt, r, 0, c.kr + c.kw, m, j, INFINITY, INFINITY, c.cn / 3, 0, 0);
        one_sided = std::max(one_sided, 2 * e.omega2());
        one_sided_c = std::max(one_sided_c, 2 * std::max(e.damp_u, e.damp_w));
      }
    }
    omega2 += one_sided;
    damping += one_sided_c;
  }

  // Dashpots of the links (linear: as (1), 4 c / m for normal dashpots, which damp the checkerboard
  // translation, and 12 c / m for tangential ones, which damp the uniform rotation too) and of face contacts. A
  // contact dashpot is clipped (it cannot pull), which damps the high modes far less than a linear one:
  // measured thresholds (a compressed, fully broken 8^3 block at e = 0.01, 0.05, 0.1) lie at 2.9x, 1.9x
  // and 1.7x the linear bound, so it enters at a third of its linear value (4 c_n / m for the bounding
  // lattice). The rolling and twisting dashpots act on the relative rotation of two bodies in contact,
  // which the two highest modes (uniform rotation, checkerboard translation) do not have; they are left
  // out (a compressed, fully broken block with them stays stable up to the undamped limit).
  {
    double c_normal = 0, c_tangential = 0;
    const float r0 = M.spacing, area = r0 * r0;
    M.for_each_link([&](std::size_t, std::uint32_t i, std::uint32_t j, int axis) {
      if (axis < 0) return;
      const GroupParams &gi = M.groups[M.group[i]], &gj = M.groups[M.group[j]];
      const float k = link_normal_stiffness(harmonic(gi.shear_modulus, gj.shear_modulus), gi.lame_lambda,
                                            gj.lame_lambda, area, r0);
      const LinkDashpots c = link_dashpots(k, M.mass[i], M.mass[j], 0.5f * (gi.damping_time + gj.damping_time),
                                           M.link_damping);
      c_normal = std::max<double>(c_normal, c.normal);
      c_tangential = std::max<double>(c_tangential, c.tangential);
    });
    double cn = 0;
    for (std::size_t g = 0; g < G; ++g)
      for (std::size_t h = 0; h < G; ++h) {
        if (!used[g] || !used[h]) continue;
        const double mg = M.groups[g].density * d * d * d, mh = M.groups[h].density * d * d * d;
        const ContactSprings c = springs(M.contact_material(g, h), 0.5f * d, 0.5f * d,
                                                      reduced(mg, mh), reduced(mg, mh) * d * d / 6);
        cn = std::max<double>(cn, c.cn);
      }
    damping += (4 * c_normal + 12 * c_tangential) / m_min + 4 * cn / 3 / m_min;
  }

  // A jittered lattice (SolverDef::lattice_jitter): the bound above is the cubic lattice's, links d long.
  // A link r long has normal and shear stiffness d / r times a d-long one's, and its shear spring acts
  // on the automata's rotation with an arm r / 2: its rotational stiffness is r / d times; all of them
  // times the lattice's stiffness factor. The largest of those factors over the links bounds them all
  // (the model's K only shrinks when each link's stiffness is lowered to that bound's), and the
  // dashpots scale with it at most as much.
  if (!M.link_rest.empty()) {
    double factor = M.lattice_stiffness;  // (the moduli's factor, on top)
    for (std::size_t l = 0; l < M.lattice_slots(); ++l)
      if (M.neighbour[l] != Model::kNoLink)
        factor = std::max({factor, M.lattice_stiffness * d / M.link_rest[l], M.lattice_stiffness * M.link_rest[l] / d});
    omega2 *= factor;
    damping *= factor;
  }
  // Surface-mode automata touch lattice ones only through contacts: Weyl again.
  set_step(out, omega2 + surface.omega2, damping + surface.damping,
           surface.omega2 > omega2 ? explicit_bound_name(M) : "the links and contacts of the automata");
  out.objects_dt = out.dt;
  projectile_bounds(M, used, out, surface);
  return out;
}

namespace {

void projectile_bounds(const Model& M, const std::vector<char>& used, TimeStepBound& out, const SurfaceBound& surface) {
  const std::size_t n = M.size(), G = M.groups.size();
  const double d = M.spacing;

  // Projectiles: as many automata as fit around one at once (4 pi (R + r)^2 / d^2), each contact's H
  // twice (see above), plus the ground and the other projectiles.
  for (std::size_t p = 0; p < M.projectiles.size(); ++p) {
    const ProjectileParams& P = M.projectiles[p];
    if (P.kinematic) continue;
    Rows rp;
    for (std::size_t g = 0; g < G; ++g) {
      if (!used[g]) continue;
      const double m = M.groups[g].density * d * d * d, j = m * d * d / 6, r = 0.5 * d;
      const double touching = std::min<double>(n, std::ceil(4 * std::numbers::pi * std::pow(P.radius + r, 2) / (d * d)));
      const ContactSprings c = springs(M.projectile_contact(p, g), r, P.radius, reduced(m, P.mass), reduced(j, P.inertia));
      Rows e;
      add_pair(e, -1, c.kn, c.kt, P.radius, 0, c.kr + c.kw, P.mass, P.inertia, INFINITY, INFINITY, c.cn / 3, 0, 0);
      const double k = 2 * touching;
      if (e.omega2() * k > rp.omega2()) set_scaled(rp, e, k);
    }
    // The lightest surface-mode automaton, as many times as fit around the projectile.
    if (surface.lightest >= 0) {
      const auto a = static_cast<std::size_t>(surface.lightest);
      const double m = M.mass[a], j = M.inertia[a], r = M.radius[a];
      const double touching = std::min<double>(surface.automata, std::ceil(4 * (P.radius + r) * (P.radius + r) / (r * r)));
      const ContactSprings c = springs(M.projectile_contact(p, M.group[a]), static_cast<float>(r), P.radius,
                                       reduced(m, P.mass), reduced(j, P.inertia));
      Rows e;
      add_pair(e, -1, c.kn, c.kt, P.radius, 0, c.kr + c.kw, P.mass, P.inertia, INFINITY, INFINITY, c.cn / 3, 0, 0);
      const double k = 2 * touching;
      if (e.omega2() * k > rp.omega2()) set_scaled(rp, e, k);
    }
    if (M.ground) {
      const ContactSprings g = springs(M.projectile_ground_contact(p), P.radius, INFINITY, P.mass, P.inertia);
      add_pair(rp, -1, g.kn, g.kt, P.radius, 0, g.kr + g.kw, P.mass, P.inertia, INFINITY, INFINITY, g.cn / 3, 0, 0);
    }
    // The other projectiles: no more of them touch this one at once than fit around it, at most
    // 4 (R_p + R_q)^2 / R_q^2 of radius R_q (the sphere of their centres over the area each takes; 16 for
    // equal balls, whose true number is 12). With more projectiles than that the row holds that many
    // times the largest of each pair's terms; adding every pair made the step fall with the number of
    // balls wherever they were (balls of 2 cm 5 m apart beside a box: one 1.21e-6 s, 17 4.86e-7 s, 100
    // 1.76e-7 s, 1,000 2.94e-8 s; now 100 and 1,000 step as 17 do).
    Rows pairs, largest;
    double fit = 0;
    for (std::size_t q = 0; q < M.projectiles.size(); ++q) {
      if (q == p) continue;
      const ProjectileParams& Q = M.projectiles[q];
      const double mb = Q.kinematic ? INFINITY : Q.mass, jb = Q.kinematic ? INFINITY : Q.inertia;
      const ContactSprings c = springs(M.projectile_pair_contact(p, q), P.radius, Q.radius,
                                       contact_reduced(P.mass, false, Q.mass, Q.kinematic),
                                       contact_reduced(P.inertia, false, Q.inertia, Q.kinematic));
      Rows e;
      add_pair(e, -1, c.kn, c.kt, P.radius, Q.radius, c.kr + c.kw, P.mass, P.inertia, mb, jb, c.cn / 3, 0, 0);
      add_scaled(pairs, e, 1.0);
      for (int a = 0; a < 3; ++a) {
        largest.diag_u[a] = std::max(largest.diag_u[a], e.diag_u[a]);
        largest.diag_w[a] = std::max(largest.diag_w[a], e.diag_w[a]);
      }
      largest.off_u = std::max(largest.off_u, e.off_u);
      largest.off_w = std::max(largest.off_w, e.off_w);
      largest.damp_u = std::max(largest.damp_u, e.damp_u);
      largest.damp_w = std::max(largest.damp_w, e.damp_w);
      const double rq = static_cast<double>(Q.radius), s = (static_cast<double>(P.radius) + rq) / rq;
      fit = std::max(fit, std::ceil(4 * s * s));
    }
    const double others = static_cast<double>(M.projectiles.size()) - 1;
    add_scaled(rp, others <= fit ? pairs : largest, others <= fit ? 1.0 : fit);
    const double dt = rp.critical();
    if (dt < out.dt) {
      out.dt = dt;
      out.limited_by = fmt::format("projectile '{}' (mass {:.3g} kg) against the automata it can touch", P.name, P.mass);
    }
  }
}

}  // namespace

}  // namespace mca::lattice
