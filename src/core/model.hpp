#pragma once
// The Model: what does not change during a run (built once from a SceneDef by the lattice builder);
// the State (state.hpp) holds what the step changes. Per-automaton data is one array per quantity (3-vectors
// as arrays of Vec3/DVec3), links are slots by lattice direction plus the explicit links; the backend
// makes its own structure-of-arrays copies of what the step reads (backend/cpu). Besides what the step
// needs, the model holds what outputs and `mca info` use: group, object and grip names, the mesh
// objects' summaries (MeshSummary), their triangles bound to automata (BoundSurface), the critical step
// and what limits it.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/math.hpp"

namespace mca {

struct ContactSprings;         // physics/contact_law.hpp
struct LinkBendingConstants;  // physics/link_law.hpp

// Strengthening law of a material (paper eq. 7; the functions are in physics/link_law.hpp).
struct Strengthening {
  int law = 0;      // 0 none, 1 exponential E0 exp(alpha e), 2 quadratic E0 (1 + alpha e^2)
  float alpha = 0;  // alpha of eq. 7
  float cap = 0;    // |e| beyond which the modulus stops growing (the largest breaking strain)
};

// Material constants of one automata group, in the form the step uses (physics.md sec. 3).
struct GroupParams {
  float youngs = 0, poisson = 0, density = 0;
  float shear_modulus = 0;   // G = E / (2 (1 + nu))
  float lame_lambda = 0;     // lambda = E nu / ((1 + nu)(1 - 2 nu)) = D * K / 3
  float tensile_strength = 0, compressive_strength = 0, fracture_strain = 0;
  float friction = 0, restitution = 0, rolling_friction = 0, twisting_friction = 0;
  float damping_time = 0;    // Kelvin-Voigt viscosity time tau [s] (physics/link_law.hpp, link_dashpot)
  float fracture_energy = 0; // G_f [J/m^2] of the links' softening; 0: instant break (physics/fracture.hpp)
  float weibull_modulus = 0; // spread of the links' strengths (Model::link_strength); 0: none
  Strengthening strengthening;
};

// What a pair of materials (or a material and the ground) brings to a contact (physics/contact_law.hpp).
struct ContactMaterial {
  float youngs = 0, shear = 0;  // E_12, G_12: harmonic means (the rigid ground counts as infinite)
  float restitution = 0;        // the pair's coefficient of restitution
  float zeta = 0;               // damping ratio of the clipped dashpot for it (continuous time)
  float friction = 0, rolling = 0, twisting = 0;
};

struct ProjectileParams {
  std::string name;
  float radius = 0, mass = 0, inertia = 0;
  int group = 0;             // material of the projectile (index into Model::groups)
  bool kinematic = false;
  float rolling = 0, twisting = 0;  // its rolling and twisting resistance (ProjectileDef)
  // Damping ratios of its contacts with automata (per group) and the ground (see Model::zeta_pair); with
  // automata a grip holds (per group; its own mass moves alone; empty in a scene without grips).
  std::vector<float> zeta_automata, zeta_held;
  float zeta_ground = 0;
  DVec3 position;
  DVec3 velocity, angular_velocity;
};

// What a mesh object was built from (mca info reports it).
struct MeshSummary {
  std::int32_t object = 0;       // index of the scene object
  std::string path;
  std::size_t vertices = 0, faces = 0;
  std::size_t boundary_edges = 0, non_manifold_edges = 0, degenerate_faces = 0, holes = 0;
  std::size_t shells = 0, cavities = 0;        // connected surfaces; those that bound a cavity
  std::array<double, 3> file_lo{}, file_hi{};  // bounding box in the file's units
  std::array<double, 3> lo{}, hi{};            // bounding box in the scene [m] (scaled, rotated, placed)
  double scale = 1;              // file units to metres
  double volume = 0;             // enclosed volume [m^3]
  double fill_seconds = 0;       // time to find the cells inside (signed distance and interior)
  std::size_t automata = 0;      // automata of the object
  // Volume fill: cells inside the mesh that no lattice link joins to the body of their shell (they would
  // fall off at t = 0), left out, and the pieces they formed.
  std::size_t dropped_automata = 0, dropped_pieces = 0;
  bool surface = false;          // filled in surface mode (one automaton per triangle)
  std::size_t links = 0, unlinked_edges = 0;  // surface mode: explicit links; non-manifold edges left unlinked
  std::size_t pieces = 0;                     // surface mode: the shell's pieces at the start (by its links)
  std::size_t duplicate_faces = 0;            // surface mode: triangles given twice, left out
  double shell_thickness = 0;    // surface mode [m]
  // Surface mode, solver.mass_scaling: the automata given mass, the mass added [kg] (included in the
  // model's masses), the object's mass before [kg], and the critical step they were raised to [s].
  std::size_t mass_scaled = 0;
  double added_mass = 0, mesh_mass = 0, scaled_step = 0;
};

// The bound surface as plain arrays (a device thread's too).
struct SurfaceCorners {
  const std::uint32_t *automaton = nullptr, *corner = nullptr, *first_corner = nullptr, *corners_of = nullptr;
  const Vec3* offset = nullptr;
};
// The input triangles of the mesh objects, each bound to one automaton (paper sec. 5.4): its corners are
// stored as offsets from that automaton's centre in the automaton's own frame (at the start the world
// frame: orientations start at identity), so the surface moves and turns with the automata and opens
// between triangles whose automata end in different fragments (analysis/surface.hpp).
struct BoundSurface {
  std::vector<std::uint32_t> automaton;  // per triangle: the automaton nearest its centroid (of its object)
  std::vector<std::uint32_t> corner;     // 3 per triangle: the mesh vertex, numbered over all meshes
  std::vector<Vec3> offset;              // 3 per triangle: the corner's offset from the automaton's centre
  std::size_t vertices = 0;              // mesh vertices over all meshes
  // The corners of each mesh vertex v: corners_of[first_corner[v] .. first_corner[v + 1]), in order.
  std::vector<std::uint32_t> first_corner, corners_of;
  std::size_t faces() const { return automaton.size(); }
  SurfaceCorners corners() const {
    return {automaton.data(), corner.data(), first_corner.data(), corners_of.data(), offset.data()};
  }
};

// Where corner c of the bound surface lies in a pose (in double; the caller rounds): at the mean of the
// positions that the corners of its mesh vertex whose triangles are of its fragment are carried to by
// their automata (each corner's offset turned by its automaton's orientation and added to its centre;
// summed in corner order).
// same(f, g): triangles f and g are of one fragment; pose(a, x, q): automaton a's centre and orientation.
template <class Same, class Pose>
MCA_HD DVec3 posed_corner(const SurfaceCorners& S, std::uint32_t c, const Same& same, const Pose& pose) {
  const std::uint32_t v = S.corner[c], f = c / 3;
  double sx = 0, sy = 0, sz = 0, count = 0;
  for (std::uint32_t k = S.first_corner[v]; k < S.first_corner[v + 1]; ++k) {
    const std::uint32_t other = S.corners_of[k];
    if (!same(f, other / 3)) continue;
    DVec3 x;
    Quat q;
    pose(S.automaton[other / 3], x, q);
    const Vec3& o = S.offset[other];
    const DVec3 p = rotated<double>(QuatT<double>{q.w, q.x, q.y, q.z}, DVec3{o.x, o.y, o.z});
    sx += x.x + p.x;
    sy += x.y + p.y;
    sz += x.z + p.z;
    count += 1;
  }
  return {sx / count, sy / count, sz / count};
}

struct ModelView;

struct Model {
  // --- automata (n) ---
  // Initial centres, double like the state's positions: rest lengths and initial strains are formed
  // from them (a float32 centre 1 km from the origin is off by 3e-5 m, a strain of 6e-4 on a 5 cm link).
  std::vector<DVec3> position0;
  std::vector<DVec3> velocity0;   // initial velocities
  std::vector<float> mass, radius, inertia, volume;
  std::vector<std::uint8_t> group;         // index into groups
  std::vector<std::uint8_t> strength_class;  // 1..4
  std::vector<float> class_factor;         // k_c of the automaton's class
  std::vector<std::int32_t> object;        // index of the scene object it came from
  std::vector<std::int16_t> grip;          // index of the grip holding it, -1 if free
  std::vector<Vec3> load;                  // constant external force; empty when the scene has no loads

