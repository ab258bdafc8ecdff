#pragma once
// The per-element work of a step outside the lattice kernels, written once over plain pointers (MCA_HD):
// the CPU backend calls these functions from its thread pool, the CUDA backend from its kernels (and
// their host emulation). One text, so both compute the same bits.
//
//   explicit_weight  an automaton's many-body weight from its intact explicit links (link order)
//   explicit_gather  the sum of its explicit links' forces, torques and stress, in link order
//   pair_contact     the force of one automaton pair of the contact list
//   ground_contact   the force of the ground on one automaton of the ground list
#include <cstddef>
#include <cstdint>

#include "backend/cpu/lattice_kernels.hpp"
#include "core/math.hpp"
#include "core/model.hpp"
#include "core/model_view.hpp"
#include "core/state.hpp"
#include "physics/contact_law.hpp"
#include "physics/link_law.hpp"

namespace mca {

// Per automaton, its explicit links as StepConstants::ex_ends lists them (kSecondEnd: it is the link's j).
inline constexpr std::uint32_t kSecondEndBit = 1u << 31;

struct ExplicitPassView {
  ModelView m;
  const std::uint32_t* first = nullptr;  // Model::ExplicitLinks::first
  const std::uint32_t* ends = nullptr;   // StepConstants::ex_ends
  const std::uint8_t* intact = nullptr;  // State::intact from the first explicit slot (slot0)
  const float* damage = nullptr;         // State::link_damage from slot0 (null: no softening)
  const float* free_face = nullptr;      // Model::free_face
  const float* volume = nullptr;         // Model::volume
  const float* area_r0 = nullptr;        // StepConstants::ex_area_r0
  const float* eps = nullptr;            // this step's strains (explicit_geometry)
  const float* kappa = nullptr;          // a shell's curvature (explicit_geometry)
  const float* lambda_over_2g = nullptr;  // per group
  const float (*free_factor)[4] = nullptr;
  const float* bend_c = nullptr;  // per automaton
  float lattice_lambda = 1, lattice_bending = 0;
  // The links' results (cpu::ExplicitView::out) and geometry, for the gather.
  const float *out = nullptr, *nx = nullptr, *ny = nullptr, *nz = nullptr, *r0f = nullptr;
};

struct ExplicitWeights {
  float weight, bend_weight;
  bool shell;  // bend_weight is set (a shell's automaton)
};

// The many-body weight of automaton a from its intact explicit links, in link order.
MCA_HD ExplicitWeights explicit_weight(const ExplicitPassView& v, std::uint32_t a) {
  const GroupParams& g = v.m.group_params[v.m.group[a]];
  if (v.m.random_automaton(a)) {
    // The random lattice: theta = sum A r s / (2 V) over the intact links, and the stress lambda theta / 2
    // on each of them (random_many_body). A damaged link's strain in tension counts by its undamaged
    // share, as the lattice's many-body kernel takes it.
    float sum = 0.0f, free = v.free_face[a];
    for (std::uint32_t x = v.first[a]; x < v.first[a + 1]; ++x) {
      const std::uint32_t l = v.ends[x] & ~kSecondEndBit;
      if (!v.intact[l]) {
        free += v.area_r0[l];  // a broken link's face is free
        continue;
      }
      float e = strengthened_strain(g.strengthening, v.eps[l]).s;
      if (v.damage && e > 0.0f) e = (1.0f - v.damage[l]) * e;
      sum += v.area_r0[l] * e;  // (A r0) e: the product is formed once
    }
    return {random_many_body(v.lattice_lambda * g.lame_lambda, v.lambda_over_2g[v.m.group[a]], v.volume[a], sum, free).stress,
            0.0f, false};
  }
  float sum = 0.0f, curvature = 0.0f;
  int count = 0;
  for (std::uint32_t x = v.first[a]; x < v.first[a + 1]; ++x) {
    const std::uint32_t l = v.ends[x] & ~kSecondEndBit;
    if (!v.intact[l]) continue;
    sum += strengthened_strain(g.strengthening, v.eps[l]).s;
    curvature += v.kappa[l];
    ++count;
  }
  return {explicit_many_body(g.lame_lambda, v.free_factor[v.m.group[a]], v.volume[a], sum, count).weight,
          explicit_bending_many_body(v.bend_c[a], curvature, count).weight, true};
}

struct ExternalSum {
  Vec3 f, t;
  Sym3 s;
  bool any;
};

// The forces, torques and stresses of automaton a's intact explicit links, summed in link order (added
// to the automaton once: the contact sums are empty at this point of the step, 0 + x = x, so this is the
// order of adding them one by one). last: the last step of a call.
MCA_HD ExternalSum explicit_gather(const ExplicitPassView& v, std::uint32_t a, bool last) {
  ExternalSum r{};
  // A random-lattice automaton's links have no bending torque at link_bending = 0 (ExplicitView::bends):
  // adding their zeros would change no bit of t (it never holds -0), so they are not read. Its mean stress
  // is read by no criterion (random_link_effort), so its links' stresses are summed only on a call's last
  // step, whose stress and mean stress are the ones kept: the same bits as summing them on every step (for
  // a call that runs all its steps; one stopped by a value not finite keeps that step's partial mean stress).
  const bool random = v.m.random_automaton(a);
  const bool bends = !random || v.lattice_bending > 0.0f, stresses = !random || last;
  using cpu::kTile;
  for (std::uint32_t x = v.first[a]; x < v.first[a + 1]; ++x) {
    const std::uint32_t l = v.ends[x] & ~kSecondEndBit;
    if (!v.intact[l]) continue;
    const float* out = v.out + cpu::tile_index(l, cpu::kExplicitOutRows);
    const Vec3 fl{out[cpu::kOutFx * kTile], out[cpu::kOutFy * kTile], out[cpu::kOutFz * kTile]};
    const bool first = !(v.ends[x] & kSecondEndBit);
    r.f += first ? fl : -fl;
    const Vec3 tl{out[cpu::kOutTx * kTile], out[cpu::kOutTy * kTile], out[cpu::kOutTz * kTile]};
    if (bends) {
      const Vec3 ml{out[cpu::kExplicitOutBx * kTile], out[(cpu::kExplicitOutBx + 1) * kTile],
                    out[(cpu::kExplicitOutBx + 2) * kTile]};
      r.t += tl + (first ? ml : -ml);
    } else {
      r.t += tl;
    }
    if (stresses) r.s += sym_outer(Vec3{v.nx[l], v.ny[l], v.nz[l]}, fl, 0.5f * v.r0f[l]);
    r.any = true;
  }
  return r;
}

// A contact's result for its two bodies: the force on the first (the second takes its opposite), each
// one's torque, the normal and the arms for the stress.
struct ContactOut {
  Vec3 f, ti, tj, n;
  float ri, rj;
  bool on;
};

struct ContactPassView {
  ModelView m;
  const double *px = nullptr, *py = nullptr, *pz = nullptr;
  const double *vx = nullptr, *vy = nullptr, *vz = nullptr, *wx = nullptr, *wy = nullptr, *wz = nullptr;
  // Springs per pair of groups and per group on the ground (null: bodies of their own, from the model).
  const ContactSprings *pair_springs = nullptr, *ground_springs = nullptr;
  const float *zeta_pair = nullptr, *zeta_ground = nullptr;
  const float* zeta_pair_held = nullptr;  // Model::zeta_pair_held (null: no grips)
  const ContactMaterial* ground_contact = nullptr;  // per group
  const float *qw = nullptr, *qx = nullptr, *qy = nullptr, *qz = nullptr;  // orientations (faces: m.face)
  Vec3 up;
  double ground_height = 0;  // (double: the positions' precision)
  float dt = 0;

