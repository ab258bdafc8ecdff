#pragma once
// The CUDA backend's kernels: one function object per pass, called for each thread index k of a launch
// (a CUDA grid, or HostDevice's loop over k in order: host_device.hpp). Each reads and writes plain
// pointers into device arrays, and does the CPU backend's work for its element with the same functions
// (lattice_kernels.inl's Block<float>, step_kernels.hpp, physics/), so it computes the same bits.
//
// Where the CPU adds to an automaton in list order (contacts), the automaton gathers its entries of the
// list in that order (an incidence list); where the CPU pushes to a list in order (candidates, the new
// contact lists), each element writes a count or flag, and an exclusive scan gives its place (a stable
// compaction); breaks are appended in no order and put in slot order on the host. No floating-point
// atomics; the integer counters below give the same totals in any order.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <tuple>

#include "backend/cpu/lanes_scalar.hpp"  // first: Lanes<float>, before core/math.hpp
#include "backend/cpu/lattice_kernels.hpp"
#include "backend/energy_terms.hpp"
#include "backend/step_kernels.hpp"
#include "core/model_view.hpp"
#include "core/state.hpp"
#include "physics/contact_law.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

namespace mca::cpu::device_lanes {
using V = float;
#include "backend/cpu/lattice_kernels.inl"
}  // namespace mca::cpu::device_lanes

namespace mca::gpu {

using Lane = cpu::device_lanes::Block<float>;
inline constexpr std::uint32_t kNone = 0xffffffffu;

// Adds v to a counter shared by threads and returns its value before (integers: the total does not depend
// on the order, the value returned does).
MCA_HD std::uint32_t count_add(std::uint32_t* c, std::uint32_t v) {
#if defined(__CUDA_ARCH__)
  return atomicAdd(c, v);
#else
  const std::uint32_t before = *c;
  *c += v;
  return before;
#endif
}
MCA_HD void count_up(std::uint32_t* c) { count_add(c, 1u); }
// *to becomes the larger of it and v where v > 0 (not NaN), as a reducing launch takes its largest: the
// bits of non-negative floats order as unsigned integers do, so the result does not depend on the order.
MCA_HD void max_up(float* to, float v) {
  if (!(v > 0.0f)) return;
#if defined(__CUDA_ARCH__)
  atomicMax(reinterpret_cast<unsigned*>(to), __float_as_uint(v));
#else
  if (v > *to) *to = v;
#endif
}

// The links broken in a step: their codes (slot | kBreakByStress), appended by the link kernels in no
// order (the host puts them in slot order); a slot breaks at most once a step, so `code` holds every slot.
struct BreakList {
  std::uint32_t* code;
  std::uint32_t* count;
  MCA_HD void add(std::uint32_t c) const { code[count_add(count, 1u)] = c; }
};

// What a thread of a reducing launch gives (Dev::launch_reduce): a float whose largest over the launch is
// wanted (each taken as 0 where not > 0, NaN included) and an index whose smallest is (kNone: none).
struct Reduced {
  float max = 0;
  std::uint32_t min = kNone;
};

// What the host reads after each step, in one copy from the device: the step's results that decide what
// it does next (stop, apply breaks, rebuild the contact lists, size the projectiles' lists).
struct StepStatus {
  float move2 = 0;       // the largest squared move since the contact rebuild of an exposed automaton
  float move2_lost = 0;  // the same of an automaton boxed in until a link was damaged (softening)
  std::uint32_t bad = kNone;             // the first automaton with a value not finite
  std::uint32_t bad_projectile = kNone;  // the first projectile with one
  // Counters, cleared by the last step's lattice kernel (AutomataKernel, FusedLatticeKernel).
  std::uint32_t breaks = 0;       // links broken (BreakList::count)
  std::uint32_t touches = 0;      // (projectile, automaton) pairs touching at the step's end: the next step's candidates
  std::uint32_t ground_joins = 0;  // ends of broken links that join the ground list
  std::uint32_t touching_pairs = 0;  // projectile pairs touching at the step's end: the next pair list's size at most
  std::uint32_t pair_count = 0;      // the projectile pair list's size
};

// --- Explicit links ---
struct ExplicitGeometryKernel {
  cpu::LatticeView v;
  cpu::ExplicitView e;
  MCA_HD void operator()(std::size_t k) const { Lane::explicit_geometry(v, e, k); }
};
struct ExplicitWeightKernel {
  ExplicitPassView pv;
  const std::uint32_t* automata;
  float *weight, *bend_weight;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t a = automata[k];
    const ExplicitWeights w = explicit_weight(pv, a);
    weight[a] = w.weight;
    if (w.shell) bend_weight[a] = w.bend_weight;
  }
};
// The forces and the fracture tests of explicit link k; its break (slot | kBreakByStress) into the list.
struct ExplicitLinksKernel {
  cpu::LatticeView v;
  cpu::ExplicitView e;
  BreakList breaks;
  MCA_HD void operator()(std::size_t k) const {
    std::uint32_t c = kNone;
    if (Lane::explicit_links(v, e, k, &c)) breaks.add(c);
  }
};

// Adds to automaton a what acts on it from outside the lattice (the automata kernel reads and clears it).
struct External {
  Vec3 *f, *t;
  Sym3* s;
  std::uint8_t* has;
  MCA_HD void add(std::uint32_t a, const Vec3& fa, const Vec3& ta, const Sym3& sa) const {
    f[a] += fa;
    t[a] += ta;
    s[a] += sa;
    has[a] = 1;
  }
};
struct ExplicitGatherKernel {
  ExplicitPassView pv;
  const std::uint32_t* automata;
  External ext;
  bool last;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t a = automata[k];
    const ExternalSum s = explicit_gather(pv, a, last);
    if (s.any) ext.add(a, s.f, s.t, s.s);
  }
};

// --- Contacts ---
struct PairContactKernel {
  ContactPassView cv;
  ContactPair* pairs;
  ContactOut* out;
  MCA_HD void operator()(std::size_t p) const { out[p] = pair_contact(cv, pairs[p]); }
};
// The incidence list: entry e of the sorted (automaton, 2 p + side) list, side 0 for the pair's first body.
struct IncidenceKeysKernel {
  const ContactPair* pairs;
  std::uint32_t* key;
  std::uint32_t* value;
  MCA_HD void operator()(std::size_t p) const {
    key[2 * p] = pairs[p].i;
    value[2 * p] = static_cast<std::uint32_t>(2 * p);
    key[2 * p + 1] = pairs[p].j;
    value[2 * p + 1] = static_cast<std::uint32_t>(2 * p + 1);
  }
};
// Each automaton in the contact list adds its contacts' forces in pair order (the CPU's order): the thread
// of the entry that starts its run of the sorted incidence list (entries [0, size)) walks the run.
struct ContactGatherKernel {
  const std::uint32_t* key;
  const std::uint32_t* value;
  std::uint32_t size;
  const ContactOut* out;
  External ext;
  MCA_HD void operator()(std::size_t e0) const {
    const std::uint32_t a = key[e0];
    if (e0 > 0 && key[e0 - 1] == a) return;
    for (std::size_t e = e0; e < size && key[e] == a; ++e) {
      const std::uint32_t p = value[e] >> 1;
      const ContactOut& o = out[p];
      if (!o.on) continue;
      if (value[e] & 1u) ext.add(a, -o.f, o.tj, sym_outer(o.n, o.f, o.rj));
      else ext.add(a, o.f, o.ti, sym_outer(o.n, o.f, o.ri));
    }
  }
};
// The ground list holds an automaton at most once: each thread adds to its own automaton.
struct GroundKernel {
  ContactPassView cv;
  BodyContact* list;
  External ext;
  MCA_HD void operator()(std::size_t k) const {
    const ContactOut o = ground_contact(cv, list[k]);
    if (o.on) ext.add(list[k].automaton, o.f, o.ti, sym_outer(o.n, o.f, o.ri));
  }
};

