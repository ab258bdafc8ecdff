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
#include "backend/energy_terms.hpp"

namespace mca {

// The view of a model and a state the terms read (energy_terms.hpp). The positions and velocities
// energies are measured at (sync): the state's own, or, synchronised, those of the last force evaluation,
// x_n = x - dt v. The kinetic energy there is that of the half-step velocities on either side of x_n,
// m v_{n-1/2} . v_{n+1/2} / 2 = m (|v_n|^2 - |h|^2) / 2, with v_n = v_{n+1/2} - h the velocity Verlet one
// and h = dt a_n / 2 half the last step's kick. With it, kinetic + elastic energy is what symplectic Euler
// conserves exactly for a linear law (the difference of two steps' sums cancels term by term), and to the
// law's small nonlinearity otherwise: the |v_n|^2 form alone oscillates by O((omega dt)^2), 2.4-2.95 % for
// an 8^3 block excited in all its modes at C = 0.5, and the naive sum over the stored half-step velocities
// by O(omega dt). Computed per access rather than in a copy of the state (which doubled the peak memory of
// a run at every frame).
namespace {
// The explicit links' bending constants (Model::explicit_bending), as the terms read them.
struct LinkBendingTables {
  std::vector<float> k_twist, k_in, k_out;
  explicit LinkBendingTables(const Model& m) {
    const std::size_t ne = m.explicit_links.size();
    k_twist.resize(ne);
    k_in.resize(ne);
    k_out.resize(ne);
    for (std::size_t k = 0; k < ne; ++k) {
      const LinkBendingConstants bc = m.explicit_bending(k);
      k_twist[k] = bc.k_twist;
      k_in[k] = bc.k_in;
      k_out[k] = bc.k_out;
    }
  }
};
EnergyView energy_view(const Model& m, const State& s, bool sync, const LinkBendingTables& bending) {
  EnergyView v;
  v.m = m.view();
  v.neighbour = m.neighbour.data();
  v.link_rest = m.link_rest.empty() ? nullptr : m.link_rest.data();
  v.link_inv_rest = m.link_inv_rest.empty() ? nullptr : m.link_inv_rest.data();
  v.spacing = m.spacing;
  v.lattice_bending = m.lattice_bending;
  v.volume = m.volume.data();
  v.grip = m.grip.data();
  v.load = m.load.empty() ? nullptr : m.load.data();
  v.k_twist = bending.k_twist.data();
  v.k_in = bending.k_in.data();
  v.k_out = bending.k_out.data();
  v.free_face = m.free_face.empty() ? nullptr : m.free_face.data();
  v.gravity = m.gravity;
  v.dt = m.dt;
  v.x = Components<double>::of(s.x.data());
  v.v = Components<double>::of(s.v.data());
  v.w = Components<double>::of(s.w.data());
  if (!s.q.empty()) {
    v.qw = &s.q.data()->w;
    v.qx = &s.q.data()->x;
    v.qy = &s.q.data()->y;
    v.qz = &s.q.data()->z;
    v.q_stride = sizeof(Quat) / sizeof(float);
  }
  v.f = s.f.data();
  v.t = s.t.data();
  v.intact = s.intact.data();
  v.damage = s.link_damage.empty() ? nullptr : s.link_damage.data();
  v.ut = Components<float>::of(s.link_ut.data());
  v.moment = Components<float>::of(s.link_moment.data());
  v.sync = sync;
  return v;
}
}  // namespace

double shell_bending_constant(const Model& m, std::size_t a) {
  const GroupParams& g = m.groups[m.group[a]];
  const auto& E = m.explicit_links;
  const std::uint32_t l0 = E.of[E.first[a]];
  return bending_many_body_constant(g.youngs, g.poisson, E.area[l0] / E.edge[l0], m.volume[a]);
}

double shell_check_constant(const Model& m, std::size_t a) {
  const auto& E = m.explicit_links;
  return !E.first.empty() && E.first[a + 1] > E.first[a] && !m.random_automaton(a) ? shell_bending_constant(m, a) : 0.0;
}

namespace {

// The projectiles' terms in compute_energies' order (the CUDA backend's SerialEnergyKernel's): for each
// projectile its kinetic energy, then its work (kinematic) or gravity's, its contacts and its ground contact;
// then the projectile pairs. Each handed to the caller's sum of its kind.
struct ProjectileTerms {
  double kinetic = 0, gravity = 0, work = 0, contact = 0;
};
template <class Add>
void for_each_projectile_term(const Model& m, const State& s, const EnergyView& at, Add&& add) {
  for (std::size_t p = 0; p < m.projectiles.size(); ++p) {
    const auto& P = m.projectiles[p];
    const auto& ps = s.projectiles[p];
    add(&ProjectileTerms::kinetic,
        at.projectile_kinetic(ps.velocity, ps.angular_velocity, ps.force, P.mass, P.inertia, P.kinematic));
    const DVec3 xp = at.projectile_at(ps.position, ps.velocity);
    if (P.kinematic) add(&ProjectileTerms::work, ps.work);
    else add(&ProjectileTerms::gravity, P.mass * dotd(m.gravity, delta(P.position, xp)));
    for (const auto& c : ps.contacts)
      add(&ProjectileTerms::contact, at.projectile_contact(c, xp, P.radius, m.projectile_contact(p, m.group[c.automaton])));
    if (m.ground)
      add(&ProjectileTerms::contact,
          EnergyView::on_ground(xp, P.radius, m.projectile_ground_contact(p), ps.ground, m.up, m.ground_height));
  }
  for (const auto& c : s.projectile_contacts) {
    const auto &A = m.projectiles[c.p], &B = m.projectiles[c.q];
    const auto &a = s.projectiles[c.p], &b = s.projectiles[c.q];
    add(&ProjectileTerms::contact,
        EnergyView::projectile_pair(at.projectile_at(a.position, a.velocity), at.projectile_at(b.position, b.velocity),
                                    A.radius, B.radius, m.projectile_pair_contact(c.p, c.q), c.h));
  }
}

Energies energies_of(const Model& m, const State& s, bool sync) {
  const LinkBendingTables bending(m);
  const EnergyView at = energy_view(m, s, sync, bending);
  Energies e;
  const std::size_t n = m.size();
  for (std::size_t a = 0; a < n; ++a) {
    const AutomatonEnergy x = at.automaton(a);
    e.kinetic += x.kinetic;
    e.gravity_work += x.gravity_work;
    if (at.load) e.load_work += x.load_work;
  }
  // Links: the 2G and shear parts per link, in slot order; per automaton their many-body sums (per axis
  // the sum of strengthened strains; explicit links' apart, the shell's many-body terms; the random
  // lattice's A r s and free faces).
  std::vector<ManyBodySums> sums(n);
  for (std::size_t a = 0; a < n; ++a) sums[a] = at.sums(a);
  m.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int ax) {
    const LinkEnergy x = at.link(l);
    e.elastic += x.elastic;
    e.elastic += x.bending;
    EnergyView::add(sums[i], x, ax, true);
    EnergyView::add(sums[j], x, ax, false);
  });
  for (std::size_t a = 0; a < n; ++a) {
    const bool shell = !m.random_automaton(a) && sums[a].links > 0;
    const EnergyView::ManyBodyEnergy x = at.many_body(a, sums[a], shell ? shell_bending_constant(m, a) : 0.0);
    e.elastic += x.strain;
    e.elastic += x.bending;
  }
  // Contact springs (as in the backend; the dashpots, which only dissipate, do not enter).
  double contact = 0;
  for (const auto& c : s.contacts) contact += at.pair_contact(c);
  for (const auto& c : s.ground_contacts) contact += at.ground_contact(c, m.ground_contact.data(), m.up, m.ground_height);
  // (into the running sums: the projectiles' gravity work onto the automata's, their contacts onto the others)
  for_each_projectile_term(m, s, at, [&](double ProjectileTerms::*kind, double v) {
    if (kind == &ProjectileTerms::kinetic) e.projectile_kinetic += v;
    else if (kind == &ProjectileTerms::work) e.projectile_work += v;
    else if (kind == &ProjectileTerms::gravity) e.gravity_work += v;
    else contact += v;
  });
  e.contact = contact;
  e.elastic += contact;
  for (double w : s.grip_work) e.grip_work += w;
  return e;
}

}  // namespace

