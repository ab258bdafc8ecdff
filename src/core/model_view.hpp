#pragma once
// The parts of a Model that a step's per-pair rules read (which link joined two automata at the start,
// how far apart they touch, the springs of their contact), over plain pointers: the same functions run on
// the host (Model's own methods call them) and on a CUDA thread over device copies of the arrays.
#include <cmath>
#include <cstddef>
#include <cstdint>

#include "core/math.hpp"
#include "core/state.hpp"
#include "physics/contact_law.hpp"

namespace mca {

// Two automata with free sides that face each other (ModelView::face_pair, face_start).
struct FaceGap {
  bool face;           // they touch as faces (where overlap > 0 and weight > 0); false: as spheres
  int side_i, side_j;  // the sides (Model::face's bits)
  Vec3 n;              // unit normal from i to j
  float overlap;       // r_i + r_j less the sites' distance along n (> 0: touching)
  float weight;        // the share of the smaller cell's square the other's covers in the sides' plane (0 to 1)
  Vec3 arm_i, arm_j;   // from each centre to the contact point
};
// The widest angle between one face's normal and the other's opposite at which two faces touch as faces.
inline constexpr float kFaceCos = 0.906307787f;  // cos 25 degrees
// Two orientations within 5 degrees of each other: |q_i . q_j| above cos(2.5 degrees) (ModelView::may_face).
inline constexpr float kSameTurn = 0.999048222f;
// How far two sites of touching faces lie apart at most, in r_i + r_j: sqrt(3) (ModelView::face_candidate).
inline constexpr float kFaceReach = 1.7320509f;

// How far, in cells of the contact search's grid (2 r_max + skin), lie the sites of faces that may touch a
// site's face (ModelView::face_candidate), with a thousandth to spare for rounding; and how many cells
// each way that takes. (The cells beyond the reach, such as the corners of the 5 x 5 x 5 around a site's
// own, hold none: the search skips them, UniformGrid::for_each_near_above.)
MCA_HD double face_search_reach(float r_max, float skin) {
  return 1.001 * (static_cast<double>(kFaceReach) * 2.0 * r_max + skin) / (2.0 * static_cast<double>(r_max) + skin);
}
MCA_HD int face_search_cells(float r_max, float skin) { return static_cast<int>(std::ceil(face_search_reach(r_max, skin))); }

struct ModelView {
  std::size_t n = 0;
  std::size_t groups = 0;
  const std::uint8_t* group = nullptr;
  const std::int32_t* object = nullptr;
  const std::uint8_t* object_random = nullptr;  // null: no object is of the random lattice
  const float *radius = nullptr, *mass = nullptr, *inertia = nullptr;
  const DVec3* position0 = nullptr;
  // Explicit links (Model::ExplicitLinks); first null when there are none.
  const std::uint32_t *first = nullptr, *of = nullptr, *ei = nullptr, *ej = nullptr;
  const double* r0 = nullptr;
  const float* area = nullptr;
  const GroupParams* group_params = nullptr;
  const ContactMaterial* contact = nullptr;  // contact[a * groups + b]
  const std::int16_t* grip = nullptr;        // Model::grip; null: no grips
  float lattice_stiffness = 1, lattice_lambda = 1;
  const std::uint8_t* face = nullptr;  // Model::face; null: no automaton has a free side
  const Vec3* axes = nullptr;          // Model::object_axes, three per object