  // --- links ---
  // Slot l = axis * n + a holds the link from automaton a to its neighbour along +axis of its object's
  // own lattice (axis 0, 1, 2: the object's local x, y, z), when it has one. This is the layout the
  // backends share (structure of arrays by direction, the far end at a fixed offset inside a box); a slot
  // without a link is never intact. Every lattice link has rest length `spacing` and cross-section
  // spacing^2 (the explicit links below have their own).
  // Automata are numbered row by row (x fastest) within each object, so the links of automaton a in
  // increasing link order of the lattice's cells are those along -z, -y, -x, +x, +y, +z.
  static constexpr std::uint32_t kNoLink = 0xffffffffu;
  std::vector<std::uint32_t> neighbour;        // 3n: a's neighbour along +axis at axis * n + a, or kNoLink
  std::vector<std::uint32_t> neighbour_below;  // 3n: a's neighbour along -axis (its link is in that one's slot)
  // Per lattice slot, when the lattice is jittered (SolverDef::lattice_jitter; empty otherwise): the
  // link's rest length (the distance of its moved sites) and its inverse.
  std::vector<double> link_rest;
  std::vector<float> link_inv_rest;
  // The factor on the lattice links' moduli (G and lambda of the pair and many-body terms) that returns
  // the input E of a jittered lattice (lattice::jitter_stiffness); on the random lattice's G only
  // (lattice::kRandomStiffness, with lattice_lambda); 1 for the cubic one.
  float lattice_stiffness = 1.0f;
  // The factor on lambda (the many-body term and a link's normal stiffness): lattice_stiffness on the
  // jittered lattice, lattice::kRandomLambda on the random one, 1 on the cubic one.
  float lattice_lambda = 1.0f;
  // The factor on the strengths and breaking strains of the random lattice's automata
  // (lattice::kRandomStrength) that gives a block of it the cubic lattice's tensile strength; 1 otherwise.
  float lattice_strength = 1.0f;
  // The factor beta on the random lattice's links' bending and twisting springs
  // (volume_bending_constants; SolverDef::link_bending); 0: none (the cubic and jittered lattices).
  float lattice_bending = 0.0f;
  // Per link slot: the link's own strength factor (Weibull, MaterialDef::weibull_modulus), which
  // multiplies the weaker end's strengths and breaking strain (lattice links and the random lattice's
  // explicit links; 1 on a surface-mode object's); empty when no material has a spread.
  std::vector<float> link_strength;
  std::size_t links = 0;                       // slots that hold a link (lattice and explicit)
  // Explicit links (objects filled in surface mode: one automaton per triangle, linked across shared
  // edges): slot 3n + k holds explicit link k, between automata i[k] < j[k], with its own rest length and
  // cross-section. The automata of such objects have no lattice links.
  struct ExplicitLinks {
    std::vector<std::uint32_t> i, j;
    std::vector<double> r0;    // rest length [m] (double: the strain at rest is zero to 1e-16, see link_geometry)
    std::vector<float> area;   // cross-section [m^2]: the shared edge's length times the shell thickness
    std::vector<float> edge;   // the shared edge's length [m] (the cross-section's width)
    std::vector<Vec3> normal;  // the shell's normal at the link at the start, orthogonal to it (0: a random link)
    // The explicit links of automaton a: of[first[a] .. first[a + 1]), in increasing link order
    // (first is empty when there are none).
    std::vector<std::uint32_t> first, of;
    std::size_t size() const { return i.size(); }
  } explicit_links;