// --- Projectiles: their state, and the automata they touch ---
// A projectile's state on the device (ProjectileState without its contact list).
struct DeviceProjectile {
  DVec3 position, velocity, angular_velocity;
  Quat orientation;
  Vec3 force;
  ContactHistory ground;
  double work = 0;
};
struct ProjectileConstants {
  DVec3 start;  // where it started (gravity's work)
  float radius = 0, mass = 0, inertia = 0;
  bool kinematic = false;
  int group = 0;
  float rolling = 0, twisting = 0;
  ContactSprings ground_springs;  // with the ground (body_contact_springs of its own)
};
// The projectiles' candidates: the automata each sphere touches, |d|^2 < (R + r_a)^2 in float (the CPU's
// test). They are found at the end of a step (positions do not change until the next step's projectile
// pass), counted per automaton, and written in (automaton, projectile) order at the next step's start.
// The (automaton, projectile) entries of the projectiles' next candidates, as the lattice kernels append
// them (Touch::count), up to `capacity`.
struct TouchList {
  std::uint32_t* automaton = nullptr;
  std::uint32_t* projectile = nullptr;
  std::uint32_t capacity = 0;
};
struct Touch {
  const DeviceProjectile* proj;
  const ProjectileConstants* P;
  std::uint32_t np;
  const double *px, *py, *pz;
  const float* r;
  MCA_HD bool operator()(std::uint32_t p, std::size_t a) const {
    const Vec3 d = delta(proj[p].position, DVec3{px[a], py[a], pz[a]});
    const float reach = P[p].radius + r[a];
    return dot(d, d) < reach * reach;
  }
  // Automaton a's entries (a, p), for the projectiles p it touches in order, from entry k on.
  MCA_HD void write(std::size_t a, std::uint32_t k, std::uint32_t* automaton, std::uint32_t* projectile) const {
    for (std::uint32_t p = 0; p < np; ++p)
      if ((*this)(p, a)) {
        automaton[k] = static_cast<std::uint32_t>(a);
        projectile[k++] = p;
      }
  }
  // count[a]: the projectiles touching automaton a; their number adds to *total. Where a list is given,
  // its entries go there too, after those of the automata that counted before it (in no order of automata;
  // the list is whole where the total is at most its capacity).
  MCA_HD void count(std::size_t a, std::uint32_t* counts, std::uint32_t* total, const TouchList& list = {}) const {
    std::uint32_t c = 0;
    for (std::uint32_t p = 0; p < np; ++p) c += (*this)(p, a) ? 1u : 0u;
    counts[a] = c;
    if (c == 0) return;
    const std::uint32_t k = count_add(total, c);
    if (list.automaton && k + c <= list.capacity) write(a, k, list.automaton, list.projectile);
  }
};

// --- Lattice ---
// A plain lattice step: no group with a strengthening law, no softening, no rest lengths of their own (the
// cubic lattice), no spread link strengths, no grips, no loads, and not a call's last step (which writes
// the averaged stress and the forces): the benchmark walls' steps. The lattice kernels below are compiled
// twice, Plain or not; the Plain ones read the view through plain(), whose constants let the compiler drop
// those branches and the registers they hold (the many-body kernel takes 40 registers instead of 64, so 6
// blocks of 256 threads on a multiprocessor instead of 4; ptxas -v, sm_90). Launched only for a plain view
// (is_plain: plain() then changes nothing), they compute the same bits from the same text.
// The view's fields that make a step not plain: each false or null in a plain one.
MCA_HD constexpr auto not_plain_fields() {
  using V = cpu::LatticeView;
  return std::tuple{&V::strengthening, &V::softening, &V::last, &V::rest, &V::inv_rest, &V::link_strength, &V::grip, &V::load};
}
MCA_HD cpu::LatticeView plain(cpu::LatticeView v) {
  std::apply([&](auto... field) { ((v.*field = {}), ...); }, not_plain_fields());
  return v;
}
inline bool is_plain(const cpu::LatticeView& v) {
  return std::apply([&](auto... field) { return (!(v.*field) && ...); }, not_plain_fields());
}
template <bool Plain>
MCA_HD decltype(auto) launched_view(const cpu::LatticeView& v) {
  if constexpr (Plain) return plain(v);  // a copy
  else return (v);                       // the view itself (a copy costs registers)
}
// The many-body terms of automaton a (they read positions, links and damage; write only the terms).
template <bool Plain>
struct ManyBodyKernel {
  cpu::LatticeView view;
  MCA_HD void operator()(std::size_t a) const { Lane::many_body(launched_view<Plain>(view), a); }
};
// Automaton a's three links (its slots along x, y and z), one after another: its own position, velocity and
// spin, read for the first, are in the cache for the other two (a thread per slot read them three times
// from memory). Each warp still reads consecutive elements of every array.
struct LinksKernel {
  cpu::LatticeView v;
  BreakList breaks;
  MCA_HD void operator()(std::size_t a) const {
#ifdef __CUDA_ARCH__
#pragma unroll
#endif
    for (int axis = 0; axis < 3; ++axis) {
      std::uint32_t c = kNone;
      if (Lane::links(v, axis, a, &c)) breaks.add(c);
    }
  }
};
// Automaton a's motion; it gives its squared move since the rebuild where exposed (else 0) to the largest,
// and itself where a value is not finite to the smallest. With projectiles (touch.np > 0), it also counts
// those its new position touches, for the next step's candidates (TouchCountKernel's work, done here while
// the position is at hand), and appends its entries to the list (TouchWriteKernel's, where it has room).
// Its first thread clears the next step's status (its counters and the reductions' starting values; the host
// has read it: it was this one's last step's).
struct AutomataKernel {
  cpu::LatticeView v;
  Touch touch;
  std::uint32_t* touch_count;
  std::uint32_t* touches;
  TouchList list;
  StepStatus* next_status;
  MCA_HD Reduced operator()(std::size_t a) const {
    if (a == 0) *next_status = StepStatus{};
    cpu::AutomataResult r;
    Lane::automata(v, a, r);
    if (touch.np) touch.count(a, touch_count, touches, list);
    return {r.max_move2, r.first_bad >= 0 ? static_cast<std::uint32_t>(a) : kNone};
  }
};
// The links and automata kernels in one (the backend's choice where it has no explicit links): automaton a
// computes its three own links and, again with the same bits, the three it is the upper end of, from the
// state before the step (view), gathers them in the automata kernel's order and moves, writing the state its
// neighbours' threads still read (positions, velocities, spins, mean stress; its links' shear displacement
// and damage) to next. No link results go through memory, and the many-body terms are the step's (the
// kernel before). Its own links' breaks go to the list, as from the links kernel; its first thread clears the
// next step's status, as the automata kernel's.
template <bool Plain>
struct FusedLatticeKernel {
  cpu::LatticeView view;
  cpu::StateNext next;
  BreakList breaks;
  Touch touch;  // positions: next's
  std::uint32_t* touch_count;
  std::uint32_t* touches;
  TouchList list;
  StepStatus* next_status;
  // The blocks of 256 threads a multiprocessor is to hold at once (CudaDevice::launch_reduce; the host
  // ignores it): 3 (the default) takes 80 registers and no spills, 2 takes 120 (unbounded), 4 takes 64 and
  // spills 116 bytes; compiled for a plain step, 80, 106, and 64 with 8 bytes spilled (ptxas -v, sm_90).
  // MCA_CUDA_LATTICE=fused:B chooses (cuda_lattice).
  int sm_blocks = 3;
  MCA_HD Reduced operator()(std::size_t a) const {
    const auto& v = launched_view<Plain>(view);
    if (a == 0) *next_status = StepStatus{};
    Lane::Gathered g = Lane::weight(v, a);
    const std::size_t n = v.n;
    for (int axis = 2; axis >= 0; --axis) {  // the links below: as their first end's thread computes them
      const std::size_t off = static_cast<std::size_t>(axis) * n;
      const std::uint32_t b = v.below[off + a];
      if (b == Model::kNoLink || !v.intact[off + b]) continue;
      const Lane::LinkTerms k = Lane::link_terms(v, axis, b, Lane::Far{static_cast<std::uint32_t>(a), 1.0f, false, 0}, true);
      Lane::take(v, g, true, true, k.force, k.torque, k.trace, 0.5f * k.r0, [&] { return k.n; });
    }
    for (int axis = 0; axis < 3; ++axis) {  // its own
      const std::size_t l = static_cast<std::size_t>(axis) * n + a;
      if (!v.intact[l]) {
        next.utx[l] = v.utx[l];
        next.uty[l] = v.uty[l];
        next.utz[l] = v.utz[l];
        if (v.softening) next.damage[l] = v.damage[l];
        continue;
      }
      const Lane::LinkTerms k = Lane::link_terms(v, axis, a, Lane::far_ends(v, axis, a), true);
      next.utx[l] = k.ut.x;
      next.uty[l] = k.ut.y;
      next.utz[l] = k.ut.z;
      if (v.softening) next.damage[l] = k.damage;
      if (k.broke) breaks.add(static_cast<std::uint32_t>(l) | (k.by_displacement ? 0u : cpu::kBreakByStress));
      Lane::take(v, g, true, false, k.force, k.torque, k.trace, 0.5f * k.r0, [&] { return k.n; });
    }
    cpu::AutomataResult r;
    Lane::move(v, a, g, next, r);
    if (touch.np) touch.count(a, touch_count, touches, list);
    return {r.max_move2, r.first_bad >= 0 ? static_cast<std::uint32_t>(a) : kNone};
  }
};
// Grip g sums the forces its automata put on it, in member order (the CPU's).
struct GripKernel {
  const std::uint32_t *first, *members;
  Vec3* ext_f;
  Vec3* force;
  double* work;
  const DVec3* velocity;
  float dt;
  MCA_HD void operator()(std::size_t g) const {
    Vec3 f;
    for (std::uint32_t k = first[g]; k < first[g + 1]; ++k) {
      const std::uint32_t a = members[k];
      f -= ext_f[a];
      ext_f[a] = Vec3{};
    }
    force[g] = f;
    work[g] += dot(to_dvec3(f), velocity[g]) * dt;
  }
};

