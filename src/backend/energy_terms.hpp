#pragma once
// The energies' terms one element at a time (an automaton's motion and work, a link, an automaton's
// many-body term, a contact), over plain pointers: compute_energies (cpu/energy.cpp) sums them serially
// from a State; Engine's check of the energy takes them per element and sums them by a fixed tree (below),
// check_energies on the CPU and the CUDA backend on the device, with the same bits. What the terms are:
// energy.cpp.
#include <cstddef>
#include <cstdint>

#include "core/math.hpp"
#include "core/model.hpp"
#include "core/model_view.hpp"
#include "core/state.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca {

MCA_HD double sq(Vec3 v) {
  return static_cast<double>(v.x) * v.x + static_cast<double>(v.y) * v.y + static_cast<double>(v.z) * v.z;
}
MCA_HD double sq(DVec3 v) { return dot(v, v); }
MCA_HD double dotd(Vec3 a, Vec3 b) {
  return static_cast<double>(a.x) * b.x + static_cast<double>(a.y) * b.y + static_cast<double>(a.z) * b.z;
}

// Vectors stored as components k * stride apart: a State's vectors (stride 3) or the device's arrays of
// one component each (stride 1).
template <class T>
struct Components {
  const T *x = nullptr, *y = nullptr, *z = nullptr;
  std::size_t stride = 1;
  // (An empty vector's data() may be null: no member of it is named then.)
  static Components of(const Vec3T<T>* v) { return v ? Components{&v->x, &v->y, &v->z, 3} : Components{}; }
  MCA_HD Vec3T<T> operator[](std::size_t k) const { return {x[k * stride], y[k * stride], z[k * stride]}; }
};

struct AutomatonEnergy {
  double kinetic = 0, gravity_work = 0, load_work = 0;
};
// What a link holds, and what it adds to its ends' many-body sums.
struct LinkEnergy {
  enum Kind : std::uint8_t { none, lattice, shell, random, random_broken };
  Kind kind = none;
  double elastic = 0;
  double bending = 0;     // its bending and twisting spring (shell, random), apart: the serial sum adds it second
  double si = 0, sj = 0;  // the ends' strengthened strains (lattice, shell) or A r s (random)
  double kappa = 0;       // a shell's kappa_nn (both ends)
  double face = 0;        // a broken random link's A r toward each end's free face
};
// An automaton's many-body sums over its intact links.
struct ManyBodySums {
  double axis[3] = {0, 0, 0};  // per lattice axis (cnt: count)
  int count[3] = {0, 0, 0};
  double sum = 0, kappa = 0;  // shell (explicit) or random links
  int links = 0;              // shell links
  double face = 0;            // the random lattice's free face (Model::free_face and broken links)
};

struct EnergyView {
  // The model.
  ModelView m;
  const std::uint32_t* neighbour = nullptr;  // per lattice slot
  const double* link_rest = nullptr;         // null: the spacing
  const float* link_inv_rest = nullptr;
  float spacing = 0, lattice_bending = 0;
  const float* volume = nullptr;
  const std::int16_t* grip = nullptr;
  const Vec3* load = nullptr;  // null: none
  const float *k_twist = nullptr, *k_in = nullptr, *k_out = nullptr;  // per explicit link (Model::explicit_bending)
  const float* free_face = nullptr;  // per automaton of the random lattice (Model::free_face)
  Vec3 gravity;
  float dt = 0;
  // The state; sync: measured at the last force evaluation, x - dt v (energy.cpp).
  Components<double> x, v, w;
  const Vec3 *f = nullptr, *t = nullptr;
  const std::uint8_t* intact = nullptr;
  const float* damage = nullptr;  // null: no softening
  Components<float> ut;           // per link slot
  Components<float> moment;       // per explicit link
  // The orientations (for the faces' contacts, m.face; the step's, not turned back with sync: a step turns
  // an automaton by w dt, which moves no gap of a face contact past float rounding at rest).
  const float *qw = nullptr, *qx = nullptr, *qy = nullptr, *qz = nullptr;
  std::size_t q_stride = 1;
  bool sync = false;

  MCA_HD Quat quat(std::size_t a) const {
    return {qw[a * q_stride], qx[a * q_stride], qy[a * q_stride], qz[a * q_stride]};
  }