  MCA_HD DVec3 pos(std::size_t a) const { return {px[a], py[a], pz[a]}; }
  MCA_HD Quat quat(std::size_t a) const { return {qw[a], qx[a], qy[a], qz[a]}; }
  MCA_HD DVec3 vel(std::size_t a) const { return {vx[a], vy[a], vz[a]}; }
  MCA_HD DVec3 ang(std::size_t a) const { return {wx[a], wy[a], wz[a]}; }
};

// The springs of the contact list's pair i, j (l: ModelView::random_link_at_start(i, j)).
MCA_HD ContactSprings pair_springs_of(const ContactPassView& v, std::uint32_t i, std::uint32_t j, std::int64_t l) {
  const ModelView& m = v.m;
  const std::size_t gi = m.group[i], gj = m.group[j];
  return m.held(i) != m.held(j) ? m.held_pair_contact_springs(i, j, l, v.zeta_pair_held)
         : v.pair_springs       ? v.pair_springs[gi * m.groups + gj]
                                : m.pair_contact_springs(i, j, l, v.zeta_pair[gi * m.groups + gj]);
}

// pair_contact of a pair that may touch as faces (its way not kAsSpheres and ModelView::may_face, as the
// caller found): true where it touches as faces or parts as faces (out: its result), false where it touches
// as spheres or not at all. Few pairs come here (those of two bodies, or of one turned): inlined into
// pair_contact, its code slowed every other pair's (wall_3k's contact pass by a fifth).
MCA_HD_CALLED bool face_contact(const ContactPassView& v, ContactPair& cp, std::int64_t l, ContactOut& out) {
  const std::uint32_t i = cp.i, j = cp.j;
  const ModelView& m = v.m;
  FaceGap face = m.faces_by_way(i, j, cp.face, v.pos(i), v.quat(i), v.pos(j), v.quat(j));
  if (face.face && cp.face == ContactPair::kApart && face.overlap > 0.0f && face.weight > 0.0f) {
    // A contact begins as faces only as the pair meets, holding no more than the pair could bring it in
    // a step or two: the springs' energy w d^2 / 2 of its overlap d and weight w, against that of two
    // steps' approach at the contact point along n, and of the weight two steps' motion across n adds
    // (a face sliding onto the next cell, pressed), with a millionth of r_i + r_j for bodies placed
    // touching at rest (what rounding leaves; the weight of a resting one); and no more overlap than a
    // hundredth of r_i + r_j. Where two sides came to face each other within 25 degrees while their cells
    // overlapped already (a piece turning against another, boxes side by side), that overlap was taken
    // at once: two blocks of 2 x 2 x 2 automata spinning apart after a collision gained 3e4 J in a step.
    // Such a pair touches as spheres, or not at all.
    const RelativeMotion rm = relative_motion(v.vel(i), v.ang(i), face.arm_i, v.vel(j), v.ang(j), face.arm_j);
    const float vn = dot(rm.v, face.n), vt = length(rm.v - vn * face.n), reach = m.radius[i] + m.radius[j];
    const float close = fmaxf(-2.0f * vn * v.dt, 0.0f), rest = 1e-6f * reach, d = face.overlap;
    const float slide = 2.0f * vt * v.dt / (2.0f * fminf(m.radius[i], m.radius[j]));
    if (!(d <= 0.01f * reach && face.weight * d * d <= close * close + slide * d * d + rest * rest)) face.face = false;
  }
  if (!face.face) return false;
  // (Apart as faces is apart as spheres: along n the sites lie no farther apart than they are.)
  if (!(face.overlap > 0.0f) || !(face.weight > 0.0f)) {
    cp.h = {};
    cp.face = ContactPair::kApart;
    out = ContactOut{};
    return true;
  }
  const ContactResult r = contact_between(face.n, face.overlap, v.vel(i), v.ang(i), face.arm_i, v.vel(j), v.ang(j),
                                          face.arm_j, weighted(pair_springs_of(v, i, j, l), face.weight), cp.h.ut,
                                          cp.h.mr, v.dt);
  cp.h = {r.o.ut, r.o.mr};
  cp.face = static_cast<std::uint8_t>(ContactPair::kAsFaces + 6 * face.side_i + face.side_j);
  // The normal force acts at the contact point too, off the line of the centres.
  const Vec3 fn = r.o.force_i - r.o.ft;
  out = {r.o.force_i, r.torque_i + cross(face.arm_i, fn), r.torque_j - cross(face.arm_j, fn), face.n,
         m.radius[i], m.radius[j], true};
  return true;
}

// The contact of the pair cp of the contact list, from the positions at the start of the step; its
// history is updated in place (zero once apart), and its way of touching (ContactPair::face).
MCA_HD ContactOut pair_contact(const ContactPassView& v, ContactPair& cp) {
  const std::uint32_t i = cp.i, j = cp.j;
  const ModelView& m = v.m;
  const std::int64_t l = m.random_link_at_start(i, j);  // looked up once: a scan of i's links
  if (cp.face != ContactPair::kAsSpheres && m.may_face(i, j, v.quat(i), v.quat(j), l)) {
    ContactOut out;
    if (face_contact(v, cp, l, out)) return out;
  }
  const double reach = m.contact_reach(i, j, l);
  // The contact point's arms: the radii, or, where the pair reaches further or less far than they do (the
  // random lattice), the radii scaled to meet, so the torques keep the angular momentum.
  const double sum = static_cast<double>(m.radius[i]) + m.radius[j];
  const float ri = reach == sum ? m.radius[i] : static_cast<float>(m.radius[i] * (reach / sum));
  const float rj = reach == sum ? m.radius[j] : static_cast<float>(m.radius[j] * (reach / sum));
  // Apart (|d| >= reach, as sphere_gap would find: sqrt(fl(reach^2)) = reach) without the square root.
  const DVec3 d = ddelta(v.pos(i), v.pos(j));
  const SphereGap gap = dot(d, d) >= reach * reach ? SphereGap{} : sphere_gap(v.pos(i), v.pos(j), reach);
  if (gap.overlap <= 0.0f || !gap.valid) {
    cp.h = {};
    cp.face = ContactPair::kApart;
    return ContactOut{};
  }
  const Vec3 n = gap.n;
  const ContactResult r =
      contact_between(n, gap.overlap, v.vel(i), v.ang(i), ri * n, v.vel(j), v.ang(j), -rj * n, pair_springs_of(v, i, j, l),
                      cp.h.ut, cp.h.mr, v.dt);
  cp.h = {r.o.ut, r.o.mr};
  if (m.face && m.face[i] && m.face[j]) cp.face = ContactPair::kAsSpheres;
  return {r.o.force_i, r.torque_i, r.torque_j, n, ri, rj, true};
}

// The springs of automaton a's contact with a projectile (radius, mass, moment of inertia, kinematic) of
// contact material c: zeta its damping ratio with a's group, zeta_held that with a held automaton of it
// (used where a grip holds a: the ball's own mass moves alone, as a kinematic ball's does against a free
// automaton; against a kinematic ball the automaton's own, held or not).
MCA_HD ContactSprings projectile_contact_springs(const ModelView& m, std::size_t a, const ContactMaterial& c, float zeta,
                                                 float zeta_held, float radius, float mass, float inertia,
                                                 bool kinematic) {
  const bool held = m.held(a) && !kinematic;
  return body_contact_springs(c, held ? zeta_held : zeta, m.radius[a], radius,
                              contact_reduced(m.mass[a], held, mass, kinematic),
                              contact_reduced(m.inertia[a], held, inertia, kinematic));
}

// The ground's contact with the automaton of bc (the automaton is the first body).
MCA_HD ContactOut ground_contact(const ContactPassView& v, BodyContact& bc) {
  const std::uint32_t a = bc.automaton;
  const ModelView& m = v.m;
  const float r = m.radius[a];
  const float overlap = ground_overlap(v.pos(a), v.up, v.ground_height, r);
  if (overlap <= 0.0f) {
    bc.h = {};
    return ContactOut{};
  }
  const Vec3 nrm = -v.up;  // from the automaton to the ground
  const std::size_t g = m.group[a];
  const ContactResult c = contact_between(
      nrm, overlap, v.vel(a), v.ang(a), r * nrm, {}, {}, {},
      v.ground_springs ? v.ground_springs[g]
                       : body_contact_springs(v.ground_contact[g], v.zeta_ground[g], r, INFINITY, m.mass[a], m.inertia[a]),
      bc.h.ut, bc.h.mr, v.dt);
  bc.h = {c.o.ut, c.o.mr};
  return {c.o.force_i, c.torque_i, {}, nrm, r, 0.0f, true};
}

}  // namespace mca
