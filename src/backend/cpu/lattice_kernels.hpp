#pragma once
// The lattice part of a CPU step as three kernels over ranges of automata, each compiled for several
// instruction sets (lattice_kernels.inl, kernels_*.cpp) and picked at run time (select_kernels). Every
// version computes the same bits: lanes run the scalar formulas of physics/ operation for operation.
//
//   many_body  each automaton's many-body terms P per axis (volumetric strain of its intact links)
//   links      pair forces, torques and stress traces of the links along one axis, and the fracture
//              criteria; the links that break are reported, in link order, and left intact for the caller
//   explicit   the explicit links of surface-mode objects (their own lengths and cross-sections, ends
//              gathered by index): geometry, then forces and criteria; the backend sums them per automaton
//   automata   gathers the forces of each automaton's six links in a fixed order (-z, -y, -x, +x, +y,
//              +z: the order of the lattice's cells), adds contacts and loads, integrates
//
// The kernels see raw arrays only (no containers, no allocation), so that nothing compiled for one
// instruction set can be shared with another by the linker (tests/check_kernel_symbols.sh checks).
#include <cstddef>
#include <cstdint>
#include <climits>
#include <vector>

#include "core/model.hpp"
#include "physics/link_law.hpp"

namespace mca::cpu {

// Constants of a link between automata of groups a and b (pairs[a * groups + b]).
struct PairConstants {
  float G;                 // harmonic mean of the shear moduli
  float kt;                // shear spring k_s G S / r0
  LinkDashpots damping;    // link_dashpots of the pair
  float soft;              // softening_constant of the pair (0: the instant break)
};

// The far ends of a block of W consecutive automata (W the lanes of a kernel set) along one direction,
// worked out once from the neighbour tables (block_runs): when the lanes that have a neighbour have it at
// one offset (inside a box of the lattice: +-1, +-nx, +-nx ny) and the run a0 + offset ... stays inside
// the automata, the kernels load the far ends as that run, without reading the neighbour table; otherwise
// (offset == kGather) they read the table and gather.
struct BlockRun {
  static constexpr std::int32_t kGather = INT32_MIN;
  std::int32_t offset;
  std::uint32_t has;  // bit k: lane k has a neighbour in this direction
};

// The runs of the blocks of `lanes` automata of a model, at dir * (n / lanes) + a0 / lanes, dir 0-2 for
// the neighbours above along x, y, z (Model::neighbour) and 3-5 for those below.
std::vector<BlockRun> block_runs(const Model& m, int lanes);

// The bits of LatticeView::near: projectile p sets bit p % kNearBits.
inline constexpr int kNearBits = 8;

struct LatticeView {
  std::size_t n = 0;  // automata; link slots are axis * n + a (core/model.hpp)
  // Model.
  const std::uint32_t* up = nullptr;     // Model::neighbour
  const std::uint32_t* below = nullptr;  // Model::neighbour_below
  const BlockRun* runs = nullptr;        // block_runs for the kernels' lanes (null for one lane)
  std::size_t blocks = 0;                // n / lanes
  std::size_t ns = 0;                    // scratch_stride(n)
  const std::uint8_t* group = nullptr;
  const float *tensile = nullptr, *compressive = nullptr, *break_strain = nullptr;  // class factor x group's
  const float *mass = nullptr, *inv_mass = nullptr, *inv_inertia = nullptr, *inv_volume = nullptr;
  // Every automaton of one material with the same mass, moment of inertia and volume: body[] holds the
  // mass and the inverses of the three (the four arrays above are not read).
  bool uniform_bodies = false;
  float body[4] = {};
  const std::int16_t* grip = nullptr;  // null: no grips
  const DVec3* grip_velocity = nullptr;
  const Vec3* load = nullptr;  // null: no loads
  const GroupParams* groups = nullptr;
  const float (*free_factor)[4] = nullptr;  // per group (free_axis_factors)
  const PairConstants* pairs = nullptr;
  int group_count = 0;
  bool one_group = false;      // every automaton of group 0... of the same group (uniform constants)
  bool strengthening = false;  // some group has a strengthening law
  // Some group softens (fracture_energy): the links kernel runs link_softening_test and keeps each link's
  // damage, which the many-body sums take into account.
  bool softening = false;
  const float* link_strength = nullptr;  // Model::link_strength (null: no spread)
  // Model::link_rest and link_inv_rest (null: the cubic lattice, every link r0 long).
  const double* rest = nullptr;
  const float* inv_rest = nullptr;
  float stiffness = 1;  // Model::lattice_stiffness: on the many-body term's lambda (the pairs' G have it)
  float r0 = 0, inv_r0 = 0, area = 0, dt = 0, stress_coefficient = 1, local_damping = 0;
  Vec3 gravity;
  bool last = false;  // the last step of a call: write the averaged stress and the applied forces
  // State, by automaton (structure of arrays).
  double *px = nullptr, *py = nullptr, *pz = nullptr;
  double *vx = nullptr, *vy = nullptr, *vz = nullptr, *wx = nullptr, *wy = nullptr, *wz = nullptr;
  float *qw = nullptr, *qx = nullptr, *qy = nullptr, *qz = nullptr;
  float* mean_stress = nullptr;
  Sym3* stress = nullptr;            // State::s (last step)
  Vec3 *f_out = nullptr, *t_out = nullptr;  // State::f, State::t (last step)
  // State, by link slot.
  std::uint8_t* intact = nullptr;
  float *utx = nullptr, *uty = nullptr, *utz = nullptr;
  float* damage = nullptr;  // State::link_damage (softening only)
  // Scratch, by link slot, at axis * ns + a: ns is n rounded up to a cache line of floats, so that a
  // block of lanes at a multiple of its width is one aligned vector there. Link directions are formed
  // from the positions by each kernel that needs them (link_geometry, the same bits each time), and
  // stored only on the last step, for the averaged stress.
  float *nx = nullptr, *ny = nullptr, *nz = nullptr;
  float* many_body = nullptr;  // P of automaton a along an axis, at axis * ns + a
  // What the links kernel leaves for the automata kernel: per slot its force, torque and stress trace, in
  // tiles (kOutRows). The automata kernel reads them as 3 runs of memory, one per axis: as 21 arrays
  // side by side (one per axis and quantity) they took its runs to some 40, and this processor's memory
  // delivers 40 runs at half the rate of 20 (docs/benchmarks.md).
  float* out = nullptr;
  // Contacts and the like, added by the automata kernel and then cleared.
  std::uint8_t* has_ext = nullptr;
  Vec3 *ext_f = nullptr, *ext_t = nullptr;
  Sym3* ext_s = nullptr;
  // Projectiles near the automata after this step: the automata kernel sets bit p % kNearBits of near[a]
  // when automaton a ends the step within reach of projectile p's centre (its position for the next
  // step), so the next projectile pass tests those automata instead of all of them (with more than
  // kNearBits projectiles a bit stands for several: still all the automata each one can touch).
  std::size_t projectiles = 0;
  const double *proj_x = nullptr, *proj_y = nullptr, *proj_z = nullptr;
  const float* proj_reach2 = nullptr;  // (R + the largest automaton radius)^2, a little widened
  std::uint8_t* near = nullptr;
  // For the contact list's staleness: intact links per automaton and the positions at the last rebuild.
  const std::uint8_t* intact_count = nullptr;
  // The positions at the last rebuild, tiled (kRefRows rows: x, y, z): only the blocks with an exposed
  // automaton read them, as one run of memory instead of three (docs/benchmarks.md, "What bought what").
  const double* ref = nullptr;
};

// Where the automata kernel writes the state it changes that links also read: the LatticeView's own arrays
// (in_place) on the CPU, whose links kernel has run for the whole lattice by then; another copy of each in
// the CUDA backend's fused kernel, whose threads recompute their neighbours' links from the state before
// the step while others move on (backend/cuda/device_kernels.hpp, FusedLatticeKernel).
struct StateNext {
  double *px = nullptr, *py = nullptr, *pz = nullptr;
  double *vx = nullptr, *vy = nullptr, *vz = nullptr, *wx = nullptr, *wy = nullptr, *wz = nullptr;
  float* mean_stress = nullptr;
  float *utx = nullptr, *uty = nullptr, *utz = nullptr;  // by link slot (the fused kernel's)
  float* damage = nullptr;                               // (softening)
  MCA_HD static StateNext in_place(const LatticeView& v) {
    return {v.px, v.py, v.pz, v.vx, v.vy, v.vz, v.wx, v.wy, v.wz, v.mean_stress, v.utx, v.uty, v.utz, v.damage};
  }
};

// The explicit links (surface mode, Model::ExplicitLinks) as the explicit kernels see them: per link
// (structure of arrays) its ends, constants and this step's results; the automata's state is the
// LatticeView's. Link k is in slot slot0 + k of the LatticeView's per-slot arrays (intact, ut).
struct ExplicitView {
  std::size_t slot0 = 0;
  const std::uint32_t *i = nullptr, *j = nullptr;
  const double* r0 = nullptr;  // rest length
  const float *r0f = nullptr, *inv_r0 = nullptr, *area = nullptr;
  const float* inv_r0_area = nullptr;  // 1 / (r0 S): turns a many-body weight into the stress P
  const float *G = nullptr, *kt = nullptr, *damp_normal = nullptr, *damp_tangential = nullptr;
  // The softening constant of each link (softening_constant; 0: the instant break, as on every link of a
  // surface-mode object); null when no link softens. A link that softens keeps its damage in the
  // LatticeView's per-slot damage.
  const float* soft = nullptr;
  const float* weight = nullptr;  // per automaton: its many-body weight (explicit_many_body)
  // Per link: the tensile and compressive strengths and the breaking strain of its weaker end (the
  // smaller of the ends' LatticeView::tensile, ...), times its own factor (LatticeView::link_strength)
  // where the strengths spread: as the lattice links' kernel forms them each step.
  const float *tensile = nullptr, *compressive = nullptr, *strain = nullptr;
  // The bending spring (link_bending): stiffnesses, stresses per unit moment, the shell's normal at the
  // start; its moment is state (per link).
  const float *k_twist = nullptr, *k_in = nullptr, *k_out = nullptr, *s_in = nullptr, *s_out = nullptr,
              *s_twist = nullptr;
  // A random-lattice link's spring (volume_link_bending) reads k_in (its bending stiffness), k_twist and
  // s_in (its fibre's stress per unit moment) only, and keeps its ends' relative rotation (world) in
  // mx, my, mz; the shell's normal is a shell's alone. k_out, s_out, s_twist, m0x/y/z and kappa are null
  // where the model has no shell (a block of random links never reads them).
  const float *m0x = nullptr, *m0y = nullptr, *m0z = nullptr;
  // A shell's moment about the link, the shell's normal, their cross product; a random link's rotation.
  float *mx = nullptr, *my = nullptr, *mz = nullptr;
  // The bending's many-body part (explicit_bending_many_body): per link this step's r0 kappa_nn / r0
  // (explicit_geometry), per automaton its weight.
  float* kappa = nullptr;
  const float* bend_weight = nullptr;
  // Per link: 1 where it has a shell's bending spring (surface mode), 2 a random-lattice link's
  // (volume_bending_constants), 0 none (the random lattice's at link_bending = 0). A block of links without
  // one skips the bending's work: its spring would add exact zeros (null: every link is a shell's).
  const std::uint8_t* bends = nullptr;
  // This step's geometry (explicit_geometry) and forces (explicit_links), per link.
  float *nx = nullptr, *ny = nullptr, *nz = nullptr, *eps = nullptr;
  // The forces: a tiled array of kExplicitOutRows rows (the force on the first end, the torque on it,
  // the bending spring's torque on it), so that an automaton's gather reads one run of memory per link.
  float* out = nullptr;
};

MCA_HD constexpr std::size_t scratch_stride(std::size_t n) { return (n + 15) / 16 * 16; }

// Tiled arrays: tiles of kTile consecutive automata or slots, each `rows` rows of kTile values, so that
// a block of lanes at a multiple of its width is one vector of a row, and a pass that reads several
// quantities of an element reads one run of memory instead of one per quantity. Value `row` of element a is at
// tile_index(a, rows) + row * kTile.
inline constexpr std::size_t kTile = 16;
MCA_HD constexpr std::size_t tile_index(std::size_t a, std::size_t rows) { return a / kTile * (kTile * rows) + a % kTile; }
// The elements a tiled array of n holds (whole tiles).
MCA_HD constexpr std::size_t tiled_size(std::size_t n, std::size_t rows) { return scratch_stride(n) * rows; }

inline constexpr std::size_t kRefRows = 3;  // LatticeView::ref

// LatticeView::out: for each axis a tiled array of kOutRows rows (force x, y, z, torque x, y, z, trace),
// the axis's at axis * ns * kOutRows.
inline constexpr std::size_t kOutRows = 7;
enum OutRow : std::size_t { kOutFx, kOutFy, kOutFz, kOutTx, kOutTy, kOutTz, kOutTrace };
// ExplicitView::out: the rows kOutFx to kOutTz, then the bending spring's torque on the first end
// (kExplicitOutBx to + 2, world; written only where the link has a spring), per explicit link.
inline constexpr std::size_t kExplicitOutBx = 6;
inline constexpr std::size_t kExplicitOutRows = 9;

// A break found by the links kernel: the link slot and the criterion (bit 31: 1 = stress).
inline constexpr std::uint32_t kBreakByStress = 1u << 31;

struct AutomataResult {
  float max_move2 = 0;          // largest squared move of an exposed automaton since the rebuild
  std::int64_t first_bad = -1;  // the first automaton with a non-finite position, velocity or orientation, or -1
  bool near = false;            // some automaton of the range is near a projectile (LatticeView::near)
};

struct Kernels {
  const char* name;  // "scalar", "sse2", "avx2", "avx512"
  int lanes;
  void (*many_body)(const LatticeView&, std::size_t b, std::size_t e);
  // Writes the breaks of slots axis * n + [b, e) to `breaks` (room for e - b) and returns their count.
  std::size_t (*links)(const LatticeView&, int axis, std::size_t b, std::size_t e, std::uint32_t* breaks);
  AutomataResult (*automata)(const LatticeView&, std::size_t b, std::size_t e);
  // Explicit links [b, e): their direction and strain; then their forces, torques and the fracture
  // criteria (the breaks of links [b, e) to `breaks`, in link order, as slot numbers; returns their count).
  void (*explicit_geometry)(const LatticeView&, const ExplicitView&, std::size_t b, std::size_t e);
  std::size_t (*explicit_links)(const LatticeView&, const ExplicitView&, std::size_t b, std::size_t e,
                                std::uint32_t* breaks);
};

const Kernels& kernels_scalar();
const Kernels& kernels_sse2();
const Kernels& kernels_avx2();
const Kernels& kernels_avx512();

// The widest set this processor runs, or the one MCA_SIMD names (scalar, sse2, avx2, avx512; a set the
// processor lacks is an error, mca::Error).
const Kernels& select_kernels();
// Every set this processor runs, narrowest first (for tests and `mca bench`).
int available_kernels(const Kernels* out[4]);

}  // namespace mca::cpu