// --- Compaction ---
struct CompactKernel {
  const std::uint32_t* flag;
  const std::uint32_t* place;
  std::uint32_t* out;
  MCA_HD void operator()(std::size_t k) const {
    if (flag[k]) out[place[k]] = static_cast<std::uint32_t>(k);
  }
};

// --- Breaks ---
struct LinkEnds {
  std::size_t n = 0, lattice_slots = 0;
  const std::uint32_t *neighbour = nullptr, *ei = nullptr, *ej = nullptr;
  MCA_HD std::uint32_t i(std::uint32_t l) const {
    return l >= lattice_slots ? ei[l - lattice_slots] : static_cast<std::uint32_t>(l % n);
  }
  MCA_HD std::uint32_t j(std::uint32_t l) const { return l >= lattice_slots ? ej[l - lattice_slots] : neighbour[l]; }
};
// Breaks link codes[k]: no longer intact, its displacement and bending state cleared, and, unless it left
// its ends' counts when first damaged, one sound link less at each end (lost, applied by LoseLinksKernel).
struct BreakKernel {
  const std::uint32_t* codes;
  LinkEnds ends;
  std::uint8_t* intact;
  std::uint8_t* unsound;  // null without softening
  float *utx, *uty, *utz;
  float *mx, *my, *mz;  // explicit links' bending state
  std::uint32_t* lost;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t l = codes[k] & ~cpu::kBreakByStress;
    intact[l] = 0;
    if (!unsound || !unsound[l]) {
      count_up(lost + ends.i(l));
      count_up(lost + ends.j(l));
      if (unsound) unsound[l] = 1;
    }
    utx[l] = uty[l] = utz[l] = 0.0f;
    if (l >= ends.lattice_slots) {
      const std::size_t x = l - ends.lattice_slots;
      mx[x] = my[x] = mz[x] = 0.0f;
    }
  }
};
// A link damaged in this step leaves its ends' counts of sound links (CpuBackend::expose_damaged).
struct ExposeDamagedKernel {
  LinkEnds ends;
  const float* damage;
  std::uint8_t* unsound;
  std::uint32_t* lost;
  MCA_HD void operator()(std::size_t l) const {
    if (unsound[l] || !(damage[l] > 0)) return;
    unsound[l] = 1;
    count_up(lost + ends.i(static_cast<std::uint32_t>(l)));
    count_up(lost + ends.j(static_cast<std::uint32_t>(l)));
  }
};
// Automaton a lost `lost` sound links: boxed in before (count 6), its move since the rebuild counts for the
// contact list's staleness; the count falls, not below 0 (CpuBackend::lose_link, once per link: the same).
// It gives its move to the largest (Dev::launch_reduce).
struct LoseLinksKernel {
  std::uint32_t* lost;
  std::uint8_t* count;
  const double *px, *py, *pz, *ref;
  MCA_HD Reduced operator()(std::size_t a) const {
    Reduced out;
    const std::uint32_t k = lost[a];
    if (k == 0) return out;
    lost[a] = 0;
    const std::uint8_t c = count[a];
    if (c == 6) {
      const double* r = ref + cpu::tile_index(a, cpu::kRefRows);
      const Vec3 d{static_cast<float>(px[a] - r[0]), static_cast<float>(py[a] - r[cpu::kTile]),
                   static_cast<float>(pz[a] - r[2 * cpu::kTile])};
      out.max = dot(d, d);
    }
    count[a] = static_cast<std::uint8_t>(c > k ? c - k : 0u);
    return out;
  }
};
// Whether automaton a is within reach of the ground (CpuBackend::near_ground).
struct GroundReach {
  const double *px, *py, *pz;
  const float* radius;
  Vec3 up;
  double height;
  float skin;
  MCA_HD bool near(std::uint32_t a) const {
    const double above = px[a] * up.x + py[a] * up.y + pz[a] * up.z - height;
    return above < static_cast<double>(radius[a]) + skin;
  }
};
// The pairs of the broken links (code[k]) as sort keys (i, j) -> i 2^32 + j, for the contact list.
struct BrokenPairKeysKernel {
  const std::uint32_t* code;
  LinkEnds ends;
  std::uint64_t* key;
  std::uint32_t* value;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t l = code[k] & ~cpu::kBreakByStress;
    key[k] = static_cast<std::uint64_t>(ends.i(l)) << 32 | ends.j(l);
    value[k] = static_cast<std::uint32_t>(k);
  }
};
// Both ends of the broken links (code[k]), for the ground list.
struct BrokenEndsKernel {
  const std::uint32_t* code;
  LinkEnds ends;
  std::uint32_t *automata, *value;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t l = code[k] & ~cpu::kBreakByStress;
    automata[2 * k] = ends.i(l);
    automata[2 * k + 1] = ends.j(l);
    value[2 * k] = static_cast<std::uint32_t>(2 * k);
    value[2 * k + 1] = static_cast<std::uint32_t>(2 * k + 1);
  }
};
// A step's breaks, one thread each: the code kept for the records, the link cleared (BreakKernel), its
// pair's key for the contact list, and where there is ground, its two ends for the ground list.
struct BreaksKernel {
  std::uint32_t* log;
  BreakKernel clear;
  BrokenPairKeysKernel pair;
  BrokenEndsKernel ends;  // automata null: no ground
  MCA_HD void operator()(std::size_t k) const {
    log[k] = clear.codes[k];
    clear(k);
    pair(k);
    if (ends.automata) ends(k);
  }
};