  // --- scene-level ---
  std::vector<GroupParams> groups;
  // Contact materials: contact[a * groups + b] for groups a, b; ground_contact[a] against the ground.
  std::vector<ContactMaterial> contact, ground_contact;
  // Damping ratios of the contact dashpots calibrated for the time step dt (lattice::set_time_step): the
  // clipped law integrated at dt returns each pair's restitution. Automata of groups a, b:
  // zeta_pair[a * groups + b]; on the ground: zeta_ground[a]; projectiles p, q: zeta_projectiles[p * P + q].
  // An automaton of group a against one of group b that a grip holds (nothing moves it: the free one's own
  // mass, as against the ground): zeta_pair_held[a * groups + b], empty in a scene without grips.
  std::vector<float> zeta_pair, zeta_ground, zeta_projectiles, zeta_pair_held;
  std::vector<std::string> group_names;
  std::vector<std::string> object_names;
  // Per object: its lattice's axes (local x, y, z) in the world, unit vectors.
  std::vector<std::array<Vec3, 3>> object_axes;
  std::vector<std::uint8_t> object_surface;  // per object: 1 when filled in surface mode (explicit links)
  // Per object: 1 when filled with the random lattice (SolverDef::Lattice::random): its automata are joined
  // by explicit links under the volume's law (a many-body term over the Voronoi cell, a bending spring of
  // the link's own section: lattice_bending), not the shell's. Empty when no object is.
  std::vector<std::uint8_t> object_random;
  // Per automaton, when an object is filled with the random lattice or the cubic lattice is jittered
  // (empty otherwise): the centre of the cubic cell its site lies in (world, at the start; an automaton of
  // another object: its position0). The object's solid is the union of these cells (its Voronoi cells,
  // bounded by the mirrored ghosts, fill exactly them); the fragment meshes (analysis/fragment_meshes.cpp)
  // bound a piece by them.
  std::vector<DVec3> cell0;
  // Per automaton, when an object is filled with the random lattice (empty otherwise): 1 for one of its
  // automata whose Voronoi neighbours are all of the object (none on its surface). Such an automaton,
  // with every link intact, is boxed in by its linked neighbours, and the contact search leaves it out
  // (as a cubic automaton with six links).
  std::vector<std::uint8_t> boxed;
  // Per automaton, when an object is filled with the random lattice (empty otherwise): the sum of A r over
  // its Voronoi cell's faces toward the ghost sites beyond the object's surface (A the face's area, r the
  // distance to the ghost) [m^3]; 0 inside. Its many-body term takes their normal strain as free
  // (random_many_body).
  std::vector<float> free_face;
  // Per automaton (empty when none has one): the free sides of its cell at the start, bit 2 axis + s for
  // the side along +axis (s = 0) or -axis (s = 1) of object_axes: on the cubic lattice where it has no
  // link, on the random one where the cell beside its own is not of the object (its site lies on that
  // side: random_lattice.cpp). 0 inside, on a surface-mode shell and on the jittered lattice (whose sites
  // are moved off the faces). Two automata whose free sides face each other touch as faces do
  // (ModelView::contact_faces), not as spheres.
  std::vector<std::uint8_t> face;
  // The distance below which automata i and j touch: r_i + r_j, or, for two automata of the random lattice,
  // the distance of their initial centres when a link joined them at the start, and the smaller of r_i +
  // r_j and that distance otherwise. Its neighbours lie from 0.5 to 2.2 d apart (median 1.28 d): a broken
  // link's pair then touches where it stood, without overlap and without a gap, as the cubic lattice's
  // pairs at d do, and pairs that start closer than their radii are not pushed apart. (Capped at r_i +
  // r_j = d, as before 2026-12-02, a broken link left most pairs a gap of up to 1.2 d: crushed material
  // without contact, through which a block in compression gave way at 0.27 of the compressive
  // strength; docs/model-notes.md, "The random lattice".)
  // l: random_link_at_start(i, j), for a caller that needs it twice (a scan of i's links).
  double contact_reach(std::size_t i, std::size_t j) const { return contact_reach(i, j, random_link_at_start(i, j)); }
  double contact_reach(std::size_t i, std::size_t j, std::int64_t l) const;
  // The explicit link that joined automata i and j of the random lattice at the start (intact or not), or
  // -1 (also where either is not of the random lattice).
  std::int64_t random_link_at_start(std::size_t i, std::size_t j) const;
  // The explicit link that joined automata i and j at the start, or -1.
  std::int64_t link_at_start(std::size_t i, std::size_t j) const;
  // The length L of the contact springs (k_n = E_12 L, physics/contact_law.hpp) between automata i and j:
  // 2 min(r_i, r_j), d for two lattice automata (a link of length d in compression); for a pair of the
  // random lattice that a link joined at the start, the length that gives the contact that link's normal
  // stiffness, (2 G_ij + (lambda_i + lambda_j) / 2) S / r0 with the lattice's stiffness factor (model.cpp):
  // a closed crack presses as its link did. (With d, a broken pair of the random lattice pressed about 4
  // times harder than its link had, a long thin link's up to 50 times.)
  // l: random_link_at_start(i, j).
  float contact_length(std::size_t i, std::size_t j, std::int64_t l) const;
  // The springs and dashpots of a contact between automata i and j (l: random_link_at_start(i, j)) whose
  // normal dashpot has the damping ratio zeta: the backend's (zeta_pair), the time step's (the contact
  // material's continuous-time one) and the energy's (whose springs alone count) are this one.
  ContactSprings pair_contact_springs(std::size_t i, std::size_t j, std::int64_t l, float zeta) const;
  // The bending and twisting spring of explicit link k: a shell's (link_bending_constants) or a random-lattice
  // link's (volume_bending_constants, its moduli with the lattice's factor; all zeros at lattice_bending 0):
  // the backend's and the energy's are this one.
  LinkBendingConstants explicit_bending(std::size_t k) const;
  // These per-pair rules over plain pointers (core/model_view.hpp), for a backend's step: the methods above
  // call them.
  ModelView view() const;
  std::vector<MeshSummary> meshes;  // one per object of shape mesh
  BoundSurface surface;             // the triangles of the mesh objects, bound to automata
  std::vector<ProjectileParams> projectiles;
  std::vector<DVec3> grip_velocity;
  std::vector<std::string> grip_names;
  bool ground = false;
  double ground_height = 0;  // the plane x . up = ground_height (double: the positions' precision far out)
  // How far the plane lies below the scene's ground.height (times |up|): the float rounding of the centres and
  // contact radii of the objects placed on the ground (at most 1e-6 of the spacing), which would start them
  // pressed into it (lattice.cpp, settle_on_the_ground). 0 where none is left.
  double ground_lowered = 0;
  Vec3 gravity;
  Vec3 up{0, 0, 1};
  float spacing = 0;             // lattice spacing d
  float dt = 0;                  // time step
  double critical_dt = 0;        // critical step of the integration (lattice/time_step.cpp)
  std::string dt_limited_by;     // what sets the critical step
  double objects_critical_dt = 0;  // the automata's own critical step, before the projectiles' (for a note)
  float skin = 0;                // contact search skin [m]
  float link_damping = 0, local_damping = 0, stress_coefficient = 1;
  double total_mass = 0;

