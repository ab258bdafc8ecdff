#include "sim/state_check.hpp"

#include <cmath>
#include <cstring>
#include <fmt/format.h>
#include <type_traits>
#include <vector>

#include "mca/error.hpp"
#include "core/fnv.hpp"

namespace mca {

namespace {

// The model's numbers, value by value (sim/fnv.hpp).
struct Fnv : Fnv1a {
  template <class T>
    requires std::is_arithmetic_v<T>
  void add(T v) {
    bytes(&v, sizeof v);
  }
  void add(const Vec3& v) {
    add(v.x);
    add(v.y);
    add(v.z);
  }
  void add(const DVec3& v) {
    add(v.x);
    add(v.y);
    add(v.z);
  }
  void add(const Strengthening& s) {
    add(s.law);
    add(s.alpha);
    add(s.cap);
  }
  void add(const ContactMaterial& c) {
    for (float v : {c.youngs, c.shear, c.restitution, c.zeta, c.friction, c.rolling, c.twisting}) add(v);
  }
  void add(const std::string& s) {
    add<std::uint64_t>(s.size());
    bytes(s.data(), s.size());
  }
  void add(const GroupParams& g) {
    for (float v : {g.youngs, g.poisson, g.density, g.shear_modulus, g.lame_lambda, g.tensile_strength,
                    g.compressive_strength, g.fracture_strain, g.friction, g.restitution, g.rolling_friction,
                    g.twisting_friction, g.damping_time})
      add(v);
    add(g.strengthening);
  }
  void add(const ProjectileParams& p) {
    add(p.name);
    add(p.radius);
    add(p.mass);
    add(p.inertia);
    add(p.group);
    add<std::uint8_t>(p.kinematic);
    add(p.position);
    add(p.velocity);
    add(p.angular_velocity);
    add(p.zeta_automata);
    add(p.zeta_ground);
    if (!p.zeta_held.empty()) add(p.zeta_held);  // (with grips only: the other scenes' checkpoints resume)
  }
  // The count first, so that arrays of different lengths cannot run into each other.
  template <class T>
  void add(const std::vector<T>& v) {
    add<std::uint64_t>(v.size());
    if constexpr (std::is_arithmetic_v<T>) {
      bytes(v.data(), v.size() * sizeof(T));
    } else {
      for (const auto& e : v) add(e);
    }
  }
};

bool finite(float v) { return std::isfinite(v); }
bool finite(double v) { return std::isfinite(v); }
bool finite(const Vec3& v) { return finite(v.x) && finite(v.y) && finite(v.z); }
bool finite(const DVec3& v) { return finite(v.x) && finite(v.y) && finite(v.z); }
bool finite(const ContactHistory& h) { return finite(h.ut) && finite(h.mr); }
bool finite(const Quat& q) { return finite(q.w) && finite(q.x) && finite(q.y) && finite(q.z); }
bool finite(const Sym3& s) {
  return finite(s.xx) && finite(s.yy) && finite(s.zz) && finite(s.xy) && finite(s.yz) && finite(s.zx);
}

// (A float, so that it prints as short as the numbers it is made of.)
float length(const Quat& q) {
  const double w = q.w, x = q.x, y = q.y, z = q.z;
  return static_cast<float>(std::sqrt(w * w + x * x + y * y + z * z));
}
// The integration's renormalisation (one Newton step, core/math.hpp) never lengthens an orientation past 1
// (but for float rounding: 1e-3 is allowed), and keeps a turning one short of it: one that turns by w dt a
// step settles at sqrt((3 - 2 / sqrt(1 + e)) / (1 + e)), e = (w dt / 2)^2 (a ball of 1 cm at 8.7e5 rad/s,
// 0.46 rad a step: 0.99873; a ball turns in parts of 0.5 rad a step at most, core/math.hpp).
bool an_orientation(const Quat& q) { return length(q) > 0.0f && length(q) <= 1.001f; }

class StateChecker {
 public:
  StateChecker(const Model& m, const std::string& source) : m_(m), source_(source) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw Error(fmt::format("{}: the saved state does not fit the model of its scene: {}; the file is damaged or "
                            "was edited: use an earlier checkpoint (remove this one) or start the run again",
                            source_, what));
  }

  template <class T>
  void size(const char* name, const std::vector<T>& v, std::size_t expected, const char* what) const {
    if (v.size() != expected)
      fail(fmt::format("{} has {} entries, the model has {} {}", name, v.size(), expected, what));
  }