Energies compute_energies(const Model& m, const State& s) {
  return energies_of(m, s, s.f.size() == m.size() && s.step > 0);
}

Energies compute_energies_at(const Model& m, const State& s) { return energies_of(m, s, false); }

namespace {
// The fixed tree's sum (chunk_sum) of values given one at a time in order, keeping only the chunks' sums.
class TreeSum {
 public:
  void add(double v) {
    s_ += v;
    if (++count_ % kSumChunk == 0) {
      chunks_.push_back(s_);
      s_ = 0;
    }
  }
  // (once: the chunks' sums are summed in place)
  double total() && {
    // The last chunk's sum (0 for none); up to one chunk, 0 + its sum is its sum (a sum from +0 is never -0).
    if (count_ % kSumChunk || count_ == 0) chunks_.push_back(s_);
    std::size_t n = chunks_.size();
    for (; n > kSumChunk; n = sum_chunks(n))
      for (std::size_t c = 0; c < sum_chunks(n); ++c) chunks_[c] = chunk_sum(chunks_.data(), n, c);  // (over a chunk summed before)
    return chunk_sum(chunks_.data(), n, 0);
  }

 private:
  double s_ = 0;
  std::size_t count_ = 0;
  std::vector<double> chunks_;
};
}  // namespace

Energies check_energies(const Model& m, const State& s) {
  const std::size_t n = m.size(), L = m.link_slots();
  const LinkBendingTables bending(m);
  const EnergyView ev = energy_view(m, s, s.f.size() == n && s.step > 0, bending);
  // Each term as the CUDA backend's kernels form it (AutomatonEnergyKernel, LinkEnergyKernel and the others in
  // device_kernels.hpp), taken in element order into the fixed tree, so with the device's bits.
  TreeSum kinetic, gravity, load, links, many_body, pairs, ground;
  std::vector<ManyBodySums> sums(n);
  for (std::size_t a = 0; a < n; ++a) {
    const AutomatonEnergy x = ev.automaton(a);
    kinetic.add(x.kinetic);
    gravity.add(x.gravity_work);
    load.add(x.load_work);
    sums[a] = ev.sums(a);
  }
  // Every slot, a link or not; each link's many-body parts onto its ends, as ManyBodyEnergyKernel gathers them
  // (per end, its lattice links per axis and its explicit links in increasing order).
  for (std::size_t l = 0; l < L; ++l) {
    const LinkEnergy x = ev.link(l);
    links.add(x.elastic + x.bending);
    if (!m.link_exists(l)) continue;
    if (l < 3 * n) {
      EnergyView::add(sums[l % n], x, static_cast<int>(l / n), true);
      EnergyView::add(sums[m.neighbour[l]], x, static_cast<int>(l / n), false);
    } else {
      EnergyView::add(sums[m.explicit_links.i[l - 3 * n]], x, -1, true);
      EnergyView::add(sums[m.explicit_links.j[l - 3 * n]], x, -1, false);
    }
  }
  for (std::size_t a = 0; a < n; ++a) {
    const EnergyView::ManyBodyEnergy x = ev.many_body(a, sums[a], shell_check_constant(m, a));
    many_body.add(x.strain + x.bending);
  }
  for (const auto& c : s.contacts) pairs.add(ev.pair_contact(c));
  for (const auto& c : s.ground_contacts) ground.add(ev.ground_contact(c, m.ground_contact.data(), m.up, m.ground_height));
  // The projectiles and grips serially, each kind on its own (SerialEnergyKernel's one thread).
  ProjectileTerms p;
  for_each_projectile_term(m, s, ev, [&](double ProjectileTerms::*kind, double v) { p.*kind += v; });
  double grip = 0;
  for (double w : s.grip_work) grip += w;
  // Put together as DeviceBackend::device_energies does.
  Energies e;
  e.kinetic = std::move(kinetic).total();
  e.contact = std::move(pairs).total() + std::move(ground).total() + p.contact;
  e.elastic = std::move(links).total() + std::move(many_body).total() + e.contact;
  e.projectile_kinetic = p.kinetic;
  e.gravity_work = std::move(gravity).total() + p.gravity;
  e.grip_work = grip;
  e.load_work = m.load.empty() ? 0.0 : std::move(load).total();
  e.projectile_work = p.work;
  return e;
}

}  // namespace mca