  std::size_t size() const { return mass.size(); }
  // The mass of a lattice automaton of group g, a cube of side d: every automaton of a lattice fill of
  // that group has it (surface-mode automata have their own), so the lattice links' constants, set per
  // pair of groups, use the masses of the pair they join.
  float lattice_mass(std::size_t g) const { return groups[g].density * spacing * spacing * spacing; }
  const ContactMaterial& contact_material(std::size_t a, std::size_t b) const { return contact[a * groups.size() + b]; }
  // The contacts of projectile p with automata of group g, with the ground, with projectile q: the
  // materials' pair values, but the projectile's own rolling and twisting resistance (a sphere rolls; the
  // materials' values are those of cube-shaped automata), the mean of two projectiles'.
  ContactMaterial projectile_contact(std::size_t p, std::size_t g) const {
    return rolling_of(contact_material(g, projectiles[p].group), projectiles[p].rolling, projectiles[p].twisting);
  }
  ContactMaterial projectile_ground_contact(std::size_t p) const {
    return rolling_of(ground_contact[projectiles[p].group], projectiles[p].rolling, projectiles[p].twisting);
  }
  ContactMaterial projectile_pair_contact(std::size_t p, std::size_t q) const {
    const ProjectileParams &A = projectiles[p], &B = projectiles[q];
    return rolling_of(contact_material(A.group, B.group), 0.5f * (A.rolling + B.rolling), 0.5f * (A.twisting + B.twisting));
  }
  static ContactMaterial rolling_of(ContactMaterial c, float rolling, float twisting) {
    c.rolling = rolling;
    c.twisting = twisting;
    return c;
  }
  std::size_t lattice_slots() const { return neighbour.size(); }
  // Whether any lattice link exists (a model of the random lattice or of surface-mode objects only has none).
  bool has_lattice_links() const {
    return std::any_of(neighbour.begin(), neighbour.end(), [](std::uint32_t j) { return j != kNoLink; });
  }
  // Some lattice automaton's material softens (fracture_energy > 0; a projectile's or a surface-mode
  // object's material does not count: they have no lattice links; the random lattice's automata count,
  // their explicit links soften): the state keeps each link's damage (State::link_damage; 0 on a
  // surface-mode object's links, which never soften).
  bool softening() const {
    for (std::size_t a = 0; a < group.size(); ++a)
      if (groups[group[a]].fracture_energy > 0 &&
          (object_surface.empty() || !object_surface[static_cast<std::size_t>(object[a])]))
        return true;
    return false;
  }
  std::size_t link_slots() const { return neighbour.size() + explicit_links.size(); }
  std::size_t link_count() const { return links; }
  bool is_explicit(std::size_t l) const { return l >= neighbour.size(); }
  // Whether automaton a is of an object filled with the random lattice.
  bool random_automaton(std::size_t a) const { return !object_random.empty() && object_random[object[a]] != 0; }
  bool link_exists(std::size_t l) const { return is_explicit(l) || neighbour[l] != kNoLink; }
  // The ends of the link in slot l (i < j) and its lattice axis (-1 for an explicit link).
  std::uint32_t link_i(std::size_t l) const {
    return is_explicit(l) ? explicit_links.i[l - neighbour.size()] : static_cast<std::uint32_t>(l % size());
  }
  std::uint32_t link_j(std::size_t l) const { return is_explicit(l) ? explicit_links.j[l - neighbour.size()] : neighbour[l]; }
  int link_axis(std::size_t l) const { return is_explicit(l) ? -1 : static_cast<int>(l / size()); }
  // Rest length and cross-section of the link in slot l.
  double link_r0(std::size_t l) const {
    return is_explicit(l) ? explicit_links.r0[l - neighbour.size()] : link_rest.empty() ? spacing : link_rest[l];
  }
  float link_area(std::size_t l) const {
    return is_explicit(l) ? explicit_links.area[l - neighbour.size()] : spacing * spacing;
  }
  // The tables of for_each_link_of as plain arrays (AutomatonLinks, below).
  struct AutomatonLinks automaton_links() const;
  // Calls f(l) for the slot of each link automaton a has: the lattice ones (at most six: its own along
  // +axis and its lower neighbours' along -axis, axis by axis), then the explicit ones in slot order.
  template <class F>
  void for_each_link_of(std::size_t a, F&& f) const;
  // Calls f(l, i, j, axis) for every link, in slot order (axis -1 for the explicit ones).
  template <class F>
  void for_each_link(F&& f) const {
    const std::size_t n = size();
    for (int axis = 0; axis < 3; ++axis)
      for (std::size_t i = 0; i < n; ++i) {
        const std::size_t l = axis * n + i;
        if (neighbour[l] != kNoLink) f(l, static_cast<std::uint32_t>(i), neighbour[l], axis);
      }
    for (std::size_t k = 0; k < explicit_links.size(); ++k) f(3 * n + k, explicit_links.i[k], explicit_links.j[k], -1);
  }
};

// The links of automaton a as Model::for_each_link_of gives them, from plain arrays (a device thread's too).
struct AutomatonLinks {
  std::size_t n = 0;
  const std::uint32_t *neighbour = nullptr, *below = nullptr;  // Model::neighbour, neighbour_below
  const std::uint32_t *first = nullptr, *of = nullptr;          // explicit links (first null: none)
  template <class F>
  MCA_HD void for_each(std::size_t a, F&& f) const {
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const std::size_t up = axis * n + a;
      if (neighbour[up] != Model::kNoLink) f(up);
      if (below[up] != Model::kNoLink) f(axis * n + below[up]);
    }
    if (first)
      for (std::uint32_t k = first[a]; k < first[a + 1]; ++k) f(3 * n + of[k]);
  }
};