// --- Sorted lists ---
MCA_HD bool pair_less(std::uint32_t ai, std::uint32_t aj, std::uint32_t bi, std::uint32_t bj) {
  return ai != bi ? ai < bi : aj < bj;
}
// The number of leading entries k < size of a sorted list for which before(k) holds (a binary search: before
// holds for a prefix of the list).
template <class Before>
MCA_HD std::uint32_t count_before(std::uint32_t size, const Before& before) {
  std::uint32_t lo = 0, hi = size;
  while (lo < hi) {
    const std::uint32_t mid = lo + (hi - lo) / 2;
    if (before(mid)) lo = mid + 1;
    else hi = mid;
  }
  return lo;
}
// The entries of a sorted list less than (i, j) (or not greater, with `or_equal`).
MCA_HD std::uint32_t pairs_before(const ContactPair* list, std::uint32_t size, std::uint32_t i, std::uint32_t j,
                                  bool or_equal) {
  return count_before(size, [&](std::uint32_t k) {
    return pair_less(list[k].i, list[k].j, i, j) || (or_equal && list[k].i == i && list[k].j == j);
  });
}
MCA_HD std::uint32_t automata_before(const BodyContact* list, std::uint32_t size, std::uint32_t a) {
  return count_before(size, [&](std::uint32_t k) { return list[k].automaton < a; });
}
// The pair contacts (threads [0, pairs.size): ContactGatherKernel's) and the ground contacts (the rest: one
// per entry of the ground list, `ground_size` of them) onto their automata in one launch, each automaton's
// pair contacts first, then its ground contact (the CPU's order): by the thread of its first incidence entry
// where it has pair contacts, else by its ground entry's thread.
struct ContactsOntoAutomataKernel {
  ContactGatherKernel pairs;
  GroundKernel ground;
  std::uint32_t ground_size;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t* key = pairs.key;
    if (k < pairs.size) {
      if (k > 0 && key[k - 1] == key[k]) return;
      pairs(k);
      const std::uint32_t a = key[k], g = automata_before(ground.list, ground_size, a);
      if (g < ground_size && ground.list[g].automaton == a) ground(g);
    } else {
      const std::uint32_t g = static_cast<std::uint32_t>(k - pairs.size), a = ground.list[g].automaton;
      const std::uint32_t e = count_before(pairs.size, [&](std::uint32_t m) { return key[m] < a; });
      if (e == pairs.size || key[e] != a) ground(g);
    }
  }
};
// The step's broken pairs (keys i << 32 | j, sorted) merged into the sorted contact list a (std::merge: a's
// entries first where equal), each fresh pair with no history, one element per thread: threads [0, na)
// place list a, [na, na + nb) the fresh pairs. A fresh pair's thread also gives its two incidence entries
// (automaton, 2 q + side; in fresh order, so sorted by automaton they keep the order of q) for
// MergeIncidenceKernel (inc_key null: not wanted).
struct MergeFreshPairsKernel {
  const ContactPair* a;
  const std::uint64_t* b;
  std::uint32_t na, nb;
  ContactPair* out;
  std::uint32_t *inc_key, *inc_value;
  // Fresh pair m, (i, j) at index q of the merged list: its two incidence entries.
  MCA_HD static void incidence(std::uint32_t m, std::uint32_t i, std::uint32_t j, std::uint32_t q, std::uint32_t* key,
                               std::uint32_t* value) {
    key[2 * m] = i;
    value[2 * m] = 2 * q;
    key[2 * m + 1] = j;
    value[2 * m + 1] = 2 * q + 1;
  }
  MCA_HD void operator()(std::size_t k) const {
    if (k < na) {
      const std::uint64_t key = static_cast<std::uint64_t>(a[k].i) << 32 | a[k].j;
      const std::uint32_t q = static_cast<std::uint32_t>(k) + count_before(nb, [&](std::uint32_t m) { return b[m] < key; });
      out[q] = a[k];
    } else {
      const std::uint32_t m = static_cast<std::uint32_t>(k - na);
      const std::uint32_t i = static_cast<std::uint32_t>(b[m] >> 32), j = static_cast<std::uint32_t>(b[m]);
      const std::uint32_t q = m + pairs_before(a, na, i, j, true);
      out[q] = {i, j, {}};
      if (inc_key) incidence(m, i, j, q, inc_key, inc_value);
    }
  }
};
// The incidence list after MergeFreshPairsKernel's merge, without sorting it again: the old entries
// (automaton, 2 p + side), sorted, each p renamed to its new index (moved_to only grows, so they stay
// sorted), merged with the fresh pairs' entries (sorted by automaton, stably). Each entry goes to its index
// plus the number of the other list's entries before it; no two entries name the same pair side, so there
// are no ties. The list comes out as IncidenceKeysKernel and a stable sort by automaton make it of the merged
// pairs.
struct MergeIncidenceKernel {
  const std::uint32_t *key, *value;
  std::uint32_t e;
  const std::uint32_t *fresh_key, *fresh_value;
  std::uint32_t f;
  std::uint32_t *out_key, *out_value;
  const ContactPair* pairs;        // the old contact list
  const std::uint64_t* fresh_pairs;  // the fresh pairs' keys, sorted
  std::uint32_t fresh_pair_count;
  MCA_HD static bool less(std::uint32_t a, std::uint32_t v, std::uint32_t b, std::uint32_t w) {
    return a != b ? a < b : v < w;
  }
  // Old pair p's new index, counted as MergeFreshPairsKernel counts it (so that this need not follow its
  // launch).
  MCA_HD std::uint32_t moved_to(std::uint32_t p) const {
    const std::uint64_t k = static_cast<std::uint64_t>(pairs[p].i) << 32 | pairs[p].j;
    return p + count_before(fresh_pair_count, [&](std::uint32_t m) { return fresh_pairs[m] < k; });
  }
  MCA_HD std::uint32_t renamed(std::uint32_t x) const { return 2 * moved_to(value[x] >> 1) + (value[x] & 1u); }
  MCA_HD void operator()(std::size_t k) const {
    std::uint32_t a, v, place;
    if (k < e) {
      const auto x = static_cast<std::uint32_t>(k);
      a = key[x];
      v = renamed(x);
      place = x + count_before(f, [&](std::uint32_t y) { return less(fresh_key[y], fresh_value[y], a, v); });
    } else {
      const auto y = static_cast<std::uint32_t>(k - e);
      a = fresh_key[y];
      v = fresh_value[y];
      // The old entries before it: those of automata below a (by key alone), then those of a's run renamed
      // below v (in order: renaming keeps it).
      std::uint32_t x = count_before(e, [&](std::uint32_t m) { return key[m] < a; });
      while (x < e && key[x] == a && renamed(x) < v) ++x;
      place = y + x;
    }
    out_key[place] = a;
    out_value[place] = v;
  }
};
// std::merge of two sorted body lists (a's entries first where equal), one element per thread: threads
// [0, na) place list a, the next ones list b, whose size is on the device (*nb, at most those threads).
struct MergeBodiesKernel {
  const BodyContact *a, *b;
  std::uint32_t na;
  const std::uint32_t* nb;
  BodyContact* out;
  MCA_HD void operator()(std::size_t k) const {
    if (k < na) {
      out[k + automata_before(b, *nb, a[k].automaton)] = a[k];
    } else if (const std::size_t m = k - na; m < *nb) {
      out[m + automata_before(a, na, b[m].automaton + 1)] = b[m];  // after a's entries <= it
    }
  }
};
// In the sorted ends of the broken links: flag[k] = 1 where automata[k] is its first entry, near the
// ground and not yet in the ground list (CpuBackend::apply_breaks); their number adds to *count.
struct GroundJoinFlagKernel {
  GroundReach g;
  const std::uint32_t* automata;
  const BodyContact* listed;
  std::uint32_t size;
  std::uint32_t* flag;
  std::uint32_t* count;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t a = automata[k];
    flag[k] = 0;
    if ((k > 0 && automata[k - 1] == a) || !g.near(a)) return;
    const std::uint32_t p = automata_before(listed, size, a);
    if (p < size && listed[p].automaton == a) return;
    flag[k] = 1;
    count_up(count);
  }
};
struct GroundJoinWriteKernel {
  const std::uint32_t *automata, *flag, *place;
  BodyContact* out;
  MCA_HD void operator()(std::size_t k) const {
    if (flag[k]) out[place[k]] = {automata[k], {}};
  }
};

// The place of element k among keys[0 .. n - 1] in their stable sort: the keys less than its own, and the
// equal ones before it (a block's sort of a few hundred elements, SmallBreaksKernel, without a sort's
// launches; the same order as Dev::stable_sort_by_key).
template <class T>
MCA_HD std::uint32_t stable_rank(const T* keys, std::uint32_t n, std::uint32_t k) {
  const T key = keys[k];
  std::uint32_t r = 0;
  for (std::uint32_t m = 0; m < n; ++m) r += keys[m] < key || (keys[m] == key && m < k) ? 1u : 0u;
  return r;
}

