// Energies of a state, in double, serially: the measuring stick of the energy tests, of stats.csv and of
// the blow-up check. Every force of the step is the gradient of one of these terms or does work that is
// counted here (damping and sliding only take energy out):
//   links      sum_links [G_ij V (F_i(e) + F_j(e)) + k_t(e) |u_t|^2 / 2]     (F(e) = e^2 / 2 without
//   many-body  sum_i lambda_i theta_i L_i V / 2                              strengthening; link_law.hpp)
//   contacts   k_n delta^2 / 2 + k_t |u_t|^2 / 2 + rolling and twisting springs, for automaton pairs, the
//              ground, projectiles (contact_law.hpp)
//   kinetic    automata and projectiles, translation and rotation
//   work       gravity, [[load]] forces, grips, kinematic projectiles
#include <cmath>

#include "backend/backend.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca {

namespace {
double sq(Vec3 v) { return static_cast<double>(v.x) * v.x + static_cast<double>(v.y) * v.y + static_cast<double>(v.z) * v.z; }
double sq(DVec3 v) { return dot(v, v); }
double dotd(Vec3 a, Vec3 b) { return static_cast<double>(a.x) * b.x + static_cast<double>(a.y) * b.y + static_cast<double>(a.z) * b.z; }

// The positions and velocities energies are measured at: the state's own, or, synchronised, those of the
// last force evaluation, x_n = x - dt v. The kinetic energy there is that of the half-step velocities on
// either side of x_n, m v_{n-1/2} . v_{n+1/2} / 2 = m (|v_n|^2 - |h|^2) / 2, with v_n = v_{n+1/2} - h the
// velocity Verlet one and h = dt a_n / 2 half the last step's kick. With it, kinetic + elastic energy is
// what symplectic Euler conserves exactly for a linear law (the difference of two steps' sums cancels
// term by term), and to the law's small nonlinearity otherwise: the |v_n|^2 form alone oscillates by
// O((omega dt)^2), 2.4-2.95 % for an 8^3 block excited in all its modes at C = 0.5, and the naive sum over
// the stored half-step velocities by O(omega dt). Computed per access rather than in a copy of the state
// (which doubled the peak memory of a run at every frame).
struct View {
  const Model& m;
  const State& s;
  bool sync;
  DVec3 x(std::size_t a) const {
    DVec3 r = s.x[a];
    if (sync) r += s.v[a] * (-m.dt);
    return r;
  }
  // Half the last step's kick of the velocity and of the angular velocity (0 when not synchronised and
  // for held automata, which move at their grip's constant velocity).
  DVec3 hv(std::size_t a) const {
    return sync && m.grip[a] < 0 ? to_dvec3(s.f[a] * (0.5f * m.dt / m.mass[a])) : DVec3{};
  }
  DVec3 hw(std::size_t a) const {
    return sync && m.grip[a] < 0 ? to_dvec3(s.t[a] * (0.5f * m.dt / m.inertia[a])) : DVec3{};
  }
  double kinetic(std::size_t a) const {
    const DVec3 h = hv(a), g = hw(a);
    return 0.5 * m.mass[a] * (sq(s.v[a] - h) - sq(h)) + 0.5 * m.inertia[a] * (sq(s.w[a] - g) - sq(g));
  }
  DVec3 xp(std::size_t p) const {
    DVec3 r = s.projectiles[p].position;
    if (sync) r += s.projectiles[p].velocity * (-m.dt);
    return r;
  }
  double kinetic_p(std::size_t p) const {
    const ProjectileParams& P = m.projectiles[p];
    const ProjectileState& ps = s.projectiles[p];
    const DVec3 h = !sync || P.kinematic ? DVec3{}
                                         : to_dvec3((ps.force * (1.0f / P.mass) + m.gravity) * (0.5f * m.dt));
    // The spin's kick is not kept (ProjectileState has no torque): its plain square.
    return 0.5 * P.mass * (sq(ps.velocity - h) - sq(h)) + 0.5 * P.inertia * sq(ps.angular_velocity);
  }
};

Energies energies_of(const View& at);

}  // namespace

Energies compute_energies(const Model& m, const State& s) {
  return energies_of(View{m, s, s.f.size() == m.size() && s.step > 0});
}

Energies compute_energies_at(const Model& m, const State& s) { return energies_of(View{m, s, false}); }