  template <class T>
  void all_finite(const char* name, const std::vector<T>& v) const {
    for (std::size_t k = 0; k < v.size(); ++k)
      if (!finite(v[k])) fail(fmt::format("{}[{}] is not a finite number", name, k));
  }

 private:
  const Model& m_;
  const std::string& source_;
};

}  // namespace

void check_run_clock(const Model& m, const State& s, const std::string& source) {
  // A resumed run adds its steps to its checkpoint's time, which its first session made as step x dt.
  const double clock = static_cast<double>(s.step) * m.dt;
  if (!(std::fabs(s.time - clock) <= 1e-6 * (clock + m.dt)))
    StateChecker(m, source)
        .fail(fmt::format("the time is {} s at step {}, where steps of {} s make {} s", s.time, s.step, m.dt, clock));
}

std::uint64_t model_fingerprint(const Model& m) {
  Fnv f;
  // Automata.
  f.add(m.position0);
  f.add(m.velocity0);
  f.add(m.mass);
  f.add(m.radius);
  f.add(m.inertia);
  f.add(m.volume);
  f.add(m.group);
  f.add(m.strength_class);
  f.add(m.class_factor);
  f.add(m.object);
  f.add(m.grip);
  f.add(m.load);
  // Links.
  f.add(m.neighbour);
  f.add(m.neighbour_below);
  if (m.explicit_links.size() > 0) {  // (a lattice model's fingerprint is that of earlier versions)
    f.add(m.explicit_links.i);
    f.add(m.explicit_links.j);
    f.add(m.explicit_links.r0);
    f.add(m.explicit_links.area);
  }
  if (!m.link_strength.empty()) f.add(m.link_strength);
  if (!m.link_rest.empty()) {
    f.add(m.link_rest);
    f.add(m.lattice_stiffness);
  }
  if (!m.object_random.empty()) {  // the random lattice
    f.add(m.object_random);
    f.add(m.boxed);
    f.add(m.free_face);
    f.add(m.lattice_stiffness);
    f.add(m.lattice_lambda);
    f.add(m.lattice_strength);
    f.add(m.lattice_bending);
    // The links' bending springs as round sections on the ends' relative rotation, kept as state (since
    // 2026-12-03, 4f87856; 2: taken from the orientations, afc609c, with that state unused; the square
    // sections before, no tag, kept their moments there).
    if (m.lattice_bending > 0.0f) f.add<std::uint8_t>(3);
  }
  // The faces that touch as faces (since 2026-12-07; before, every pair touched as spheres).
  if (!m.face.empty()) f.add(m.face);
  // Scene-level numbers. Names are left out: they label outputs and do not shape the state.
  f.add(m.groups);
  f.add(m.projectiles);
  f.add(m.grip_velocity);
  f.add<std::uint8_t>(m.ground);
  // The ground's height was a float: a height a float holds hashes as it did (earlier checkpoints resume),
  // another also as the double it now is.
  const float ground_height = static_cast<float>(m.ground_height);
  f.add(ground_height);
  if (static_cast<double>(ground_height) != m.ground_height) f.add(m.ground_height);
  f.add(m.contact);
  f.add(m.ground_contact);
  f.add(m.zeta_pair);
  f.add(m.zeta_ground);
  f.add(m.zeta_projectiles);
  if (!m.zeta_pair_held.empty()) f.add(m.zeta_pair_held);  // (with grips only, as above)
  f.add(m.gravity);
  f.add(m.up);
  f.add(m.spacing);
  f.add(m.dt);
  f.add(m.skin);
  f.add(m.link_damping);
  f.add(m.local_damping);
  f.add(m.stress_coefficient);
  return f.h;
}