// A step's breaks where they are few (at most kSmallBreaks), in one block, as phases: what BreaksKernel,
// the sorts of the broken pairs' keys and of their ends, the fresh pairs' incidence entries
// (MergeFreshPairsKernel's) and their sort, GroundJoinFlagKernel, the scan, GroundJoinWriteKernel and
// LoseLinksKernel do in ten launches or more, each element's place in a sort or scan counted (stable_rank)
// instead. The merges into the long lists follow (MergeBreaksKernel). Both read the number of breaks from
// the device (the step's status), so they can be launched before the host has read it; they do nothing
// where there are none or more than kSmallBreaks.
inline constexpr std::uint32_t kSmallBreaks = 256;
MCA_HD std::uint32_t small_breaks(const std::uint32_t* breaks) { return *breaks <= kSmallBreaks ? *breaks : 0u; }
struct SmallBreaksKernel {
  static constexpr int kPhases = 5;
  BreaksKernel breaks;  // its pair keys and ends (always) into the raw arrays below, in break order
  const std::uint32_t* count;  // the step's breaks (StepStatus::breaks)
  const std::uint64_t* raw_key;
  std::uint64_t* key;  // the broken pairs' keys, sorted
  const std::uint32_t* raw_end;
  std::uint32_t* end;  // their ends, sorted
  const ContactPair* contacts;  // the contact list before the merge
  std::uint32_t pairs;
  std::uint32_t *raw_inc_key, *raw_inc_value, *inc_key, *inc_value;  // the fresh incidence entries, sorted
  GroundJoinFlagKernel join;  // (join.flag null: no ground)
  std::uint32_t* place;       // the flags' exclusive scan, 2 nb + 1 entries
  GroundJoinWriteKernel write;
  LoseLinksKernel lose;
  float* move2_lost;
  MCA_HD std::size_t size(int phase) const {
    const std::size_t b = small_breaks(count), e = 2 * b;
    if (b == 0) return 0;
    switch (phase) {
      case 0: return b;
      case 1: return b + e;
      case 2: return e + b;
      case 3: return e + 1 + e;
      default: return join.flag ? e : 0;
    }
  }
  MCA_HD void operator()(int phase, std::size_t i) const {
    const std::uint32_t nb = small_breaks(count), e = 2 * nb, k = static_cast<std::uint32_t>(i);
    if (phase == 0) {
      breaks(k);
    } else if (phase == 1) {
      if (k < nb) key[stable_rank(raw_key, nb, k)] = raw_key[k];
      else end[stable_rank(raw_end, e, k - nb)] = raw_end[k - nb];
    } else if (phase == 2) {
      if (k < e) {
        if (join.flag) join(k);
        if (k == 0 || end[k - 1] != end[k]) max_up(move2_lost, lose(end[k]).max);  // once per automaton
      } else {
        const std::uint32_t m = k - e, a = static_cast<std::uint32_t>(key[m] >> 32), b = static_cast<std::uint32_t>(key[m]);
        MergeFreshPairsKernel::incidence(m, a, b, m + pairs_before(contacts, pairs, a, b, true), raw_inc_key, raw_inc_value);
      }
    } else if (phase == 3) {
      if (k <= e) {
        if (!join.flag) return;
        std::uint32_t c = 0;
        for (std::uint32_t m = 0; m < k; ++m) c += join.flag[m];
        place[k] = c;
      } else {
        const std::uint32_t y = k - e - 1, r = stable_rank(raw_inc_key, e, y);
        inc_key[r] = raw_inc_key[y];
        inc_value[r] = raw_inc_value[y];
      }
    } else {
      write(k);
    }
  }
};
// After SmallBreaksKernel, in one launch: the broken pairs merged into the contact list (threads [0,
// pair_threads): the old list's, then at most kSmallBreaks fresh ones), their ends near the ground into the
// ground list (the next ground_threads; its fresh entries' number: the status's ground joins), and the fresh
// pairs' incidence entries into the incidence list (the rest: the old list's, then two per break; each old
// pair's new index counted by its own threads, MergeIncidenceKernel's moved_to).
struct MergeBreaksKernel {
  const std::uint32_t* count;   // the step's breaks
  MergeFreshPairsKernel pairs;  // (nb: the count; its incidence entries: SmallBreaksKernel's)
  std::size_t pair_threads;
  MergeBodiesKernel ground;
  std::size_t ground_threads;
  MergeIncidenceKernel incidence;  // (f, fresh_pair_count: from the count)
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t nb = small_breaks(count);
    if (nb == 0) return;
    if (k < pair_threads) {
      MergeFreshPairsKernel p = pairs;
      p.nb = nb;
      if (k < p.na + p.nb) p(k);
    } else if (k < pair_threads + ground_threads) {
      ground(k - pair_threads);
    } else {
      MergeIncidenceKernel m = incidence;
      m.f = 2 * nb;
      m.fresh_pair_count = nb;
      k -= pair_threads + ground_threads;
      if (k < m.e + m.f) m(k);
    }
  }
};

// --- Contact list rebuild ---
// Exposed automata: fewer than 6 sound links (CpuBackend::rebuild_contacts).
struct ExposedFlagKernel {
  const std::uint8_t* count;
  std::uint32_t* flag;
  MCA_HD void operator()(std::size_t a) const { flag[a] = count[a] < 6 ? 1u : 0u; }
};
// The uniform grid of the search: cells of side h, hashed into 2^bits buckets.
struct HashGrid {
  double inv_h = 0;
  std::uint64_t mask = 0;
  MCA_HD std::int64_t cell(double x) const { return grid_cell(x, inv_h); }  // (clamped, as the CPU's grid)
  MCA_HD std::uint64_t bucket(std::int64_t x, std::int64_t y, std::int64_t z) const {
    const std::uint64_t h = static_cast<std::uint64_t>(x) * 73856093ull ^ static_cast<std::uint64_t>(y) * 19349663ull ^
                            static_cast<std::uint64_t>(z) * 83492791ull;
    return (h ^ (h >> 29)) & mask;
  }
};
struct GridKeysKernel {
  HashGrid grid;
  const std::uint32_t* exposed;
  const double *px, *py, *pz;
  std::uint64_t* key;
  std::uint32_t* value;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t a = exposed[k];
    key[k] = grid.bucket(grid.cell(px[a]), grid.cell(py[a]), grid.cell(pz[a]));
    value[k] = a;
  }
};
struct BucketRangeKernel {
  const std::uint64_t* key;
  std::size_t n;
  std::uint32_t *begin, *end;
  MCA_HD void operator()(std::size_t k) const {
    if (k == 0 || key[k] != key[k - 1]) begin[key[k]] = static_cast<std::uint32_t>(k);
    if (k + 1 == n || key[k] != key[k + 1]) end[key[k]] = static_cast<std::uint32_t>(k + 1);
  }
};
// Whether automata i and j are joined by an intact link (CpuBackend::linked).
struct Linked {
  std::size_t n;
  const std::uint32_t *neighbour, *below;
  const std::uint8_t* intact;
  const std::uint32_t *first, *of, *ei, *ej;  // first null: no explicit links
  MCA_HD bool operator()(std::uint32_t i, std::uint32_t j) const {
    for (int axis = 0; axis < 3; ++axis) {
      const std::size_t up = axis * n + i;
      if (neighbour[up] == j && intact[up]) return true;
      if (below[up] == j && intact[axis * n + j]) return true;
    }
    if (first)
      for (std::uint32_t k = first[i]; k < first[i + 1]; ++k) {
        const std::uint32_t l = of[k];
        if ((ei[l] == j || ej[l] == j) && intact[3 * n + l]) return true;
      }
    return false;
  }
};
// The candidates of exposed automaton k (the CPU's search: the grid's points above it within r_i + r_j +
// skin and not linked, and a random-lattice automaton's broken links within their rest length + skin):
// counted (out null) or written to out + offset[k], then sorted and made unique; count[k] is their number.
struct CandidatesKernel {
  HashGrid grid;
  const std::uint32_t* exposed;
  const std::uint32_t *sorted, *begin, *end;  // the grid: exposed automata by bucket
  const double *px, *py, *pz;
  const float* radius;
  float skin;
  Linked linked;
  ModelView m;
  const double* r0;  // explicit links' rest lengths
  const std::uint32_t* offset;
  std::uint32_t* out;
  std::uint32_t* count;
  const float *qw, *qx, *qy, *qz;  // orientations (sites of faces: m.face)
  int face_cells;                  // face_search_cells
  double face_reach;               // face_search_reach
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t i = exposed[k];
    const DVec3 xi{px[i], py[i], pz[i]};
    std::uint32_t c = 0;
    auto take = [&](std::uint32_t j) {
      if (out) out[offset[k] + c] = j;
      ++c;
    };
    const std::int64_t cx = grid.cell(xi.x), cy = grid.cell(xi.y), cz = grid.cell(xi.z);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const std::uint64_t b = grid.bucket(cx + dx, cy + dy, cz + dz);
          // (Two cells may share a bucket: its points are taken twice, and made unique below.)
          for (std::uint32_t e = begin[b]; e < end[b]; ++e) {
            const std::uint32_t j = sorted[e];
            if (j <= i) continue;
            const Vec3 d = delta(xi, DVec3{px[j], py[j], pz[j]});
            const float reach = radius[i] + radius[j] + skin;
            if (dot(d, d) < reach * reach && !linked(i, j)) take(j);
          }
        }
    // An automaton with free sides: the sites of others that may come to touch it as faces (face_candidate).
    if (m.face && m.face[i]) {
      const Quat qi{qw[i], qx[i], qy[i], qz[i]};
      // (The cells beyond the reach hold none: skipped, as UniformGrid::for_each_near_above.)
      for_each_cell_within(grid_fraction(xi.x, grid.inv_h), grid_fraction(xi.y, grid.inv_h), grid_fraction(xi.z, grid.inv_h),
                           face_cells, face_reach, [&](int dx, int dy, int dz) {
                             const std::uint64_t b = grid.bucket(cx + dx, cy + dy, cz + dz);
                             for (std::uint32_t e = begin[b]; e < end[b]; ++e) {
                               const std::uint32_t j = sorted[e];
                               if (j <= i) continue;
                               if (m.face_candidate(i, j, delta(xi, DVec3{px[j], py[j], pz[j]}), qi,
                                                    Quat{qw[j], qx[j], qy[j], qz[j]}, skin) &&
                                   !linked(i, j))
                                 take(j);
                             }
                           });
    }
    // A random-lattice automaton's broken links: their pairs reach their initial distance
    // (Model::contact_reach), up to 2.2 d, beyond the grid's cells of r_i + r_j + skin.
    if (m.random_automaton(i) && m.first) {
      for (std::uint32_t x = m.first[i]; x < m.first[i + 1]; ++x) {
        const std::uint32_t l = m.of[x], j = m.ei[l] == i ? m.ej[l] : m.ei[l];
        if (j <= i || linked.intact[3 * m.n + l]) continue;
        const Vec3 d = delta(xi, DVec3{px[j], py[j], pz[j]});
        const float reach = static_cast<float>(r0[l]) + skin;
        if (dot(d, d) < reach * reach) take(j);
      }
    }
    if (out) {
      // Sort (insertion: a handful) and drop repeats.
      std::uint32_t* js = out + offset[k];
      for (std::uint32_t x = 1; x < c; ++x) {
        const std::uint32_t v = js[x];
        std::uint32_t y = x;
        for (; y > 0 && js[y - 1] > v; --y) js[y] = js[y - 1];
        js[y] = v;
      }
      std::uint32_t u = 0;
      for (std::uint32_t x = 0; x < c; ++x)
        if (u == 0 || js[x] != js[u - 1]) js[u++] = js[x];
      c = u;
    }
    count[k] = c;
  }
};
// The new list's pairs of exposed automaton k, with the histories of the pairs the old list held.
struct WritePairsKernel {
  const std::uint32_t *exposed, *raw, *raw_offset, *count, *place;
  const ContactPair* old;
  std::uint32_t old_size;
  ContactPair* out;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t i = exposed[k];
    for (std::uint32_t x = 0; x < count[k]; ++x) {
      const std::uint32_t j = raw[raw_offset[k] + x];
      ContactPair c{i, j, {}};
      const std::uint32_t p = pairs_before(old, old_size, i, j, false);
      if (p < old_size && old[p].i == i && old[p].j == j) c = old[p];  // (its history and way of touching)
      out[place[k] + x] = c;
    }
  }
};
struct NearGroundFlagKernel {
  GroundReach g;
  const std::uint32_t* exposed;
  std::uint32_t* flag;
  MCA_HD void operator()(std::size_t k) const { flag[k] = g.near(exposed[k]) ? 1u : 0u; }
};
struct WriteGroundKernel {
  const std::uint32_t *exposed, *flag, *place;
  const BodyContact* old;
  std::uint32_t old_size;
  BodyContact* out;
  MCA_HD void operator()(std::size_t k) const {
    if (!flag[k]) return;
    const std::uint32_t a = exposed[k];
    BodyContact c{a, {}};
    const std::uint32_t p = automata_before(old, old_size, a);
    if (p < old_size && old[p].automaton == a) c.h = old[p].h;
    out[place[k]] = c;
  }
};
// The positions at this rebuild (LatticeView::ref, tiled).
struct ReferenceKernel {
  const double *px, *py, *pz;
  double* ref;
  MCA_HD void operator()(std::size_t a) const {
    double* r = ref + cpu::tile_index(a, cpu::kRefRows);
    r[0] = px[a];
    r[cpu::kTile] = py[a];
    r[2 * cpu::kTile] = pz[a];
  }
};