  MCA_HD std::size_t lattice_slots() const { return 3 * m.n; }
  MCA_HD DVec3 at(std::size_t a) const {
    DVec3 r = x[a];
    if (sync) r += v[a] * (-dt);
    return r;
  }
  // Half the last step's kick of the velocity and of the angular velocity (0 when not synchronised and
  // for held automata, which move at their grip's constant velocity).
  MCA_HD DVec3 hv(std::size_t a) const {
    return sync && grip[a] < 0 ? to_dvec3(f[a] * (0.5f * dt / m.mass[a])) : DVec3{};
  }
  MCA_HD DVec3 hw(std::size_t a) const {
    return sync && grip[a] < 0 ? to_dvec3(t[a] * (0.5f * dt / m.inertia[a])) : DVec3{};
  }

  MCA_HD AutomatonEnergy automaton(std::size_t a) const {
    AutomatonEnergy e;
    const DVec3 h = hv(a), g = hw(a);
    e.kinetic = 0.5 * m.mass[a] * (sq(v[a] - h) - sq(h)) + 0.5 * m.inertia[a] * (sq(w[a] - g) - sq(g));
    const Vec3 dx = delta(m.position0[a], at(a));
    e.gravity_work = m.mass[a] * dotd(gravity, dx);
    if (load) e.load_work = dotd(load[a], dx);
    return e;
  }

  // Link l (a lattice slot, or 3 n + k for explicit link k).
  MCA_HD LinkEnergy link(std::size_t l) const {
    LinkEnergy e;
    const std::size_t n = m.n;
    const bool is_explicit = l >= lattice_slots();
    const std::size_t k = l - lattice_slots();
    const int ax = is_explicit ? -1 : static_cast<int>(l / n);
    if (!is_explicit && neighbour[l] == Model::kNoLink) return e;
    const std::uint32_t i = is_explicit ? m.ei[k] : static_cast<std::uint32_t>(l % n), j = is_explicit ? m.ej[k] : neighbour[l];
    const double r0 = is_explicit ? m.r0[k] : link_rest ? link_rest[l] : spacing;
    const float area = is_explicit ? m.area[k] : spacing * spacing;
    const bool random = ax < 0 && m.random_automaton(i);
    if (!intact[l]) {
      if (random) {
        e.kind = LinkEnergy::random_broken;
        e.face = static_cast<double>(area * static_cast<float>(r0));
      }
      return e;
    }
    const GroupParams &gi = m.group_params[m.group[i]], &gj = m.group_params[m.group[j]];
    const LinkGeometry g = ax >= 0 && link_rest ? link_geometry(at(i), at(j), link_rest[l], link_inv_rest[l])
                           : ax >= 0            ? link_geometry(at(i), at(j), spacing, 1.0f / spacing)
                                                : link_geometry(at(i), at(j), r0, static_cast<float>(1.0 / r0));
    // (A jittered or random lattice's links have its stiffness factor, as the backend's pair constants.)
    const double G = link_shear_modulus(ax >= 0 || random ? m.lattice_stiffness : 1.0f, gi.shear_modulus, gj.shear_modulus);
    const double V = static_cast<double>(area) * r0;
    const double f_mean = 0.5 * (strengthening_factor(gi.strengthening, g.eps) + strengthening_factor(gj.strengthening, g.eps));
    const double kt = kShearFactor * G * area / r0 * f_mean;
    // A damaged link (softening: physics/fracture.hpp) holds the undamaged share of its pair spring's
    // energy in tension and of its shear spring's, and its ends' many-body sums see that share of its
    // strain, as the forces do; the rest was dissipated.
    // (A surface-mode object's links never soften: their damage stays 0.)
    const double keep = damage ? 1.0 - damage[l] : 1.0;
    e.elastic = (g.eps > 0 ? keep : 1.0) * G * V *
                    (strengthening_energy(gi.strengthening, g.eps) + strengthening_energy(gj.strengthening, g.eps)) +
                keep * 0.5 * kt * sq(ut[l]);
    double si = strengthened_strain(gi.strengthening, g.eps).s, sj = strengthened_strain(gj.strengthening, g.eps).s;
    if (g.eps > 0 && damage && (ax >= 0 || random)) {
      const float share = 1.0f - damage[l];  // as the many-body kernel takes it
      si = static_cast<float>(si) * share;
      sj = static_cast<float>(sj) * share;
    }
    if (random) {  // the random lattice's many-body sums: A r s (random_many_body)
      if (lattice_bending > 0.0f) {
        // Its bending and twisting spring (volume_link_bending: the ends' relative rotation, state, split
        // along the link), carried by the undamaged share.
        const Vec3 phi = moment[k];
        const DVec3 nrm = to_dvec3(g.n);
        const double phi_n = dotd(phi, g.n);
        const DVec3 phi_b = to_dvec3(phi) - nrm * phi_n;
        e.bending = keep * 0.5 * (static_cast<double>(k_twist[k]) * phi_n * phi_n + static_cast<double>(k_in[k]) * sq(phi_b));
      }
      e.kind = LinkEnergy::random;
      e.si = static_cast<double>(area * static_cast<float>(r0) * static_cast<float>(si));
      e.sj = static_cast<double>(area * static_cast<float>(r0) * static_cast<float>(sj));
      return e;
    }
    if (ax < 0) {
      // The bending and twisting spring: its moment's components on the pair's frame (link_bending).
      const Vec3 M = moment[k];
      const double mn = M.x, mm = M.y, mb = M.z;
      e.bending = bending_energy(mn, k_twist[k]) + bending_energy(mm, k_in[k]) + bending_energy(mb, k_out[k]);
      e.kind = LinkEnergy::shell;
      e.kappa = k_out[k] > 0 ? mb / (static_cast<double>(k_out[k]) * static_cast<float>(r0)) : 0.0;
      e.si = si;
      e.sj = sj;
      return e;
    }
    e.kind = LinkEnergy::lattice;
    e.si = si;
    e.sj = sj;
    return e;
  }