void check_state(const Model& m, const State& s, const std::string& source) {
  const StateChecker c(m, source);
  const std::size_t n = m.size(), links = m.link_slots(), grips = m.grip_velocity.size();

  if (s.step < 0) c.fail(fmt::format("the step counter is {}", s.step));
  if (!std::isfinite(s.time) || s.time < 0) c.fail(fmt::format("the time is {}", s.time));

  // Per automaton.
  c.size("x", s.x, n, "automata");
  c.size("v", s.v, n, "automata");
  c.size("w", s.w, n, "automata");
  c.size("q", s.q, n, "automata");
  c.size("s", s.s, n, "automata");
  c.size("mean_stress", s.mean_stress, n, "automata");
  c.size("f", s.f, n, "automata");
  c.size("t", s.t, n, "automata");
  // Empty means "rebuild the contact list on upload".
  if (!s.x_at_rebuild.empty()) c.size("x_at_rebuild", s.x_at_rebuild, n, "automata");
  c.all_finite("x", s.x);
  c.all_finite("v", s.v);
  c.all_finite("w", s.w);
  c.all_finite("q", s.q);
  c.all_finite("s", s.s);
  c.all_finite("mean_stress", s.mean_stress);
  c.all_finite("f", s.f);
  c.all_finite("t", s.t);
  c.all_finite("x_at_rebuild", s.x_at_rebuild);
  for (std::size_t k = 0; k < n; ++k)
    if (!an_orientation(s.q[k]))
      c.fail(fmt::format("q[{}] has length {}, and an orientation's is above 0 and at most 1 (1.001 with rounding)",
                         k, length(s.q[k])));

  // Per link. Links only ever break (all are intact at the start), and each break is recorded once, so
  // the broken links, the break records and the counters by criterion are three views of one set.
  c.size("intact", s.intact, links, "links");
  c.size("link_ut", s.link_ut, links, "links");
  c.all_finite("link_ut", s.link_ut);
  c.size("link_moment", s.link_moment, m.explicit_links.size(), "explicit links");
  c.all_finite("link_moment", s.link_moment);
  c.size("link_damage", s.link_damage, m.softening() ? links : 0, m.softening() ? "links" : "softening links");
  c.all_finite("link_damage", s.link_damage);
  for (std::size_t l = 0; l < s.link_damage.size(); ++l)
    if (!(s.link_damage[l] >= 0 && s.link_damage[l] <= 1))
      c.fail(fmt::format("link_damage[{}] is {} (0 to 1)", l, s.link_damage[l]));
  std::int64_t broken = 0;
  for (std::size_t l = 0; l < links; ++l) {
    if (s.intact[l] > 1) c.fail(fmt::format("intact[{}] is {} (0 or 1)", l, s.intact[l]));
    if (s.intact[l] && !m.link_exists(l)) c.fail(fmt::format("intact[{}] is set for a slot without a link", l));
    broken += s.intact[l] == 0 && m.link_exists(l);
  }
  std::vector<std::uint8_t> recorded(links, 0);
  std::int64_t by[2] = {0, 0};
  for (std::size_t k = 0; k < s.breaks.size(); ++k) {
    const BreakRecord& b = s.breaks[k];
    const auto criterion = static_cast<unsigned>(b.criterion);
    if (b.link >= links || !m.link_exists(b.link))
      c.fail(fmt::format("break record {} names link slot {} of {}, which holds no link", k, b.link, links));
    if (criterion > 1) c.fail(fmt::format("break record {} has criterion {} (0 or 1)", k, criterion));
    if (b.step < 0 || b.step > s.step)
      c.fail(fmt::format("break record {} is at step {}, outside 0..{}", k, b.step, s.step));
    if (s.intact[b.link]) c.fail(fmt::format("break record {} names link {}, which is intact", k, b.link));
    if (recorded[b.link]) c.fail(fmt::format("link {} has two break records", b.link));
    recorded[b.link] = 1;
    ++by[criterion];
  }
  for (int k = 0; k < 2; ++k)
    if (s.broken_by[k] != by[k])
      c.fail(fmt::format("{} links are counted as broken by the {} criterion, {} break records say so",
                         s.broken_by[k], k == 0 ? "displacement" : "stress", by[k]));
  if (by[0] + by[1] != broken)
    c.fail(fmt::format("{} links are broken but there are {} break records", broken, by[0] + by[1]));

  // Contacts: unlinked pairs i < j, sorted by (i, j) without repeats (the backend merges lists by that order).
  for (std::size_t k = 0; k < s.contacts.size(); ++k) {
    const ContactPair& p = s.contacts[k];
    if (!(p.i < p.j && p.j < n))
      c.fail(fmt::format("contact {} is the pair ({}, {}): needs i < j < {} automata", k, p.i, p.j, n));
    if (k > 0) {
      const ContactPair& q = s.contacts[k - 1];
      if (!(q.i < p.i || (q.i == p.i && q.j < p.j)))
        c.fail(fmt::format("contacts {} ({}, {}) and {} ({}, {}) are not in order", k - 1, q.i, q.j, k, p.i, p.j));
    }
    if (!finite(p.h)) c.fail(fmt::format("contact {} has a non-finite spring history", k));
    // Its way of touching: as faces only by free sides of the two cells (Model::face), and a way at all
    // only between two automata with free sides.
    if (p.face != ContactPair::kApart && p.i < p.j && p.j < n) {
      const bool sides = !m.face.empty() && m.face[p.i] && m.face[p.j];
      const int way = p.face - ContactPair::kAsFaces;
      if (!sides || (p.face >= ContactPair::kAsFaces &&
                     (way >= 36 || !(m.face[p.i] & (1u << (way / 6))) || !(m.face[p.j] & (1u << (way % 6))))))
        c.fail(fmt::format("contact {} ({}, {}) touches in way {}, which their cells' free sides do not have", k, p.i,
                           p.j, p.face));
    }
  }
  // The ground's: automata sorted without repeats, and none where there is no ground (the ground pass runs
  // over the list as it is: an entry would be a ground nobody set).
  if (!m.ground && !s.ground_contacts.empty())
    c.fail(fmt::format("the state has ground contacts ({}), and the scene has no ground", s.ground_contacts.size()));
  for (std::size_t k = 0; k < s.ground_contacts.size(); ++k) {
    const BodyContact& b = s.ground_contacts[k];
    if (b.automaton >= n) c.fail(fmt::format("ground contact {} names automaton {} of {}", k, b.automaton, n));
    if (k > 0 && s.ground_contacts[k - 1].automaton >= b.automaton)
      c.fail(fmt::format("the ground contacts are not sorted by automaton (at {})", k));
    if (!finite(b.h)) c.fail(fmt::format("ground contact {} has a non-finite spring history", k));
  }

  // Projectiles.
  if (s.projectiles.size() != m.projectiles.size())
    c.fail(fmt::format("{} projectiles are saved, the scene has {}", s.projectiles.size(), m.projectiles.size()));
  for (std::size_t p = 0; p < s.projectiles.size(); ++p) {
    const ProjectileState& ps = s.projectiles[p];
    if (!finite(ps.position) || !finite(ps.velocity) || !finite(ps.angular_velocity) || !finite(ps.orientation) ||
        !finite(ps.force))
      c.fail(fmt::format("projectile {} has a non-finite position, velocity, orientation or force", p));
    if (!an_orientation(ps.orientation))
      c.fail(fmt::format("projectile {}'s orientation has length {}, and an orientation's is above 0 and at most 1 "
                         "(1.001 with rounding)",
                         p, length(ps.orientation)));
    for (std::size_t k = 0; k < ps.contacts.size(); ++k) {
      const BodyContact& b = ps.contacts[k];
      if (b.automaton >= n)
        c.fail(fmt::format("contact {} of projectile {} names automaton {} of {}", k, p, b.automaton, n));
      if (k > 0 && ps.contacts[k - 1].automaton >= b.automaton)
        c.fail(fmt::format("the contacts of projectile {} are not sorted by automaton (at {})", p, k));
      if (!finite(b.h)) c.fail(fmt::format("contact {} of projectile {} is not finite", k, p));
    }
    if (!finite(ps.ground) || !std::isfinite(ps.work))
      c.fail(fmt::format("projectile {} has a non-finite ground contact or work", p));
    const ContactHistory none{};
    if (!m.ground && std::memcmp(&ps.ground, &none, sizeof none) != 0)
      c.fail(fmt::format("projectile {} has a ground contact's history, and the scene has no ground", p));
  }
  const std::size_t np = m.projectiles.size();
  for (std::size_t k = 0; k < s.projectile_contacts.size(); ++k) {
    const ProjectilePair& pp = s.projectile_contacts[k];
    if (!(pp.p < pp.q && pp.q < np))
      c.fail(fmt::format("projectile contact {} is the pair ({}, {}): needs p < q < {} projectiles", k, pp.p, pp.q, np));
    if (k > 0) {
      const ProjectilePair& o = s.projectile_contacts[k - 1];
      if (!(o.p < pp.p || (o.p == pp.p && o.q < pp.q)))
        c.fail(fmt::format("projectile contacts {} and {} are not in order", k - 1, k));
    }
    if (!finite(pp.h)) c.fail(fmt::format("projectile contact {} has a non-finite spring history", k));
  }
  if (!std::isfinite(s.initial_energy)) c.fail("the starting energy is not a finite number");

  // Grips.
  c.size("grip_work", s.grip_work, grips, "grips");
  c.size("grip_force", s.grip_force, grips, "grips");
  c.all_finite("grip_work", s.grip_work);
  c.all_finite("grip_force", s.grip_force);
}

}  // namespace mca