// --- Projectiles ---
// The projectiles' pair contacts: their springs from the materials' table and the pair's damping ratio, as
// Model::projectile_pair_contact and the CPU's projectile pass form them (nothing held per pair).
struct ProjectilePairs {
  const ProjectileConstants* P;
  std::uint32_t np;
  const ContactMaterial* contact;  // per pair of groups (Model::contact)
  std::size_t groups;
  const float* zeta;  // Model::zeta_projectiles
  // Model::projectile_pair_contact.
  MCA_HD ContactMaterial material(std::uint32_t p, std::uint32_t q) const {
    const ProjectileConstants &A = P[p], &B = P[q];
    ContactMaterial c = contact[static_cast<std::size_t>(A.group) * groups + static_cast<std::size_t>(B.group)];
    c.rolling = 0.5f * (A.rolling + B.rolling);
    c.twisting = 0.5f * (A.twisting + B.twisting);
    return c;
  }
  MCA_HD ContactSprings springs(std::uint32_t p, std::uint32_t q) const {
    const ProjectileConstants &A = P[p], &B = P[q];
    return body_contact_springs(material(p, q), zeta[static_cast<std::size_t>(p) * np + q], A.radius, B.radius,
                                contact_reduced(A.mass, A.kinematic, B.mass, B.kinematic),
                                contact_reduced(A.inertia, A.kinematic, B.inertia, B.kinematic));
  }
  // Whether p and q touch and one of them can respond (the CPU's test), and where.
  MCA_HD SphereGap touch(const DeviceProjectile* proj, std::uint32_t p, std::uint32_t q) const {
    if (P[p].kinematic && P[q].kinematic) return SphereGap{};  // neither can respond
    const SphereGap gap = sphere_gap(proj[p].position, proj[q].position, static_cast<double>(P[p].radius) + P[q].radius);
    return gap.overlap <= 0.0f || !gap.valid ? SphereGap{} : gap;
  }
};
// The projectile pairs in contact (the CPU's pass over all pairs (p, q), p < q, in order), one thread per
// projectile p: at the end of a step, count[p] of its pairs (q > p) touch, and their number adds to *total
// (the next step's pair list's size: its pair pass tests the same positions); at the next step's start,
// write them at offset[p], in q order.
struct ProjectilePairCountKernel {
  const DeviceProjectile* proj;
  ProjectilePairs pairs;
  std::uint32_t* count;
  std::uint32_t* total;
  MCA_HD void operator()(std::size_t p) const {
    std::uint32_t c = 0;
    for (std::uint32_t q = static_cast<std::uint32_t>(p) + 1; q < pairs.np; ++q)
      c += pairs.touch(proj, static_cast<std::uint32_t>(p), q).valid ? 1u : 0u;
    count[p] = c;
    if (c) count_add(total, c);
  }
};
struct ProjectilePairWriteKernel {
  const DeviceProjectile* proj;
  ProjectilePairs pairs;
  const std::uint32_t* offset;
  ProjectilePair* out;
  MCA_HD void operator()(std::size_t p) const {
    std::uint32_t k = offset[p];
    for (std::uint32_t q = static_cast<std::uint32_t>(p) + 1; q < pairs.np; ++q)
      if (pairs.touch(proj, static_cast<std::uint32_t>(p), q).valid) out[k++] = {static_cast<std::uint32_t>(p), q, {}};
  }
};
// Touching pair k: its contact, from the history the previous list (sorted by (p, q)) held for it.
struct ProjectilePairContactKernel {
  const DeviceProjectile* proj;
  ProjectilePairs pairs;
  const ProjectilePair* old;
  std::uint32_t old_size;
  ProjectilePair* list;  // the pairs in order; their histories are written here
  ContactOut* out;       // force on p, torques on p and q
  float dt;
  MCA_HD void operator()(std::size_t k) const {
    const std::uint32_t p = list[k].p, q = list[k].q;
    const ProjectileConstants &A = pairs.P[p], &B = pairs.P[q];
    const std::uint32_t o = count_before(old_size, [&](std::uint32_t x) { return pair_less(old[x].p, old[x].q, p, q); });
    const ContactHistory prev = o < old_size && old[o].p == p && old[o].q == q ? old[o].h : ContactHistory{};
    const SphereGap gap = pairs.touch(proj, p, q);
    const DeviceProjectile &a = proj[p], &b = proj[q];
    const Vec3 nrm = gap.n;
    const ContactResult r = contact_between(nrm, gap.overlap, a.velocity, a.angular_velocity, A.radius * nrm, b.velocity,
                                            b.angular_velocity, -B.radius * nrm, pairs.springs(p, q), prev.ut, prev.mr, dt);
    list[k].h = {r.o.ut, r.o.mr};
    out[k] = {r.o.force_i, r.torque_i, r.torque_j, nrm, 0.0f, 0.0f, true};
  }
};