  // What link l (its energy e) adds to the sums of end a (first: a is its first end); axis -1 for an explicit
  // link, which is never of the lattice's kind.
  MCA_HD static void add(ManyBodySums& s, const LinkEnergy& e, int axis, bool first) {
    const double x = first ? e.si : e.sj;
    switch (e.kind) {
      case LinkEnergy::lattice:
        if (axis < 0) break;
        s.axis[axis] += x;
        ++s.count[axis];
        break;
      case LinkEnergy::shell:
        s.kappa += e.kappa;
        s.sum += x;
        ++s.links;
        break;
      case LinkEnergy::random:
        s.sum += x;
        break;
      case LinkEnergy::random_broken:
        s.face += e.face;
        break;
      case LinkEnergy::none:
        break;
    }
  }

  // Automaton a's sums before its links add to them.
  MCA_HD ManyBodySums sums(std::size_t a) const {
    ManyBodySums s;
    if (free_face) s.face = free_face[a];
    return s;
  }
  // Automaton a's many-body energy from its sums: the strains' part, and a shell's bending part apart (the
  // serial sum adds it second); shell_c: its shell's bending constant (bending_many_body_constant).
  struct ManyBodyEnergy {
    double strain = 0, bending = 0;
  };
  MCA_HD ManyBodyEnergy many_body(std::size_t a, const ManyBodySums& s, double shell_c) const {
    const GroupParams& g = m.group_params[m.group[a]];
    if (m.random_automaton(a)) {
      if (!m.first) return {};  // (no link at all: a random object of one automaton)
      const double theta = s.sum / (2.0 * volume[a] + s.face * g.lame_lambda / (2.0 * g.shear_modulus));
      return {0.25 * static_cast<double>(m.lattice_lambda * g.lame_lambda) * theta * s.sum, 0.0};
    }
    if (s.links > 0) {
      const int dims = s.links < 2 ? s.links : 2;
      const double L = s.sum * dims / s.links;
      const double theta = L / (1.0 + (3 - dims) * static_cast<double>(g.lame_lambda) / (2.0 * g.shear_modulus));
      const double trace = s.kappa * dims / s.links;
      return {0.5 * g.lame_lambda * theta * L * volume[a], 0.5 * shell_c * trace * trace};
    }
    double L = 0;
    int free_axes = 0;
    for (int ax = 0; ax < 3; ++ax) {
      if (s.count[ax]) L += s.axis[ax] / s.count[ax];
      else ++free_axes;
    }
    const double theta = L / (1.0 + free_axes * static_cast<double>(g.lame_lambda) / (2.0 * g.shear_modulus));
    return {0.5 * static_cast<double>(m.lattice_stiffness * g.lame_lambda) * theta * L * volume[a], 0.0};
  }