  MCA_HD bool random_automaton(std::size_t a) const { return object_random && object_random[object[a]] != 0; }
  // Held by a grip: it moves with the grip and does not turn, whatever acts on it.
  MCA_HD bool held(std::size_t a) const { return grip && grip[a] >= 0; }
  // The explicit link that joined automata i and j at the start, or -1.
  MCA_HD std::int64_t link_at_start(std::size_t i, std::size_t j) const {
    if (!first) return -1;
    for (std::uint32_t k = first[i]; k < first[i + 1]; ++k) {
      const std::uint32_t l = of[k];
      if (ei[l] == j || ej[l] == j) return l;
    }
    return -1;
  }
  MCA_HD std::int64_t random_link_at_start(std::size_t i, std::size_t j) const {
    return random_automaton(i) && random_automaton(j) ? link_at_start(i, j) : -1;
  }
  MCA_HD double contact_reach(std::size_t i, std::size_t j, std::int64_t l) const {
    const double r = static_cast<double>(radius[i]) + radius[j];
    if (!random_automaton(i) || !random_automaton(j)) return r;
    if (l >= 0) return r0[l];  // (its rest length: this distance, formed the same way)
    const DVec3 d = ddelta(position0[i], position0[j]);
    const double dist = sqrt(dot(d, d));
    return dist < r ? dist : r;  // std::min(r, dist)
  }
  // The outward normal at the start of side k (Model::face's bit k) of automaton a's cell, and an axis
  // along that side.
  MCA_HD Vec3 side_normal0(std::size_t a, int k) const {
    const Vec3 e = axes[3 * static_cast<std::size_t>(object[a]) + static_cast<std::size_t>(k >> 1)];
    return (k & 1) ? -e : e;
  }
  MCA_HD Vec3 side_tangent0(std::size_t a, int k) const {
    const int axis = k >> 1;
    return axes[3 * static_cast<std::size_t>(object[a]) + static_cast<std::size_t>(axis == 2 ? 0 : axis + 1)];
  }
  // The free sides of automaton a's cell (Model::face), turned by q: their normals into n, their bits
  // into k; returns how many.
  MCA_HD int free_sides(std::size_t a, const Quat& q, Vec3* n, int* k) const {
    int count = 0;
    for (int side = 0; side < 6; ++side)
      if (face[a] & (1u << side)) {
        n[count] = rotated(q, side_normal0(a, side));
        k[count++] = side;
      }
    return count;
  }
  // Automata i and j at xi, xj, turned by qi, qj, as faces: side si of i's cell (Model::face) against
  // side sj of j's, whose normals turned with them face each other (face false where they have turned
  // to within 60 degrees of each other). Two faces of automata that do not line up (a body turned against
  // the other, the random lattice's sites) touched as spheres only where two sites came near, each pair
  // along the line between them: a third of the sites carried the load, up to 8 times the mean, with a
  // fifth of it along the faces, and two bodies meeting face to face at 1 m/s chipped each other
  // (docs/model-notes.md, "Faces touch as faces"). As faces, they press along the mean of the two
  // normals, over r_i + r_j less the distance of the sites along it, with springs weighted by how much of
  // the smaller cell's square the other's covers in the sides' plane (on two grids a site's weights sum to
  // 1, whatever their offset or turn), at the point midway between the sites
  // (tools/face_contact_study.py).
  MCA_HD FaceGap face_pair(std::size_t i, std::size_t j, const DVec3& xi, const Quat& qi, const DVec3& xj,
                           const Quat& qj, int si, int sj) const {
    FaceGap g{};
    const Vec3 mean = rotated(qi, side_normal0(i, si)) - rotated(qj, side_normal0(j, sj));
    const float len = length(mean);
    if (!(len > 1.0f)) return g;
    const Vec3 n = mean * (1.0f / len);
    const DVec3 d = ddelta(xi, xj);
    // In double, as sphere_gap: a resting contact's overlap is below a float distance's resolution.
    const double along = d.x * n.x + d.y * n.y + d.z * n.z;
    g.face = true;
    g.side_i = si;
    g.side_j = sj;
    g.n = n;
    g.overlap = static_cast<float>(static_cast<double>(radius[i]) + radius[j] - along);
    const Vec3 dv = to_vec3(d);
    const Vec3 lateral = dv - static_cast<float>(along) * n;
    Vec3 t = rotated(qi, side_tangent0(i, si));
    t = t - dot(t, n) * n;
    t = t * (1.0f / length(t));
    const Vec3 s = cross(n, t);
    const float reach = radius[i] + radius[j], width = 2.0f * fminf(radius[i], radius[j]);
    // The cells' overlaps across n, along i's side's axis t and the other.
    const float across_t = fminf(fmaxf(reach - fabsf(dot(lateral, t)), 0.0f), width);
    const float across_s = fminf(fmaxf(reach - fabsf(dot(lateral, s)), 0.0f), width);
    g.weight = (across_t / width) * (across_s / width);
    g.arm_i = 0.5f * dv;
    g.arm_j = -g.arm_i;
    return g;
  }
  // The sides by which automata i and j, apart so far, would touch as faces (face_pair): of their cells'
  // free sides, two whose normals face each other within 25 degrees (kFaceCos), j in front of i's side;
  // of several such pairs (an edge's or a corner's automaton), the one along which the sites lie
  // farthest apart (the least overlap, as between two boxes). Whether they begin to touch so is the
  // contact's (pair_contact: only as the pair meets).
  MCA_HD FaceGap face_start(std::size_t i, std::size_t j, const DVec3& xi, const Quat& qi, const DVec3& xj,
                            const Quat& qj) const {
    Vec3 ni[6], nj[6];
    int ki[6], kj[6];
    const int ci = free_sides(i, qi, ni, ki), cj = free_sides(j, qj, nj, kj);
    const DVec3 d = ddelta(xi, xj);
    double farthest = 0;
    int si = -1, sj = -1;
    for (int a = 0; a < ci; ++a)
      for (int b = 0; b < cj; ++b) {
        if (!(dot(ni[a], nj[b]) < -kFaceCos)) continue;
        const Vec3 mean = ni[a] - nj[b];
        const Vec3 n = mean * (1.0f / length(mean));
        const double along = d.x * n.x + d.y * n.y + d.z * n.z;  // (face_pair's)
        if (along > 0 && (si < 0 || along > farthest)) {
          farthest = along;
          si = ki[a];
          sj = kj[b];
        }
      }
    if (si < 0) return FaceGap{};
    return face_pair(i, j, xi, qi, xj, qj, si, sj);
  }
  // Whether automata i and j, turned by qi, qj, may touch as faces at all: both with free sides, touching
  // as spheres at r_i + r_j (not a pair of the random lattice a link joined at the start, or nearer than
  // that: those touch where they stood, up to 2.2 d apart, and as faces they touched at d only), and of
  // two objects, or of one turned more than 5 degrees against each other. Two pieces of one object that
  // have kept their turn keep its lattice: their cells line up, as spheres do (and a body's own automata,
  // which never face each other, cost the contact search and pass nothing: a slab of one cell's
  // thickness listed 1,442 pairs of its top and bottom automata, and ran at a third of the speed).
  // l: random_link_at_start(i, j) (a scan of i's links: a contact looks it up once for all its uses).
  MCA_HD bool may_face(std::size_t i, std::size_t j, const Quat& qi, const Quat& qj, std::int64_t l) const {
    if (!face || !face[i] || !face[j]) return false;
    if (object[i] == object[j] && fabsf(qi.w * qj.w + qi.x * qj.x + qi.y * qj.y + qi.z * qj.z) > kSameTurn) return false;
    return contact_reach(i, j, l) == static_cast<double>(radius[i]) + radius[j];
  }
  // Automata i and j with free sides as faces, by the way their contact began (ContactPair::face, way): as
  // faces it keeps the sides it began on (face_pair) till the pair parts; apart, it begins as faces where
  // face_start finds sides facing each other. face false: as spheres. A contact that changed its way while
  // the pair pressed would take or give at once the difference of the two ways' springs' energies (as
  // spheres, automata whose faces stand at 25 degrees to the line between them overlap 0.1 d less: two
  // loose automata meeting at 19 m/s left with 140 times their energy), so a contact begun as spheres
  // stays so.
  // l: random_link_at_start(i, j), looked up once by the contact's caller.
  MCA_HD FaceGap contact_faces(std::size_t i, std::size_t j, std::uint8_t way, const DVec3& xi, const Quat& qi,
                               const DVec3& xj, const Quat& qj, std::int64_t l) const {
    if (way == ContactPair::kAsSpheres || !may_face(i, j, qi, qj, l)) return FaceGap{};
    return faces_by_way(i, j, way, xi, qi, xj, qj);
  }
  // contact_faces of a pair its caller found may touch as faces (way not kAsSpheres, may_face).
  MCA_HD FaceGap faces_by_way(std::size_t i, std::size_t j, std::uint8_t way, const DVec3& xi, const Quat& qi,
                              const DVec3& xj, const Quat& qj) const {
    if (way == ContactPair::kApart) return face_start(i, j, xi, qi, xj, qj);
    const int sides = way - ContactPair::kAsFaces;
    return face_pair(i, j, xi, qi, xj, qj, sides / 6, sides % 6);
  }
  // Whether automata i and j, d apart (from i to j, as the contact search forms it) and turned by qi, qj,
  // may touch as faces before the contact list is built again (till then no automaton moves skin / 2):
  // both with free sides, nearer than sqrt(3) (r_i + r_j) + skin (two touching sides' sites lie less than
  // r_i + r_j apart along their normal and each way across it), and two of their sides turned more than
  // 120 degrees from each other (not two sites of one face, or of one body at rest). A piece that turns
  // the 35 degrees further before the next rebuild without moving skin / 2 (a loose automaton spinning in
  // place) misses its faces' partners beyond its spheres' reach till then.
  MCA_HD bool face_candidate(std::size_t i, std::size_t j, const Vec3& d, const Quat& qi, const Quat& qj,
                             float skin) const {
    if (!face || !face[i] || !face[j]) return false;
    const float reach = kFaceReach * (radius[i] + radius[j]) + skin;
    if (!(dot(d, d) < reach * reach)) return false;
    if (!may_face(i, j, qi, qj, random_link_at_start(i, j))) return false;
    Vec3 ni[6], nj[6];
    int ki[6], kj[6];
    const int ci = free_sides(i, qi, ni, ki), cj = free_sides(j, qj, nj, kj);
    for (int a = 0; a < ci; ++a)
      for (int b = 0; b < cj; ++b)
        if (dot(ni[a], nj[b]) < -0.5f) return true;
    return false;
  }
  MCA_HD const ContactMaterial& contact_material(std::size_t a, std::size_t b) const { return contact[a * groups + b]; }
  MCA_HD float contact_length(std::size_t i, std::size_t j, std::int64_t l) const {
    if (l < 0) return 2.0f * fminf(radius[i], radius[j]);
    const GroupParams &gi = group_params[group[i]], &gj = group_params[group[j]];
    const float s = lattice_stiffness, sl = lattice_lambda;
    const float k = link_normal_stiffness(s * harmonic(gi.shear_modulus, gj.shear_modulus), sl * gi.lame_lambda,
                                          sl * gj.lame_lambda, area[l], static_cast<float>(r0[l]));
    return k / contact_material(group[i], group[j]).youngs;
  }
  MCA_HD ContactSprings pair_contact_springs(std::size_t i, std::size_t j, std::int64_t l, float zeta) const {
    return contact_springs(contact_material(group[i], group[j]), zeta, contact_length(i, j, l),
                           reduced(radius[i], radius[j]), reduced(mass[i], mass[j]), reduced(inertia[i], inertia[j]));
  }
  // Where one of the pair is held (held(i) != held(j)): the free one's mass and moment of inertia move
  // alone, as against the ground or a kinematic ball (the pair's reduced ones gave an automaton bouncing
  // off a held one a restitution of 0.275 for the pair's 0.20); zeta_held: Model::zeta_pair_held.
  MCA_HD ContactSprings held_pair_contact_springs(std::size_t i, std::size_t j, std::int64_t l,
                                                  const float* zeta_held) const {
    const std::size_t f = held(i) ? j : i, h = held(i) ? i : j;
    return contact_springs(contact_material(group[i], group[j]), zeta_held[group[f] * groups + group[h]],
                           contact_length(i, j, l), reduced(radius[i], radius[j]), mass[f], inertia[f]);
  }
};

}  // namespace mca