struct TouchCountKernel {
  Touch touch;
  std::uint32_t* count;
  std::uint32_t* total;
  MCA_HD void operator()(std::size_t a) const { touch.count(a, count, total); }
};
// Automaton a's entries (a, p) of the candidates in (automaton, projectile) order, from offset[a].
struct TouchWriteKernel {
  Touch touch;
  const std::uint32_t* offset;  // n + 1 entries
  std::uint32_t *automaton, *projectile;
  MCA_HD void operator()(std::size_t a) const {
    if (offset[a + 1] != offset[a]) touch.write(a, offset[a], automaton, projectile);
  }
};
// The candidates in (projectile, automaton) order, the CPU's: entry j is candidate order[j] (order null:
// one projectile, the same order). key[j] is its projectile (null: 0).
struct Candidates {
  const std::uint32_t *automaton, *projectile, *order, *key;
  std::uint32_t size;
  MCA_HD std::uint32_t at(std::uint32_t j) const { return order ? order[j] : j; }
  MCA_HD std::uint32_t projectile_of(std::uint32_t j) const { return key ? key[j] : 0u; }
};
// The sort's input: key[k] = the projectile of candidate k, order[k] = k; after the sort, where[order[j]] = j.
struct OrderKeysKernel {
  const std::uint32_t* projectile;
  std::uint32_t *key, *order;
  MCA_HD void operator()(std::size_t k) const {
    key[k] = projectile[k];
    order[k] = static_cast<std::uint32_t>(k);
  }
};
struct InvertKernel {
  const std::uint32_t* order;
  std::uint32_t* where;
  MCA_HD void operator()(std::size_t j) const { where[order[j]] = static_cast<std::uint32_t>(j); }
};
// Candidate j (in projectile order): its contact from its projectile's previous list (the lists of all
// projectiles in one array, projectile p's from start[p]); keep[j] = 1 where it stays in the list
// (touching, or a tangential spring still loaded), with its new history and what it adds to the automaton.
struct ProjectileContactKernel {
  const DeviceProjectile* proj;
  const ProjectileConstants* P;
  Candidates cand;
  const BodyContact* old;
  const std::uint32_t* start;  // np + 1 entries
  ContactPassView cv;
  const ContactMaterial* material;  // per projectile and group: projectile_contact(p, g)
  const float* zeta;                // per projectile and group
  const float* zeta_held;           // per projectile and group, with held automata (null: no grips)
  std::size_t groups;
  BodyContact* next;  // per candidate
  ContactOut* out;    // per candidate: force on the automaton, its torque, the projectile's
  std::uint32_t* keep;
  MCA_HD void operator()(std::size_t j) const {
    const std::uint32_t k = cand.at(static_cast<std::uint32_t>(j)), a = cand.automaton[k], p = cand.projectile[k];
    const DeviceProjectile& ps = proj[p];
    const ProjectileConstants& Pp = P[p];
    const BodyContact* list = old + start[p];
    const std::uint32_t size = start[p + 1] - start[p];
    const std::uint32_t o = automata_before(list, size, a);
    const ContactHistory prev = o < size && list[o].automaton == a ? list[o].h : ContactHistory{};
    keep[j] = 0;
    const float ra = cv.m.radius[a];
    const SphereGap gap = sphere_gap(cv.pos(a), ps.position, static_cast<double>(Pp.radius) + ra);
    if (!gap.valid) return;
    const Vec3 nrm = gap.n;
    const std::size_t g = static_cast<std::size_t>(p) * groups + cv.m.group[a];
    const ContactSprings springs = projectile_contact_springs(cv.m, a, material[g], zeta[g],
                                                              zeta_held ? zeta_held[g] : 0.0f, Pp.radius, Pp.mass,
                                                              Pp.inertia, Pp.kinematic);
    const ContactResult r = contact_between(nrm, gap.overlap, cv.vel(a), cv.ang(a), ra * nrm, ps.velocity,
                                            ps.angular_velocity, -Pp.radius * nrm, springs, prev.ut, prev.mr, cv.dt);
    if (r.o.fn <= 0.0f && length(r.o.ut) == 0.0f) return;
    keep[j] = 1;
    next[j] = {a, {r.o.ut, r.o.mr}};
    out[j] = {r.o.force_i, r.torque_i, r.torque_j, nrm, ra, 0.0f, true};
  }
};
// The kept contacts into the projectiles' new lists (place: the scan of keep).
struct ProjectileCommitKernel {
  const std::uint32_t *keep, *place;
  const BodyContact* next;
  BodyContact* list;
  MCA_HD void operator()(std::size_t j) const {
    if (keep[j]) list[place[j]] = next[j];
  }
};
// For q = 0 .. np: segment[q], the first candidate of projectile q or later, and start[q], where its new list
// starts.
struct ProjectileSegmentKernel {
  Candidates cand;
  const std::uint32_t* place;  // size + 1 entries
  std::uint32_t *segment, *start;
  MCA_HD void operator()(std::size_t q) const {
    const std::uint32_t first = count_before(cand.size, [&](std::uint32_t j) { return cand.projectile_of(j) < q; });
    segment[q] = first;
    start[q] = cand.size ? place[first] : 0;
  }
};
// Each automaton adds its kept projectile contacts in projectile order (the CPU's): the first thread of its
// run of the candidates in (automaton, projectile) order does it.
struct ProjectileExternalKernel {
  Candidates cand;
  const std::uint32_t* where;  // candidate k's place in projectile order (null: k)
  const std::uint32_t* keep;
  const ContactOut* out;
  External ext;
  MCA_HD void operator()(std::size_t k0) const {
    const std::uint32_t* a = cand.automaton;
    if (k0 > 0 && a[k0 - 1] == a[k0]) return;
    for (std::size_t k = k0; k < cand.size && a[k] == a[k0]; ++k) {
      const std::uint32_t j = where ? where[k] : static_cast<std::uint32_t>(k);
      if (!keep[j]) continue;
      const ContactOut& o = out[j];
      ext.add(a[k], o.f, o.ti, sym_outer(o.n, o.f, o.ri));
    }
  }
};
// Projectile p's sums over its kept contacts in list order, then its contact with the ground.
struct ProjectileSumKernel {
  DeviceProjectile* proj;
  const ProjectileConstants* P;
  const std::uint32_t *segment, *keep;
  const ContactOut* out;
  Vec3 *fsum, *tsum;
  bool ground;
  Vec3 up;
  double ground_height;
  float dt;
  MCA_HD void operator()(std::size_t p) const {
    DeviceProjectile& ps = proj[p];
    const ProjectileConstants& Pp = P[p];
    Vec3 f, t;
    for (std::uint32_t j = segment[p]; j < segment[p + 1]; ++j) {
      if (!keep[j]) continue;
      f -= out[j].f;
      t += out[j].tj;
    }
    if (ground) {
      // The ground, as for an automaton: the projectile is the first body.
      const Vec3 nrm = -up;
      const ContactResult r = contact_between(nrm, ground_overlap(ps.position, up, ground_height, Pp.radius), ps.velocity,
                                              ps.angular_velocity, Pp.radius * nrm, {}, {}, {}, Pp.ground_springs,
                                              ps.ground.ut, ps.ground.mr, dt);
      ps.ground = {r.o.ut, r.o.mr};
      f += r.o.force_i;
      t += r.torque_i;
    }
    fsum[p] = f;
    tsum[p] = t;
  }
};
// One thread: the touching pairs' sums in (p, q) order (the CPU's), and the projectiles' motion.
// bad[0]: the first projectile with a value not finite, or kNone.
struct ProjectileMotionKernel {
  DeviceProjectile* proj;
  const ProjectileConstants* P;
  std::uint32_t np;
  const ProjectilePair* list;
  const ContactOut* out;
  std::uint32_t pairs;
  std::uint32_t* list_size;
  Vec3 *fsum, *tsum;
  Vec3 gravity;
  float dt;
  std::uint32_t* bad;
  MCA_HD void operator()(std::size_t) const {
    for (std::uint32_t k = 0; k < pairs; ++k) {
      const std::uint32_t p = list[k].p, q = list[k].q;
      fsum[p] += out[k].f;
      fsum[q] -= out[k].f;
      tsum[p] += out[k].ti;
      tsum[q] += out[k].tj;
    }
    *list_size = pairs;
    *bad = kNone;
    for (std::uint32_t p = 0; p < np; ++p) {
      DeviceProjectile& ps = proj[p];
      ps.force = fsum[p];
      if (P[p].kinematic) {
        // Power the projectile puts in: minus that of the forces on it at its own velocities.
        ps.work -= (dot(to_dvec3(fsum[p]), ps.velocity) + dot(to_dvec3(tsum[p]), ps.angular_velocity)) * dt;
      } else {
        ps.velocity += (fsum[p] * (1.0f / P[p].mass) + gravity) * dt;
        ps.angular_velocity += tsum[p] * (dt / P[p].inertia);
        ps.orientation = integrate_projectile_orientation(ps.orientation, to_vec3(ps.angular_velocity), dt);
        if (!(projectile_turn(to_vec3(ps.angular_velocity), dt) <= kLargestProjectileTurn)) {
          *bad = p;  // (a turn its orientation does not follow; the step stops here, as the CPU's does)
          return;
        }
      }
      ps.position += ps.velocity * static_cast<double>(dt);
      const double x = ps.position.x + ps.position.y + ps.position.z;
      const double v = ps.velocity.x + ps.velocity.y + ps.velocity.z;
      const double w = ps.angular_velocity.x + ps.angular_velocity.y + ps.angular_velocity.z;
      const float q = ps.orientation.w + ps.orientation.x + ps.orientation.y + ps.orientation.z;
      if (!(x - x == 0.0 && v - v == 0.0 && w - w == 0.0 && q - q == 0.0f)) {
        *bad = p;  // the step stops here, as the CPU's does
        return;
      }
    }
  }
};
// Commit and External over the same candidates, in one launch.
struct ProjectileCommitExternalKernel {
  ProjectileCommitKernel commit;
  ProjectileExternalKernel external;
  MCA_HD void operator()(std::size_t k) const {
    commit(k);
    external(k);
  }
};
// The end of the projectile pass in one block: each projectile's first candidate and new list's start,
// then its sums, then (`move`: where no projectile pairs touch) the motion of them all.
struct ProjectileSumsKernel {
  static constexpr int kPhases = 3;
  ProjectileSegmentKernel segment;
  ProjectileSumKernel sum;
  ProjectileMotionKernel motion;
  std::uint32_t np;
  bool move;
  MCA_HD std::size_t size(int phase) const { return phase == 0 ? np + 1 : phase == 1 ? np : move ? 1 : 0; }
  MCA_HD void operator()(int phase, std::size_t k) const {
    if (phase == 0) segment(k);
    else if (phase == 1) sum(k);
    else motion(k);
  }
};
// The projectile pass after its candidates' order where they are few (at most kSmallCandidates), in one block,
// as phases: each candidate's contact (ProjectileContactKernel), the scan of what is kept (each of `chunks`
// chunks summed, then placed after the sums of the chunks before it), the kept contacts into the new lists
// and onto their automata (ProjectileCommitExternalKernel), and ProjectileSumsKernel's phases: four launches
// in one.
inline constexpr std::uint32_t kSmallCandidates = 1024;
struct ProjectilePassKernel {
  static constexpr int kPhases = 7;
  static constexpr std::uint32_t kChunks = 256;  // one to each thread of a block (the tests take fewer)
  ProjectileContactKernel contact;
  std::uint32_t chunks;
  std::uint32_t* chunk_sum;  // `chunks` entries
  std::uint32_t* place;      // the scan of contact.keep: candidates + 1 entries
  std::uint32_t candidates;
  ProjectileCommitExternalKernel commit;
  ProjectileSumsKernel sums;
  MCA_HD std::size_t size(int phase) const {
    switch (phase) {
      case 0: return candidates;
      case 1:
      case 2: return candidates ? chunks : 0;
      case 3: return candidates;
      default: return sums.size(phase - 4);
    }
  }
  MCA_HD void operator()(int phase, std::size_t k) const {
    const std::uint32_t n = candidates, per = (n + chunks - 1) / chunks, c = static_cast<std::uint32_t>(k);
    const std::uint32_t first = c * per < n ? c * per : n, last = first + per < n ? first + per : n;
    if (phase == 0) {
      contact(k);
    } else if (phase == 1) {
      std::uint32_t sum = 0;
      for (std::uint32_t j = first; j < last; ++j) sum += contact.keep[j];
      chunk_sum[c] = sum;
    } else if (phase == 2) {
      std::uint32_t at = 0;
      for (std::uint32_t b = 0; b < c; ++b) at += chunk_sum[b];
      for (std::uint32_t j = first; j < last; ++j) {
        place[j] = at;
        at += contact.keep[j];
      }
      if (c == chunks - 1) place[n] = at;  // the total
    } else if (phase == 3) {
      commit(k);
    } else {
      sums(phase - 4, k);
    }
  }
};

