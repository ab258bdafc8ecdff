// Energies of a state, in double, serially: the measuring stick of the energy test and of stats.csv.
// The elastic energy is the potential the link law derives from (link_law.hpp):
//   W = sum_links [G_ij eps^2 V + k_t |u_t|^2 / 2] + sum_i [lambda_i theta_i^2 / 2 + G_i sum_free e_f^2] V
//       + contact springs.
#include <cmath>

#include "backend/backend.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca {

namespace {
double sq(Vec3 v) { return static_cast<double>(v.x) * v.x + static_cast<double>(v.y) * v.y + static_cast<double>(v.z) * v.z; }
}  // namespace

Energies compute_energies(const Model& m, const State& s_end) {
  // Measure at the positions the last step's forces were computed at, x_n = x - dt v, with the
  // velocities in step with them (velocity Verlet's v_n = v_{n+1/2} - dt/2 a_n). Symplectic Euler
  // conserves this energy to O(dt^2); the naive sum over the stored half-step velocities is off by
  // O(omega dt), several per cent for a lattice excited in all its modes.
  State s;
  const State* sp = &s_end;
  const bool sync = s_end.f.size() == m.size() && s_end.step > 0;
  if (sync) {
    s = s_end;
    const float h = 0.5f * m.dt;
    for (std::size_t a = 0; a < m.size(); ++a) {
      s.x[a] += s_end.v[a] * (-m.dt);
      if (m.grip[a] >= 0) continue;
      s.v[a] = s_end.v[a] - s_end.f[a] * (h / m.mass[a]);
      s.w[a] = s_end.w[a] - s_end.t[a] * (h / m.inertia[a]);
    }
    for (std::size_t p = 0; p < m.projectiles.size(); ++p) {
      auto& ps = s.projectiles[p];
      ps.position += s_end.projectiles[p].velocity * (-m.dt);
      if (!m.projectiles[p].kinematic)
        ps.velocity = s_end.projectiles[p].velocity -
                      (s_end.projectiles[p].force * (1.0f / m.projectiles[p].mass) + m.gravity) * h;
    }
    sp = &s;
  }
  return compute_energies_at(m, *sp);
}

Energies compute_energies_at(const Model& m, const State& s) {
  Energies e;
  const std::size_t n = m.size();
  for (std::size_t a = 0; a < n; ++a) {
    e.kinetic += 0.5 * m.mass[a] * sq(s.v[a]) + 0.5 * m.inertia[a] * sq(s.w[a]);
    const Vec3 dx = delta(to_dvec3(m.position0[a]), s.x[a]);
    e.gravity_work += m.mass[a] * (static_cast<double>(m.gravity.x) * dx.x + static_cast<double>(m.gravity.y) * dx.y +
                                   static_cast<double>(m.gravity.z) * dx.z);
  }
  // Links: shear and 2G part per link; volumetric strain per automaton for the many-body part.
  std::vector<double> sum(3 * n, 0.0);
  std::vector<int> cnt(3 * n, 0);
  for (std::size_t l = 0; l < m.link_count(); ++l) {
    if (!s.intact[l]) continue;
    const std::uint32_t i = m.link_i[l], j = m.link_j[l];
    const LinkGeometry g = link_geometry(s.x[i], s.x[j], m.link_r0[l], 1.0f / m.link_r0[l]);
    const double G = harmonic(m.groups[m.group[i]].shear_modulus, m.groups[m.group[j]].shear_modulus);
    const double V = static_cast<double>(m.link_area[l]) * m.link_r0[l];
    const double kt = kShearFactor * G * m.link_area[l] / m.link_r0[l];
    e.elastic += G * g.eps * g.eps * V + 0.5 * kt * sq(s.link_ut[l]);
    const int ax = m.link_axis[l];
    sum[3 * i + ax] += g.eps;
    sum[3 * j + ax] += g.eps;
    ++cnt[3 * i + ax];
    ++cnt[3 * j + ax];
  }
  // Contacts between automata (springs as in the backend).
  for (const auto& c : s.contacts) {
    const double dist = std::sqrt(sq(delta(s.x[c.i], s.x[c.j])));
    const double overlap = m.radius[c.i] + m.radius[c.j] - dist;
    if (overlap <= 0) continue;
    const PairContact pc = contact_params(m.groups[m.group[c.i]], m.groups[m.group[c.j]],
                                          m.radius[c.i] + m.radius[c.j], 0.0f);
    const double kn = pc.kn, kt = pc.kt;
    e.elastic += 0.5 * kn * overlap * overlap + 0.5 * kt * sq(c.ut);
  }
  for (std::size_t p = 0; p < m.projectiles.size(); ++p) {
    const auto& P = m.projectiles[p];
    const auto& ps = s.projectiles[p];
    e.projectile_kinetic += 0.5 * P.mass * sq(ps.velocity) + 0.5 * P.inertia * sq(ps.angular_velocity);
    if (!P.kinematic) {
      const Vec3 dx = delta(to_dvec3(P.position), ps.position);
      e.gravity_work += P.mass * (static_cast<double>(m.gravity.x) * dx.x + static_cast<double>(m.gravity.y) * dx.y +
                                  static_cast<double>(m.gravity.z) * dx.z);
    }
  }
  for (double w : s.grip_work) e.grip_work += w;
  return e;
}

}  // namespace mca