namespace {

Energies energies_of(const View& at) {
  const Model& m = at.m;
  const State& s = at.s;
  Energies e;
  const std::size_t n = m.size();
  for (std::size_t a = 0; a < n; ++a) {
    e.kinetic += at.kinetic(a);
    const Vec3 dx = delta(m.position0[a], at.x(a));
    e.gravity_work += m.mass[a] * dotd(m.gravity, dx);
    if (!m.load.empty()) e.load_work += dotd(m.load[a], dx);
  }
  // Links: the 2G and shear parts per link; per automaton and axis the sum of strengthened strains for
  // the many-body part.
  // Explicit links (axis -1) sum per automaton apart: theirs is the shell's many-body term
  // (explicit_many_body).
  // The bending's many-body part likewise (explicit_bending_many_body): the sum of kappa_nn = phi / r0
  // over the intact links, phi = M_b / k_out the relative rotation about n x m the spring holds.
  std::vector<double> sum(3 * n, 0.0), explicit_sum, explicit_kappa, free_face;
  std::vector<int> cnt(3 * n, 0), explicit_cnt;
  if (m.explicit_links.size()) {
    explicit_sum.assign(n, 0.0);
    explicit_kappa.assign(n, 0.0);
    explicit_cnt.assign(n, 0);
  }
  // The random lattice's free faces (random_many_body): toward the ghosts, and its broken links'.
  if (!m.free_face.empty()) free_face.assign(m.free_face.begin(), m.free_face.end());
  m.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int ax) {
    if (!s.intact[l]) {
      if (ax < 0 && m.random_automaton(i)) {
        const double ar = static_cast<double>(m.link_area(l) * static_cast<float>(m.link_r0(l)));
        free_face[i] += ar;
        free_face[j] += ar;
      }
      return;
    }
    const GroupParams &gi = m.groups[m.group[i]], &gj = m.groups[m.group[j]];
    const double r0 = m.link_r0(l);
    const float area = m.link_area(l);
    const LinkGeometry g = ax >= 0 && !m.link_rest.empty()
                               ? link_geometry(at.x(i), at.x(j), m.link_rest[l], m.link_inv_rest[l])
                           : ax >= 0 ? link_geometry(at.x(i), at.x(j), m.spacing, 1.0f / m.spacing)
                                   : link_geometry(at.x(i), at.x(j), r0, static_cast<float>(1.0 / r0));
    // (A jittered or random lattice's links have its stiffness factor, as the backend's pair constants.)
    const bool random = ax < 0 && m.random_automaton(i);
    const double G = link_shear_modulus(ax >= 0 || random ? m.lattice_stiffness : 1.0f, gi.shear_modulus, gj.shear_modulus);
    const double V = static_cast<double>(area) * r0;
    const double f_mean = 0.5 * (strengthening_factor(gi.strengthening, g.eps) + strengthening_factor(gj.strengthening, g.eps));
    const double kt = kShearFactor * G * area / r0 * f_mean;
    // A damaged link (softening: physics/fracture.hpp) holds the undamaged share of its pair spring's
    // energy in tension and of its shear spring's, and its ends' many-body sums see that share of its
    // strain, as the forces do; the rest was dissipated.
    // (A surface-mode object's links never soften: their damage stays 0.)
    const double keep = !s.link_damage.empty() ? 1.0 - s.link_damage[l] : 1.0;
    e.elastic += (g.eps > 0 ? keep : 1.0) * G * V *
                     (strengthening_energy(gi.strengthening, g.eps) + strengthening_energy(gj.strengthening, g.eps)) +
                 keep * 0.5 * kt * sq(s.link_ut[l]);
    double si = strengthened_strain(gi.strengthening, g.eps).s, sj = strengthened_strain(gj.strengthening, g.eps).s;
    if (g.eps > 0 && !s.link_damage.empty() && (ax >= 0 || random)) {
      const float share = 1.0f - s.link_damage[l];  // as the many-body kernel takes it
      si = static_cast<float>(si) * share;
      sj = static_cast<float>(sj) * share;
    }
    if (random) {  // the random lattice's many-body sums: A r s (random_many_body)
      if (m.lattice_bending > 0.0f) {
        // Its bending and twisting spring (volume_link_bending: the ends' relative rotation, state, split
        // along the link), carried by the undamaged share.
        const std::size_t k = l - m.lattice_slots();
        const LinkBendingConstants bc = m.explicit_bending(k);
        const Vec3 phi = s.link_moment[k];
        const DVec3 n = to_dvec3(g.n);
        const double phi_n = dotd(phi, g.n);
        const DVec3 phi_b = to_dvec3(phi) - n * phi_n;
        e.elastic += keep * 0.5 * (static_cast<double>(bc.k_twist) * phi_n * phi_n + static_cast<double>(bc.k_in) * sq(phi_b));
      }
      explicit_sum[i] += static_cast<double>(area * static_cast<float>(r0) * static_cast<float>(si));
      explicit_sum[j] += static_cast<double>(area * static_cast<float>(r0) * static_cast<float>(sj));
      return;
    }
    if (ax < 0) {
      // The bending and twisting spring: its moment's components on the pair's frame (link_bending).
      const std::size_t k = l - m.lattice_slots();
      const LinkBendingConstants bc = m.explicit_bending(k);
      const Vec3 M = s.link_moment[k];
      const double mn = M.x, mm = M.y, mb = M.z;
      e.elastic += bending_energy(mn, bc.k_twist) + bending_energy(mm, bc.k_in) + bending_energy(mb, bc.k_out);
      const double kappa = bc.k_out > 0 ? mb / (static_cast<double>(bc.k_out) * static_cast<float>(r0)) : 0.0;
      explicit_kappa[i] += kappa;
      explicit_kappa[j] += kappa;
      explicit_sum[i] += si;
      explicit_sum[j] += sj;
      ++explicit_cnt[i];
      ++explicit_cnt[j];
      return;
    }
    sum[3 * i + ax] += si;
    sum[3 * j + ax] += sj;
    ++cnt[3 * i + ax];
    ++cnt[3 * j + ax];
  });
  for (std::size_t a = 0; a < n; ++a) {
    const GroupParams& g = m.groups[m.group[a]];
    if (m.random_automaton(a)) {
      if (explicit_sum.empty()) continue;  // (no link at all: a random object of one automaton)
      const double theta = explicit_sum[a] / (2.0 * m.volume[a] + free_face[a] * g.lame_lambda / (2.0 * g.shear_modulus));
      e.elastic += 0.25 * static_cast<double>(m.lattice_lambda * g.lame_lambda) * theta * explicit_sum[a];
      continue;
    }
    if (!explicit_cnt.empty() && explicit_cnt[a] > 0) {
      const int dims = std::min(explicit_cnt[a], 2);
      const double L = explicit_sum[a] * dims / explicit_cnt[a];
      const double theta = L / (1.0 + (3 - dims) * static_cast<double>(g.lame_lambda) / (2.0 * g.shear_modulus));
      e.elastic += 0.5 * g.lame_lambda * theta * L * m.volume[a];
      const auto& E = m.explicit_links;
      const std::uint32_t l0 = E.of[E.first[a]];
      const double c = bending_many_body_constant(g.youngs, g.poisson, E.area[l0] / E.edge[l0], m.volume[a]);
      const double trace = explicit_kappa[a] * dims / explicit_cnt[a];
      e.elastic += 0.5 * c * trace * trace;
      continue;
    }
    double L = 0;
    int free_axes = 0;
    for (int ax = 0; ax < 3; ++ax) {
      if (cnt[3 * a + ax]) L += sum[3 * a + ax] / cnt[3 * a + ax];
      else ++free_axes;
    }
    const double theta = L / (1.0 + free_axes * static_cast<double>(g.lame_lambda) / (2.0 * g.shear_modulus));
    e.elastic += 0.5 * static_cast<double>(m.lattice_stiffness * g.lame_lambda) * theta * L * m.volume[a];
  }
  // Contact springs (as in the backend; the dashpots, which only dissipate, do not enter).
  double contact = 0;
  for (const auto& c : s.contacts) {
    const std::int64_t l = m.random_link_at_start(c.i, c.j);
    const SphereGap gap = sphere_gap(at.x(c.i), at.x(c.j), m.contact_reach(c.i, c.j, l));
    const ContactSprings cs = m.pair_contact_springs(c.i, c.j, l, 0.0f);
    contact += contact_energy(cs, gap.overlap, c.h.ut, c.h.mr, gap.n);
  }
  for (const auto& c : s.ground_contacts) {
    const std::uint32_t a = c.automaton;
    const ContactSprings cs = body_contact_springs(m.ground_contact[m.group[a]], 0.0f, m.radius[a], INFINITY, 1.0f, 1.0f);
    contact += contact_energy(cs, ground_overlap(at.x(a), m.up, m.ground_height, m.radius[a]), c.h.ut, c.h.mr, -m.up);
  }
  for (std::size_t p = 0; p < m.projectiles.size(); ++p) {
    const auto& P = m.projectiles[p];
    const auto& ps = s.projectiles[p];
    e.projectile_kinetic += at.kinetic_p(p);
    const DVec3 xp = at.xp(p);
    if (P.kinematic) {
      e.projectile_work += ps.work;
    } else {
      e.gravity_work += P.mass * dotd(m.gravity, delta(P.position, xp));
    }
    for (const auto& c : ps.contacts) {
      const std::uint32_t a = c.automaton;
      const SphereGap gap = sphere_gap(at.x(a), xp, static_cast<double>(P.radius) + m.radius[a]);
      const ContactSprings cs = body_contact_springs(m.projectile_contact(p, m.group[a]), 0.0f, m.radius[a], P.radius,
                                                     1.0f, 1.0f);
      contact += contact_energy(cs, gap.overlap, c.h.ut, c.h.mr, gap.n);
    }
    if (m.ground) {
      const ContactSprings cs = body_contact_springs(m.projectile_ground_contact(p), 0.0f, P.radius, INFINITY, 1.0f, 1.0f);
      contact += contact_energy(cs, ground_overlap(xp, m.up, m.ground_height, P.radius), ps.ground.ut,
                                ps.ground.mr, -m.up);
    }
  }
  for (const auto& c : s.projectile_contacts) {
    const auto &A = m.projectiles[c.p], &B = m.projectiles[c.q];
    const SphereGap gap = sphere_gap(at.xp(c.p), at.xp(c.q),
                                     static_cast<double>(A.radius) + B.radius);
    const ContactSprings cs = body_contact_springs(m.projectile_pair_contact(c.p, c.q), 0.0f, A.radius, B.radius, 1.0f, 1.0f);
    contact += contact_energy(cs, gap.overlap, c.h.ut, c.h.mr, gap.n);
  }
  e.contact = contact;
  e.elastic += contact;
  for (double w : s.grip_work) e.grip_work += w;
  return e;
}

}  // namespace

}  // namespace mca