// --- Energies: Engine's check of the energy, from energy_terms.hpp's terms, summed on the device ---
struct EnergySums {
  double kinetic = 0, gravity_work = 0, load_work = 0, links = 0, many_body = 0, pairs = 0, ground = 0;
  double projectile_kinetic = 0, projectile_gravity = 0, projectile_work = 0, projectile_contact = 0, grip_work = 0;
};
struct AutomatonEnergyKernel {
  EnergyView ev;
  double *kinetic, *gravity, *load;  // load null: none
  MCA_HD void operator()(std::size_t a) const {
    const AutomatonEnergy e = ev.automaton(a);
    kinetic[a] = e.kinetic;
    gravity[a] = e.gravity_work;
    if (load) load[a] = e.load_work;
  }
};
struct LinkEnergyKernel {
  EnergyView ev;
  LinkEnergy* link;
  double* elastic;
  MCA_HD void operator()(std::size_t l) const {
    const LinkEnergy e = ev.link(l);
    link[l] = e;
    elastic[l] = e.elastic + e.bending;
  }
};
// Automaton a's many-body energy from its links' terms (Model::for_each_link_of's links).
struct ManyBodyEnergyKernel {
  EnergyView ev;
  const std::uint32_t* below;
  const LinkEnergy* link;
  const double* shell_c;  // per automaton (null: no shell)
  double* out;
  MCA_HD void operator()(std::size_t a) const {
    const std::size_t n = ev.m.n;
    ManyBodySums s = ev.sums(a);
    for (int axis = 0; axis < 3; ++axis) {
      const std::size_t up = axis * n + a;
      if (ev.neighbour[up] != Model::kNoLink) EnergyView::add(s, link[up], axis, true);
      if (below[up] != Model::kNoLink) EnergyView::add(s, link[axis * n + below[up]], axis, false);
    }
    if (ev.m.first)
      for (std::uint32_t x = ev.m.first[a]; x < ev.m.first[a + 1]; ++x) {
        const std::uint32_t k = ev.m.of[x];
        EnergyView::add(s, link[3 * n + k], -1, ev.m.ei[k] == a);
      }
    const EnergyView::ManyBodyEnergy e = ev.many_body(a, s, shell_c ? shell_c[a] : 0.0);
    out[a] = e.strain + e.bending;
  }
};
struct PairEnergyKernel {
  EnergyView ev;
  const ContactPair* pairs;
  double* out;
  MCA_HD void operator()(std::size_t p) const { out[p] = ev.pair_contact(pairs[p]); }
};
struct GroundEnergyKernel {
  EnergyView ev;
  const BodyContact* list;
  const ContactMaterial* ground;  // per group
  Vec3 up;
  double height;
  double* out;
  MCA_HD void operator()(std::size_t k) const { out[k] = ev.ground_contact(list[k], ground, up, height); }
};
// A chunk's sum of an array (chunk_sum: the energy check's fixed tree), for each chunk.
struct ChunkSumKernel {
  const double* x;
  std::size_t n;
  double* out;  // a value per chunk
  MCA_HD void operator()(std::size_t chunk) const { out[chunk] = chunk_sum(x, n, chunk); }
};
// One thread: the projectiles' terms and the grips' work, in compute_energies' order.
struct SerialEnergyKernel {
  EnergyView ev;
  const DeviceProjectile* proj;
  ProjectilePairs pairs;
  const BodyContact* lists;     // the projectiles' contact lists, one after another
  const std::uint32_t* start;   // np + 1 entries
  const ContactMaterial* material;  // per projectile and group: projectile_contact(p, g)
  const ContactMaterial* ground_material;  // per group (null: no ground)
  Vec3 up;
  double height;
  const ProjectilePair* pair_list;
  std::uint32_t pair_count;
  const double* grip_work;
  std::size_t grips;
  EnergySums* sums;
  MCA_HD void operator()(std::size_t) const {
    const ProjectileConstants* P = pairs.P;
    double kinetic = 0, gravity = 0, work = 0, contact = 0;
    for (std::uint32_t p = 0; p < pairs.np; ++p) {
      const DeviceProjectile& ps = proj[p];
      kinetic += ev.projectile_kinetic(ps.velocity, ps.angular_velocity, ps.force, P[p].mass, P[p].inertia, P[p].kinematic);
      const DVec3 xp = ev.projectile_at(ps.position, ps.velocity);
      if (P[p].kinematic) work += ps.work;
      else gravity += P[p].mass * dotd(ev.gravity, delta(P[p].start, xp));
      for (std::uint32_t k = start[p]; k < start[p + 1]; ++k)
        contact += ev.projectile_contact(lists[k], xp, P[p].radius,
                                         material[static_cast<std::size_t>(p) * pairs.groups + ev.m.group[lists[k].automaton]]);
      if (ground_material) {
        ContactMaterial c = ground_material[P[p].group];  // Model::projectile_ground_contact
        c.rolling = P[p].rolling;
        c.twisting = P[p].twisting;
        contact += EnergyView::on_ground(xp, P[p].radius, c, ps.ground, up, height);
      }
    }
    for (std::uint32_t k = 0; k < pair_count; ++k) {
      const ProjectilePair& c = pair_list[k];
      const DeviceProjectile &a = proj[c.p], &b = proj[c.q];
      contact += EnergyView::projectile_pair(ev.projectile_at(a.position, a.velocity), ev.projectile_at(b.position, b.velocity),
                                             P[c.p].radius, P[c.q].radius, pairs.material(c.p, c.q), c.h);
    }
    double grip = 0;
    for (std::size_t g = 0; g < grips; ++g) grip += grip_work[g];
    sums->projectile_kinetic = kinetic;
    sums->projectile_gravity = gravity;
    sums->projectile_work = work;
    sums->projectile_contact = contact;
    sums->grip_work = grip;
  }
};

}  // namespace mca::gpu