  // Contact springs (as in the backend; the dashpots, which only dissipate, do not enter).
  MCA_HD double pair_contact(const ContactPair& c) const {
    const std::int64_t l = m.random_link_at_start(c.i, c.j);
    const ContactSprings cs = m.pair_contact_springs(c.i, c.j, l, 0.0f);
    const FaceGap face = c.face >= ContactPair::kAsFaces
                             ? m.contact_faces(c.i, c.j, c.face, at(c.i), quat(c.i), at(c.j), quat(c.j), l)
                             : FaceGap{};
    if (face.face)
      return face.overlap > 0.0f && face.weight > 0.0f
                 ? contact_energy(weighted(cs, face.weight), face.overlap, c.h.ut, c.h.mr, face.n)
                 : 0.0;
    const SphereGap gap = sphere_gap(at(c.i), at(c.j), m.contact_reach(c.i, c.j, l));
    return contact_energy(cs, gap.overlap, c.h.ut, c.h.mr, gap.n);
  }
  // A body of radius r at x on the ground (up, height: the model's).
  MCA_HD static double on_ground(DVec3 x, float r, const ContactMaterial& material, const ContactHistory& h, Vec3 up,
                                 double height) {
    const ContactSprings cs = body_contact_springs(material, 0.0f, r, INFINITY, 1.0f, 1.0f);
    return contact_energy(cs, ground_overlap(x, up, height, r), h.ut, h.mr, -up);
  }
  // ground: the ground's contact material per group.
  MCA_HD double ground_contact(const BodyContact& c, const ContactMaterial* ground, Vec3 up, double height) const {
    const std::uint32_t a = c.automaton;
    return on_ground(at(a), m.radius[a], ground[m.group[a]], c.h, up, height);
  }
  // Automaton a's contact with a projectile of radius R at xp (material: projectile_contact(p, group)).
  MCA_HD double projectile_contact(const BodyContact& c, DVec3 xp, float R, const ContactMaterial& material) const {
    const std::uint32_t a = c.automaton;
    const SphereGap gap = sphere_gap(at(a), xp, static_cast<double>(R) + m.radius[a]);
    const ContactSprings cs = body_contact_springs(material, 0.0f, m.radius[a], R, 1.0f, 1.0f);
    return contact_energy(cs, gap.overlap, c.h.ut, c.h.mr, gap.n);
  }

  // Projectiles: where one is measured, its kinetic energy (the spin's kick is not kept, ProjectileState
  // has no torque: its plain square), and two in contact (material: projectile_pair_contact).
  MCA_HD DVec3 projectile_at(DVec3 position, DVec3 velocity) const {
    DVec3 r = position;
    if (sync) r += velocity * (-dt);
    return r;
  }
  MCA_HD double projectile_kinetic(DVec3 velocity, DVec3 spin, Vec3 force, float mass, float inertia, bool kinematic) const {
    const DVec3 h = !sync || kinematic ? DVec3{} : to_dvec3((force * (1.0f / mass) + gravity) * (0.5f * dt));
    return 0.5 * mass * (sq(velocity - h) - sq(h)) + 0.5 * inertia * sq(spin);
  }
  MCA_HD static double projectile_pair(DVec3 xa, DVec3 xb, float ra, float rb, const ContactMaterial& material,
                                       const ContactHistory& h) {
    const SphereGap gap = sphere_gap(xa, xb, static_cast<double>(ra) + rb);
    const ContactSprings cs = body_contact_springs(material, 0.0f, ra, rb, 1.0f, 1.0f);
    return contact_energy(cs, gap.overlap, h.ut, h.mr, gap.n);
  }
};

// The bending constant of automaton a's shell (bending_many_body_constant), for one with shell links.
double shell_bending_constant(const Model& m, std::size_t a);
// That constant as the energy check takes it (check_energies, and the CUDA backend's per-automaton array):
// for every automaton of a shell, the links it has left or not; 0 for the others.
double shell_check_constant(const Model& m, std::size_t a);

// The fixed tree of the energy check's sums (Backend::energies), the same on every backend: an array of n
// values is cut into chunks of kSumChunk, each summed in order (chunk_sum); the chunks' sums are summed the
// same way, until one chunk is left (on a GPU a thread per chunk: ChunkSumKernel; check_energies on the CPU).
constexpr std::size_t kSumChunk = 256;
MCA_HD std::size_t sum_chunks(std::size_t n) { return (n + kSumChunk - 1) / kSumChunk; }
MCA_HD double chunk_sum(const double* x, std::size_t n, std::size_t chunk) {
  const std::size_t first = chunk * kSumChunk, last = n - first < kSumChunk ? n : first + kSumChunk;
  double s = 0;
  for (std::size_t k = first; k < last; ++k) s += x[k];
  return s;
}

}  // namespace mca