// The damage of automaton a (automaton_damage): the share of its links that are broken, a
// softening link's damage counted (damage null: none), 0 without links.
MCA_HD float automaton_damage_of(const AutomatonLinks& links, std::size_t a, const std::uint8_t* intact,
                                 const float* damage) {
  std::uint32_t count = 0;
  float lost = 0;
  links.for_each(a, [&](std::size_t l) {
    ++count;
    lost += !intact[l] ? 1.0f : damage ? damage[l] : 0.0f;
  });
  return count ? lost / static_cast<float>(count) : 0.0f;
}

inline AutomatonLinks Model::automaton_links() const {
  return {size(), neighbour.data(), neighbour_below.data(),
          explicit_links.first.empty() ? nullptr : explicit_links.first.data(), explicit_links.of.data()};
}
template <class F>
void Model::for_each_link_of(std::size_t a, F&& f) const {
  automaton_links().for_each(a, f);
}

// The damage of each automaton: the share of its links (those it had at the start) that are broken, 0 for
// one without links, where a softening link that is damaged but intact counts by its damage
// (State::link_damage; null: none). intact and link_damage have a value per link slot, out one per
// automaton.
void automaton_damage(const Model& m, const std::uint8_t* intact, const float* link_damage, float* out);

// Bytes a run of a model of this many automata holds at its peak, for `mca info` and the memory check.
std::size_t estimate_memory_bytes(std::size_t automata, std::size_t explicit_links = 0, std::size_t random_automata = 0);
// Bytes a run holds on top of that when its objects break down to single automata (`mca info`'s figure for
// a body shattered to rubble).
std::size_t estimate_rubble_bytes(std::size_t automata, std::size_t random_automata = 0);

}  // namespace mca
