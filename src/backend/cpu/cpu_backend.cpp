// The CPU backend: the reference implementation of a step (physics.md secs. 3-7).
//
// A step is a sequence of passes, each over index ranges that a thread pool (oneTBB here) or a CUDA grid
// can drive:
//   explicit links, contacts, the ground, projectiles: what acts on the automata from outside the
//                  lattice, from the positions at the start of the step, added to automata in list order
//   lattice sweep  the kernels of lattice_kernels.hpp (compiled for several instruction sets and picked at
//                  run time) chunk by chunk: the many-body terms P of each automaton, the links' pair
//                  forces, torques and fracture criteria, and the automata (gather forces in a fixed
//                  order, averaged stress, gravity, loads, integrate)
//   breaks         applied in link order at the end of the step
// Links write their forces; automata gather them in a fixed order. No floating-point atomics, no
// order-dependent reductions: results are bitwise identical for any thread count and instruction set.
//
// During a run the automata's positions, velocities, rotations and the links' shear displacements live
// here as structures of arrays (one array per component, as SIMD lanes load them); State's arrays of
// structures are brought up to date when the state is read (state(), download()).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "backend/backend.hpp"
#include "backend/cpu/aligned.hpp"
#include "backend/cpu/lattice_kernels.hpp"
#include "backend/step_constants.hpp"
#include "backend/step_kernels.hpp"
#include "core/environment.hpp"
#include "core/model_view.hpp"
#include "core/text.hpp"
#include "grid/uniform_grid.hpp"
#include "mca/error.hpp"
#include "physics/contact_law.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

namespace mca {
namespace {

using cpu::kBreakByStress;

constexpr std::size_t kChunk = 2048;  // fixed work chunks (a multiple of every lane count): per-chunk
                                      // results are combined in chunk order
// Work on this many automata (or pairs) or fewer runs on the calling thread: handing it to a worker costs
// more than it saves.
constexpr std::size_t kSerial = 4096;
// The kernels' blocks and tiles (lattice_kernels.hpp) start at multiples of kTile: so must the chunks.
static_assert(kChunk % cpu::kTile == 0 && kSerial % kChunk == 0);

template <class F>
void parallel_range(std::size_t n, F&& body) {
  if (n <= kSerial) {
    for (std::size_t k = 0; k < n; ++k) body(k);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) body(k);
                    });
}

// body(c, b, e) for the chunks [b, e) of [0, n): in parallel when there is more than kSerial work.
template <class F>
void parallel_chunks(std::size_t n, F&& body) {
  const std::size_t count = (n + kChunk - 1) / kChunk;
  auto chunk = [&](std::size_t c) { body(c, c * kChunk, std::min(n, (c + 1) * kChunk)); };
  if (n <= kSerial) {
    for (std::size_t c = 0; c < count; ++c) chunk(c);
    return;
  }
  tbb::parallel_for(std::size_t{0}, count, chunk);
}

// Wall time per pass, summed over steps, printed when the backend is destroyed where MCA_PROFILE=1.
struct PassProfile {
  static constexpr int kPasses = 6;
  bool on = profile_requested();
  const char* set = "";
  double seconds[kPasses] = {};
  std::int64_t steps = 0, rebuilds = 0;
  ~PassProfile() {
    if (!on || steps == 0) return;
    static const char* names[kPasses] = {"explicit links", "contacts", "projectiles", "lattice sweep",
                                         "breaks", "contact list"};
    double total = 0;
    for (double t : seconds) total += t;
    std::fprintf(stderr, "cpu backend (%s) profile over %lld steps (%.3f s):\n", set, static_cast<long long>(steps),
                 total);
    for (int k = 0; k < kPasses; ++k)
      std::fprintf(stderr, "  %-14s %8.3f ms/step  %5.1f %%\n", names[k], 1e3 * seconds[k] / steps,
                   100 * seconds[k] / total);
    if (rebuilds > 0)
      std::fprintf(stderr, "  contact lists rebuilt %lld times (every %.1f steps)\n", static_cast<long long>(rebuilds),
                   static_cast<double>(steps) / rebuilds);
    else
      std::fprintf(stderr, "  contact lists not rebuilt\n");
  }
};

class PassTimer {
 public:
  explicit PassTimer(PassProfile& p) : p_(p) {
    if (p_.on) {
      ++p_.steps;
      last_ = std::chrono::steady_clock::now();
    }
  }
  void lap(int k) {
    if (!p_.on) return;
    const auto now = std::chrono::steady_clock::now();
    p_.seconds[k] += std::chrono::duration<double>(now - last_).count();
    last_ = now;
  }

 private:
  PassProfile& p_;
  std::chrono::steady_clock::time_point last_;
};

bool finite(DVec3 a) { return std::isfinite(a.x + a.y + a.z); }
bool finite(Quat q) { return std::isfinite(q.w + q.x + q.y + q.z); }

bool pair_less(const ContactPair& a, const ContactPair& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; }

class CpuBackend final : public StateBackend {
 public:
  Energies energies() const override { return check_energies(M_, state()); }

  explicit CpuBackend(const Model& m)
      : M_(m), MV_(m.view()), K_(build_step_constants(m)), kernels_(cpu::select_kernels()) {
    const std::size_t n = m.size(), L = m.link_slots(), ne = m.explicit_links.size();
    profile_.set = kernels_.name;
    runs_ = cpu::block_runs(m, kernels_.lanes);
    // State and scratch arrays.
    for (auto* v : {&ex_nx_, &ex_ny_, &ex_nz_, &ex_eps_, &ex_mx_, &ex_my_, &ex_mz_}) v->resize(ne);
    if (K_.shells_any) ex_kappa_.resize(ne);  // a shell's curvature
    ex_out_.resize(cpu::tiled_size(ne, cpu::kExplicitOutRows));
    explicit_weight_.assign(n, 0.0f);
    bend_weight_.assign(n, 0.0f);
    explicit_breaks_.resize(ne);
    for (auto* v : {&px_, &py_, &pz_, &vx_, &vy_, &vz_, &wx_, &wy_, &wz_}) v->resize(n);
    ref_.resize(cpu::tiled_size(n, cpu::kRefRows));
    for (auto* v : {&qw_, &qx_, &qy_, &qz_}) v->resize(n);
    for (auto* v : {&utx_, &uty_, &utz_}) v->resize(L);
    for (auto* v : {&nx_, &ny_, &nz_, &many_body_}) v->resize(3 * cpu::scratch_stride(n));
    out_.resize(3 * cpu::tiled_size(n, cpu::kOutRows));
    intact_count_.resize(n);
    ext_f_.resize(n);
    ext_t_.resize(n);
    ext_s_.resize(n);
    has_ext_.assign(n, 0);
    near_.assign(n, 0);
    chunk_near_.assign((n + kChunk - 1) / kChunk, 0);
    breaks_.resize(L);
    // How far below an automaton its lower neighbours lie at most (lattice_sweep).
    std::size_t reach = 0;
    for (std::size_t l = 0; l < m.lattice_slots(); ++l)
      if (m.neighbour[l] != Model::kNoLink) {
        const std::size_t a = l % n, j = m.neighbour[l];
        if (j <= a) throw std::logic_error("lattice neighbour above an automaton lies before it");
        reach = std::max(reach, j - a);
      }
    head_chunks_ = (reach + kChunk - 1) / kChunk;
    if (const char* e = std::getenv("MCA_SWEEP"); e && *e) {
      const std::string how = text::lower(e);  // any case, as MCA_SIMD
      if (how == "passes") sweep_ = Sweep::passes;
      else if (how == "fused") sweep_ = Sweep::fused;
      else if (how != "auto")
        throw Error("MCA_SWEEP=" + std::string(e) + ": use auto (the default: the sweep where it pays), fused or passes");
    }
    for (auto* v : {&proj_x_, &proj_y_, &proj_z_}) v->resize(m.projectiles.size());
  }

  std::string name() const override { return std::string("cpu-") + kernels_.name; }
  void upload(State s) override {
    S_ = std::move(s);
    clock_.start(S_, M_.dt);
    const std::size_t n = M_.size();
    for (std::size_t a = 0; a < n; ++a) {
      px_[a] = S_.x[a].x; py_[a] = S_.x[a].y; pz_[a] = S_.x[a].z;
      vx_[a] = S_.v[a].x; vy_[a] = S_.v[a].y; vz_[a] = S_.v[a].z;
      wx_[a] = S_.w[a].x; wy_[a] = S_.w[a].y; wz_[a] = S_.w[a].z;
      qw_[a] = S_.q[a].w; qx_[a] = S_.q[a].x; qy_[a] = S_.q[a].y; qz_[a] = S_.q[a].z;
    }
    sound_link_counts(M_, S_, intact_count_.data());
    for (std::size_t l = 0; l < M_.link_slots(); ++l) {
      utx_[l] = S_.link_ut[l].x; uty_[l] = S_.link_ut[l].y; utz_[l] = S_.link_ut[l].z;
    }
    unsound_.clear();
    if (!S_.link_damage.empty()) {
      unsound_.resize(M_.link_slots());
      for (std::size_t l = 0; l < unsound_.size(); ++l) unsound_[l] = !S_.intact[l] || damaged(l);
    }
    for (std::size_t k = 0; k < S_.link_moment.size(); ++k) {
      ex_mx_[k] = S_.link_moment[k].x; ex_my_[k] = S_.link_moment[k].y; ex_mz_[k] = S_.link_moment[k].z;
    }
    stale_ = false;
    near_valid_ = false;
    if (S_.x_at_rebuild.size() != S_.x.size()) rebuild_contacts();
    else reference_positions();
  }
 private:
  std::int64_t one_step() override;
  void sync_state() const override {
    sync_positions();
    const std::size_t n = M_.size();
    for (std::size_t a = 0; a < n; ++a) {
      S_.v[a] = {vx_[a], vy_[a], vz_[a]};
      S_.w[a] = {wx_[a], wy_[a], wz_[a]};
      S_.q[a] = {qw_[a], qx_[a], qy_[a], qz_[a]};
    }
    for (std::size_t l = 0; l < M_.link_slots(); ++l) S_.link_ut[l] = {utx_[l], uty_[l], utz_[l]};
    for (std::size_t k = 0; k < S_.link_moment.size(); ++k) S_.link_moment[k] = {ex_mx_[k], ex_my_[k], ex_mz_[k]};
  }
  DVec3 pos(std::size_t a) const { return {px_[a], py_[a], pz_[a]}; }
  DVec3 vel(std::size_t a) const { return {vx_[a], vy_[a], vz_[a]}; }
  DVec3 ang(std::size_t a) const { return {wx_[a], wy_[a], wz_[a]}; }
  // State::x from the arrays here (the contact grid reads it).
  void sync_positions() const {
    for (std::size_t a = 0; a < M_.size(); ++a) S_.x[a] = pos(a);
  }
  cpu::LatticeView view();
  // The view with the projectiles' current positions, for the automata kernel to mark the automata near
  // them (near_).
  cpu::LatticeView with_projectiles(cpu::LatticeView v) {
    const std::size_t np = M_.projectiles.size();
    for (std::size_t p = 0; p < np; ++p) {
      const DVec3 c = S_.projectiles[p].position;
      proj_x_[p] = c.x;
      proj_y_[p] = c.y;
      proj_z_[p] = c.z;
    }
    v.projectiles = np;
    v.proj_x = proj_x_.data();
    v.proj_y = proj_y_.data();
    v.proj_z = proj_z_.data();
    v.proj_reach2 = K_.proj_reach2.data();
    v.near = near_.data();
    return v;
  }
  // ref_ from State::x_at_rebuild.
  void reference_positions() {
    for (std::size_t a = 0; a < M_.size(); ++a) {
      double* r = ref_.data() + cpu::tile_index(a, cpu::kRefRows);
      r[0] = S_.x_at_rebuild[a].x;
      r[cpu::kTile] = S_.x_at_rebuild[a].y;
      r[2 * cpu::kTile] = S_.x_at_rebuild[a].z;
    }
  }

  std::int64_t lattice_sweep(const cpu::LatticeView& v, std::vector<std::size_t>& counts, float& max_move2);
  cpu::ExplicitView explicit_view();
  ExplicitPassView explicit_pass_view() const;
  ContactPassView contact_pass_view() const;
  std::vector<std::size_t> explicit_link_pass(const cpu::LatticeView& v);
  void explicit_gather_pass(bool last);
  void apply_breaks(const std::vector<std::size_t>& counts, const std::vector<std::size_t>& explicit_counts,
                    float& max_move2);
  // The squared move of automaton a since the last rebuild, as the automata kernel measures it.
  float moved2(std::size_t a) const {
    const Vec3 d{static_cast<float>(px_[a] - S_.x_at_rebuild[a].x), static_cast<float>(py_[a] - S_.x_at_rebuild[a].y),
                 static_cast<float>(pz_[a] - S_.x_at_rebuild[a].z)};
    return dot(d, d);
  }
  void contact_pass();
  void ground_pass();
  std::int64_t projectile_pass();
  void grip_pass();
  void rebuild_contacts();
  bool linked(std::uint32_t i, std::uint32_t j) const;
  void lose_link(std::uint32_t a, float& max_move2);
  bool near_ground(std::uint32_t a) const;
  void add_external(std::uint32_t a, Vec3 f, Vec3 t, const Sym3& s) {
    ext_f_[a] += f;
    ext_t_[a] += t;
    ext_s_[a] += s;
    has_ext_[a] = 1;
  }

  const Model& M_;
  const ModelView MV_;     // the model's per-pair rules (contact reach, springs) over its arrays
  const StepConstants K_;  // what the step reads of the model, worked out once
  const cpu::Kernels& kernels_;
  // Automata (structure of arrays).
  cpu::LineArray<double> px_, py_, pz_;
  cpu::LineArray<double> ref_;  // positions at the last contact rebuild (State::x_at_rebuild), tiled
  cpu::LineArray<double> vx_, vy_, vz_, wx_, wy_, wz_;
  cpu::LineArray<float> qw_, qx_, qy_, qz_;
  // Sound links per automaton: intact and, where the model softens, undamaged (6: boxed in, see rebuild).
  std::vector<std::uint8_t> intact_count_;
  // Where the model softens: per link slot, 1 once the link is damaged or broken (no longer counted in
  // its ends' intact_count_).
  std::vector<std::uint8_t> unsound_;
  bool damaged(std::size_t l) const { return !S_.link_damage.empty() && S_.link_damage[l] > 0; }
  // Takes the links damaged in this step (softening) out of their ends' intact_count_, in slot order.
  void expose_damaged(float& max_move2);
  // Link slots (structure of arrays): shear displacement (state), then scratch rebuilt every step.
  cpu::LineArray<float> utx_, uty_, utz_, nx_, ny_, nz_, many_body_;
  cpu::LineArray<float> out_;  // the links kernel's results for the automata kernel (LatticeView::out)
  std::vector<cpu::BlockRun> runs_;     // how each block of lanes finds its neighbours
  std::vector<std::uint32_t> breaks_;  // per chunk of slots, what the links kernel found
  std::size_t head_chunks_ = 0;         // chunks of a region the region before may read (lattice_sweep)
  // How lattice_sweep runs the kernels (MCA_SWEEP, for tests and measurements; the same results each way):
  // chunk by chunk where it pays, always chunk by chunk, or one kernel at a time over all chunks.
  enum class Sweep { automatic, fused, passes } sweep_ = Sweep::automatic;
  // Explicit links: this step's geometry and forces, the bending springs' state, per automaton its
  // many-body weight.
  cpu::LineArray<float> ex_nx_, ex_ny_, ex_nz_, ex_eps_;
  cpu::LineArray<float> ex_out_;  // cpu::ExplicitView::out
  cpu::LineArray<float> ex_mx_, ex_my_, ex_mz_;  // state: the bending springs' moments (State::link_moment)
  static constexpr std::uint32_t kSecondEnd = StepConstants::kSecondEnd;
  std::vector<float> explicit_weight_;
  std::vector<float> bend_weight_;              // the shells' bending's many-body weight per automaton
  cpu::LineArray<float> ex_kappa_;              // per explicit link: this step's kappa_nn (explicit_geometry)
  std::vector<std::uint32_t> explicit_breaks_;  // per chunk of links, what the explicit kernel found
  std::vector<std::uint32_t> exposed_;
  std::vector<std::uint8_t> near_, chunk_near_;  // see LatticeView::near; per chunk: any marked
  std::vector<double> proj_x_, proj_y_, proj_z_;  // the projectiles' centres for the marks
  bool near_valid_ = false;                      // near_ is from the last step (not before an upload)
  std::vector<Vec3> ext_f_, ext_t_;
  std::vector<Sym3> ext_s_;
  std::vector<std::uint8_t> has_ext_;
  std::vector<ContactOut> contact_out_;  // a contact's result, written in parallel, added in list order
  UniformGrid grid_;
  PassProfile profile_;
};

cpu::LatticeView CpuBackend::view() {
  const Model& m = M_;
  cpu::LatticeView v = lattice_view_numbers(m, K_);
  v.up = m.neighbour.data();
  v.below = m.neighbour_below.data();
  v.runs = runs_.data();
  v.blocks = kernels_.lanes > 1 ? m.size() / static_cast<std::size_t>(kernels_.lanes) : 0;
  v.group = m.group.data();
  v.tensile = K_.tensile.data();
  v.compressive = K_.compressive.data();
  v.break_strain = K_.break_strain.data();
  v.mass = m.mass.data();
  v.inv_mass = K_.inv_mass.data();
  v.inv_inertia = K_.inv_inertia.data();
  v.inv_volume = K_.inv_volume.data();
  v.grip = m.grip_velocity.empty() ? nullptr : m.grip.data();
  v.grip_velocity = m.grip_velocity.data();
  v.load = m.load.empty() ? nullptr : m.load.data();
  v.groups = m.groups.data();
  v.free_factor = reinterpret_cast<const float(*)[4]>(K_.free_factor.data());
  v.pairs = K_.pairs.data();
  v.softening = !S_.link_damage.empty();
  v.damage = v.softening ? S_.link_damage.data() : nullptr;
  v.link_strength = m.link_strength.empty() ? nullptr : m.link_strength.data();
  v.rest = m.link_rest.empty() ? nullptr : m.link_rest.data();
  v.inv_rest = m.link_inv_rest.empty() ? nullptr : m.link_inv_rest.data();
  v.last = last_step_;
  v.px = px_.data(); v.py = py_.data(); v.pz = pz_.data();
  v.vx = vx_.data(); v.vy = vy_.data(); v.vz = vz_.data();
  v.wx = wx_.data(); v.wy = wy_.data(); v.wz = wz_.data();
  v.qw = qw_.data(); v.qx = qx_.data(); v.qy = qy_.data(); v.qz = qz_.data();
  v.mean_stress = S_.mean_stress.data();
  v.stress = S_.s.data();
  v.f_out = S_.f.data();
  v.t_out = S_.t.data();
  v.intact = S_.intact.data();
  v.utx = utx_.data(); v.uty = uty_.data(); v.utz = utz_.data();
  v.nx = nx_.data(); v.ny = ny_.data(); v.nz = nz_.data();
  v.many_body = many_body_.data();
  v.out = out_.data();
  v.has_ext = has_ext_.data();
  v.ext_f = ext_f_.data();
  v.ext_t = ext_t_.data();
  v.ext_s = ext_s_.data();
  v.intact_count = intact_count_.data();
  v.ref = ref_.data();
  return v;
}

// Automaton a lost a sound link: one boxed in (intact_count_ 6) is exposed from now on, and its move since
// the last rebuild counts for the contact list's staleness. (The count stays at 0 or above: an automaton of
// the random lattice has more links than the encoding's 6.)
void CpuBackend::lose_link(std::uint32_t a, float& max_move2) {
  if (intact_count_[a] == 6) max_move2 = std::max(max_move2, moved2(a));
  if (intact_count_[a] > 0) --intact_count_[a];
}

bool CpuBackend::linked(std::uint32_t i, std::uint32_t j) const {
  const std::size_t n = M_.size();
  for (int axis = 0; axis < 3; ++axis) {
    const std::size_t up = axis * n + i;
    if (M_.neighbour[up] == j && S_.intact[up]) return true;
    if (M_.neighbour_below[up] == j && S_.intact[axis * n + j]) return true;
  }
  const auto& E = M_.explicit_links;
  if (!E.first.empty())
    for (std::uint32_t k = E.first[i]; k < E.first[i + 1]; ++k) {
      const std::uint32_t l = E.of[k];
      if ((E.i[l] == j || E.j[l] == j) && S_.intact[3 * n + l]) return true;
    }
  return false;
}

// Whether automaton a is within reach of the ground: its height above it is below r + skin.
bool CpuBackend::near_ground(std::uint32_t a) const {
  const DVec3 x = pos(a);
  const double above = x.x * M_.up.x + x.y * M_.up.y + x.z * M_.up.z - M_.ground_height;
  return above < static_cast<double>(M_.radius[a]) + M_.skin;
}

// The lattice's three kernels in one sweep over the chunks of kChunk automata, so that what one kernel
// leaves for the next (the many-body terms, the link results, the positions they read) is still in the
// cache when the next one reads it (docs/model-notes.md, "Passes and the lattice sweep"). A kernel may
// run on a chunk once what it reads is final, and an automaton may integrate once nothing left to run
// reads its state. With `reach` the largest distance in lattice order between a link's two ends (a box's
// nx ny along z):
//  - the links of chunk c read the many-body terms of their ends, up to reach automata above: chunks up
//    to c + head_chunks_;
//  - the many-body terms of an automaton read the positions of its neighbours, reach below and above;
//  - an automaton's position, velocities and mean stress are read by its own links and those of its
//    lower neighbours, and its many-body term and those of its neighbours.
// So a chunk c runs many_body(c + h), links(c), automata(c) in turn (h = head_chunks_). With several
// threads the chunks form regions of consecutive chunks, one task each. Where two regions meet, the h
// chunks before the boundary (the tail) need the many-body terms of the h chunks after it (the head),
// and the head's automata may integrate only once the tail's links have read them: each region does its
// head's many-body terms and links first, and the tail's links and automata and the head's automata are
// done by whichever of the two regions gets there second. The kernels' results do not depend on how the
// chunks are grouped or by whom (a test checks the sweep against one pass at a time).
//
// The breaks of axis a and chunk c go to counts[a * chunks + c], in slot order; they are applied after
// the sweep (apply_breaks): a link that breaks carries its force in the step it breaks.
std::int64_t CpuBackend::lattice_sweep(const cpu::LatticeView& v, std::vector<std::size_t>& counts, float& max_move2) {
  const std::size_t n = M_.size(), chunks = (n + kChunk - 1) / kChunk, h = head_chunks_;
  counts.assign(3 * chunks, 0);
  std::vector<cpu::AutomataResult> result(chunks);
  auto range = [&](std::size_t c) { return std::pair{c * kChunk, std::min(n, (c + 1) * kChunk)}; };
  auto many_body = [&](std::size_t c) {
    if (c >= chunks) return;
    const auto [b, e] = range(c);
    kernels_.many_body(v, b, e);
  };
  auto links = [&](std::size_t c) {
    const auto [b, e] = range(c);
    // A chunk's three axes one after the other: its automata's data is read from memory once, not three
    // times.
    for (int axis = 0; axis < 3; ++axis)
      counts[axis * chunks + c] = kernels_.links(v, axis, b, e, breaks_.data() + axis * n + b);
  };
  auto automata = [&](std::size_t c) {
    const auto [b, e] = range(c);
    result[c] = kernels_.automata(v, b, e);
  };
  // The threads oneTBB is allowed (mca sets it from --threads, at most the cores; a test may allow more),
  // not the processor's count: the regions, and so what a test exercises, do not depend on the machine
  // (the results depend on neither).
  const std::size_t threads = tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
  // About four regions per thread, of at least 2h + 1 chunks each (a head, a tail and one between).
  const std::size_t regions =
      n <= kSerial || threads < 2 ? 1 : std::clamp(chunks / (2 * h + 1), std::size_t{1}, 4 * threads);
  // With fewer than two regions per thread the joins at the boundaries, done after a region's own work,
  // lengthen the step more than the cache saves (a small scene is in the cache anyway): then, unless
  // MCA_SWEEP=fused, one kernel at a time over all chunks, each in parallel.
  const bool by_pass = sweep_ == Sweep::passes ||
                       (sweep_ == Sweep::automatic && n > kSerial && threads > 1 && regions < 2 * threads);
  if (by_pass) {
    parallel_chunks(n, [&](std::size_t c, std::size_t, std::size_t) { many_body(c); });
    parallel_chunks(n, [&](std::size_t c, std::size_t, std::size_t) { links(c); });
    parallel_chunks(n, [&](std::size_t c, std::size_t, std::size_t) { automata(c); });
  } else if (regions == 1) {
    for (std::size_t c = 0; c < h; ++c) many_body(c);
    for (std::size_t c = 0; c < chunks; ++c) {
      many_body(c + h);
      links(c);
      automata(c);
    }
  } else {
    // Region r: chunks [first(r), first(r + 1)). Boundary r (r >= 1) lies at its start.
    auto first = [&](std::size_t r) { return r * chunks / regions; };
    auto end = [&](std::size_t r) { return first(r + 1); };
    std::vector<std::atomic<int>> arrived(regions);  // zeros
    // Boundary r: the tail of region r - 1 and the head of region r, by the second to arrive.
    auto arrive = [&](std::size_t r) {
      if (arrived[r].fetch_add(1, std::memory_order_acq_rel) == 0) return;
      const std::size_t c0 = first(r);
      for (std::size_t c = c0 - h; c < c0; ++c) links(c);
      for (std::size_t c = c0 - h; c < c0 + h; ++c) automata(c);
    };
    tbb::parallel_for(std::size_t{0}, regions, [&](std::size_t r) {
      const std::size_t c0 = first(r), c1 = end(r);
      std::size_t c = c0;
      if (r > 0) {
        for (std::size_t k = c0; k < c0 + 2 * h; ++k) many_body(k);
        for (; c < c0 + h; ++c) links(c);
        arrive(r);
      } else {
        for (std::size_t k = c0; k < c0 + h; ++k) many_body(k);
      }
      const std::size_t stop = r + 1 == regions ? c1 : c1 - h;
      for (; c < stop; ++c) {
        many_body(c + h);
        links(c);
        automata(c);
      }
      if (r + 1 < regions) arrive(r + 1);
    });
  }
  max_move2 = 0;
  for (const auto& r : result) max_move2 = std::max(max_move2, r.max_move2);
  near_valid_ = v.projectiles > 0;
  for (std::size_t ch = 0; ch < chunks && near_valid_; ++ch) chunk_near_[ch] = result[ch].near;
  for (const auto& r : result)
    if (r.first_bad >= 0) return r.first_bad;
  return kAllFinite;
}

// Explicit links (surface mode): the kernels' explicit_geometry over fixed chunks of links, each
// automaton's many-body weight from its intact links in link order, then the kernels' explicit_links (the
// lattice's law with each link's own length and cross-section); the breaks per chunk, in link order.
std::vector<std::size_t> CpuBackend::explicit_link_pass(const cpu::LatticeView& v) {
  const std::size_t L = M_.explicit_links.size();
  const cpu::ExplicitView ev = explicit_view();
  parallel_chunks(L, [&](std::size_t, std::size_t b, std::size_t e) { kernels_.explicit_geometry(v, ev, b, e); });
  const ExplicitPassView pv = explicit_pass_view();
  parallel_range(K_.explicit_automata.size(), [&](std::size_t k) {
    const std::uint32_t a = K_.explicit_automata[k];
    const ExplicitWeights w = explicit_weight(pv, a);
    explicit_weight_[a] = w.weight;
    if (w.shell) bend_weight_[a] = w.bend_weight;
  });
  const std::size_t chunks = (L + kChunk - 1) / kChunk;
  std::vector<std::size_t> counts(chunks, 0);
  parallel_chunks(L, [&](std::size_t ch, std::size_t b, std::size_t e) {
    counts[ch] = kernels_.explicit_links(v, ev, b, e, explicit_breaks_.data() + b);
  });
  return counts;
}

cpu::ExplicitView CpuBackend::explicit_view() {
  const auto& E = M_.explicit_links;
  cpu::ExplicitView e;
  e.slot0 = 3 * M_.size();
  e.i = E.i.data();
  e.j = E.j.data();
  e.r0 = E.r0.data();
  e.r0f = K_.ex_r0f.data();
  e.inv_r0 = K_.ex_inv_r0.data();
  e.area = K_.ex_area.data();
  e.inv_r0_area = K_.ex_to_stress.data();
  e.G = K_.ex_G.data();
  e.kt = K_.ex_kt.data();
  e.damp_normal = K_.ex_damp_n.data();
  e.damp_tangential = K_.ex_damp_t.data();
  e.soft = K_.ex_soft.empty() ? nullptr : K_.ex_soft.data();
  e.weight = explicit_weight_.data();
  e.tensile = K_.ex_tensile.data();
  e.compressive = K_.ex_compressive.data();
  e.strain = K_.ex_strain.data();
  e.nx = ex_nx_.data(); e.ny = ex_ny_.data(); e.nz = ex_nz_.data(); e.eps = ex_eps_.data();
  e.out = ex_out_.data();
  e.k_twist = K_.ex_k_twist.data(); e.k_in = K_.ex_k_in.data(); e.k_out = K_.ex_k_out.data();
  e.s_in = K_.ex_s_in.data(); e.s_out = K_.ex_s_out.data(); e.s_twist = K_.ex_s_twist.data();
  e.m0x = K_.ex_m0x.data(); e.m0y = K_.ex_m0y.data(); e.m0z = K_.ex_m0z.data();
  e.mx = ex_mx_.data(); e.my = ex_my_.data(); e.mz = ex_mz_.data();
  e.kappa = ex_kappa_.data();
  e.bend_weight = bend_weight_.data();
  e.bends = M_.object_random.empty() ? nullptr : K_.ex_bends.data();
  return e;
}

ExplicitPassView CpuBackend::explicit_pass_view() const {
  const std::size_t slot0 = 3 * M_.size();
  ExplicitPassView v;
  v.m = MV_;
  v.first = M_.explicit_links.first.data();
  v.ends = K_.ex_ends.data();
  v.intact = S_.intact.data() + slot0;
  v.damage = S_.link_damage.empty() ? nullptr : S_.link_damage.data() + slot0;
  v.free_face = M_.free_face.empty() ? nullptr : M_.free_face.data();
  v.volume = M_.volume.data();
  v.area_r0 = K_.ex_area_r0.data();
  v.eps = ex_eps_.data();
  v.kappa = ex_kappa_.empty() ? nullptr : ex_kappa_.data();
  v.lambda_over_2g = K_.lambda_over_2g.data();
  v.free_factor = reinterpret_cast<const float(*)[4]>(K_.free_factor.data());
  v.bend_c = K_.bend_c.data();
  v.lattice_lambda = M_.lattice_lambda;
  v.lattice_bending = M_.lattice_bending;
  v.out = ex_out_.data();
  v.nx = ex_nx_.data();
  v.ny = ex_ny_.data();
  v.nz = ex_nz_.data();
  v.r0f = K_.ex_r0f.data();
  return v;
}

ContactPassView CpuBackend::contact_pass_view() const {
  ContactPassView v;
  v.m = MV_;
  v.px = px_.data(); v.py = py_.data(); v.pz = pz_.data();
  v.vx = vx_.data(); v.vy = vy_.data(); v.vz = vz_.data();
  v.wx = wx_.data(); v.wy = wy_.data(); v.wz = wz_.data();
  v.qw = qw_.data(); v.qx = qx_.data(); v.qy = qy_.data(); v.qz = qz_.data();
  v.pair_springs = K_.uniform_bodies ? K_.pair_springs.data() : nullptr;
  v.ground_springs = K_.uniform_bodies ? K_.ground_springs.data() : nullptr;
  v.zeta_pair = M_.zeta_pair.data();
  v.zeta_pair_held = M_.zeta_pair_held.empty() ? nullptr : M_.zeta_pair_held.data();
  v.zeta_ground = M_.zeta_ground.data();
  v.ground_contact = M_.ground_contact.data();
  v.up = M_.up;
  v.ground_height = M_.ground_height;
  v.dt = M_.dt;
  return v;
}

// Each automaton adds the forces of its intact explicit links in link order (with the contacts' and loads'
// forces in the automata kernel), so the sums do not depend on the threads.
void CpuBackend::explicit_gather_pass(bool last) {
  const ExplicitPassView pv = explicit_pass_view();
  parallel_range(K_.explicit_automata.size(), [&](std::size_t k) {
    const std::uint32_t a = K_.explicit_automata[k];
    const ExternalSum e = explicit_gather(pv, a, last);
    if (e.any) add_external(a, e.f, e.t, e.s);
  });
}

// Breaks found in this step's sweep, in link order, applied at its end: the link carried its force in the
// step it broke and carries none from the next on, and the broken pair touches, so it joins the contact
// list (and the ground list, when near it) for the next step, not at the next rebuild.
// A damaged link may stretch far beyond a sound one (up to the softening's end, ku times the strength's
// strain) while it is intact: its ends are no longer boxed in at ~d, and automata that kept all six
// links passed through each other unseen by the contact search (a wall of fracture_energy = 1e6 struck at
// 120 m/s). So a link counts as sound, for the contact search, only while it is undamaged.
void CpuBackend::expose_damaged(float& max_move2) {
  for (std::size_t l = 0; l < unsound_.size(); ++l) {
    if (unsound_[l] || !(S_.link_damage[l] > 0)) continue;
    unsound_[l] = 1;
    for (const std::uint32_t a : {M_.link_i(l), M_.link_j(l)}) lose_link(a, max_move2);
  }
}

void CpuBackend::apply_breaks(const std::vector<std::size_t>& counts, const std::vector<std::size_t>& explicit_counts,
                              float& max_move2) {
  const std::size_t n = M_.size(), chunks = (n + kChunk - 1) / kChunk;
  std::vector<ContactPair> fresh;
  std::vector<std::uint32_t> ground_fresh;
  // The lattice's chunks by axis, then the explicit links' chunks: slot order.
  for (std::size_t k = 0; k < counts.size() + explicit_counts.size(); ++k) {
    const bool lattice = k < counts.size();
    const std::uint32_t* found =
        lattice ? breaks_.data() + (k / chunks) * n + (k % chunks) * kChunk : explicit_breaks_.data() + (k - counts.size()) * kChunk;
    const std::size_t count = lattice ? counts[k] : explicit_counts[k - counts.size()];
    for (std::size_t r = 0; r < count; ++r) {
      const std::uint32_t code = found[r], l = code & ~kBreakByStress;
      const int crit = code & kBreakByStress ? 1 : 0;
      const std::uint32_t i = M_.link_i(l), j = M_.link_j(l);
      S_.intact[l] = 0;
      // An automaton exposed now joins the contact list's staleness check from this step's move on, as
      // if the automata kernel had seen it exposed (it saw the links before the breaks). (A softening
      // link left the count when it was first damaged.)
      if (unsound_.empty() || l >= unsound_.size() || !unsound_[l]) {
        for (const std::uint32_t a : {i, j}) lose_link(a, max_move2);
        if (l < unsound_.size()) unsound_[l] = 1;
      }
      utx_[l] = uty_[l] = utz_[l] = 0.0f;
      if (M_.is_explicit(l)) {
        const std::size_t k = l - M_.lattice_slots();
        ex_mx_[k] = ex_my_[k] = ex_mz_[k] = 0.0f;
      }
      S_.breaks.push_back({S_.step, l, static_cast<BreakCriterion>(crit)});
      ++S_.broken_by[crit];
      fresh.push_back({i, j, {}});
      if (M_.ground) {
        if (near_ground(i)) ground_fresh.push_back(i);
        if (near_ground(j)) ground_fresh.push_back(j);
      }
    }
  }
  if (!fresh.empty()) {
    std::sort(fresh.begin(), fresh.end(), pair_less);
    std::vector<ContactPair> merged;
    merged.reserve(S_.contacts.size() + fresh.size());
    std::merge(S_.contacts.begin(), S_.contacts.end(), fresh.begin(), fresh.end(), std::back_inserter(merged),
               pair_less);
    S_.contacts.swap(merged);
  }
  if (!ground_fresh.empty()) {
    std::sort(ground_fresh.begin(), ground_fresh.end());
    ground_fresh.erase(std::unique(ground_fresh.begin(), ground_fresh.end()), ground_fresh.end());
    std::vector<BodyContact> merged;
    merged.reserve(S_.ground_contacts.size() + ground_fresh.size());
    std::size_t o = 0;
    for (std::uint32_t a : ground_fresh) {
      while (o < S_.ground_contacts.size() && S_.ground_contacts[o].automaton < a) merged.push_back(S_.ground_contacts[o++]);
      if (o < S_.ground_contacts.size() && S_.ground_contacts[o].automaton == a) continue;  // already listed
      merged.push_back({a, {}});
    }
    merged.insert(merged.end(), S_.ground_contacts.begin() + static_cast<std::ptrdiff_t>(o), S_.ground_contacts.end());
    S_.ground_contacts.swap(merged);
  }
}

void CpuBackend::contact_pass() {
  auto& C = S_.contacts;
  if (C.empty()) return;
  contact_out_.resize(C.size());
  const ContactPassView cv = contact_pass_view();
  parallel_range(C.size(), [&](std::size_t p) { contact_out_[p] = pair_contact(cv, C[p]); });
  // Add to the automata in pair order (deterministic).
  for (std::size_t p = 0; p < C.size(); ++p) {
    const ContactOut& o = contact_out_[p];
    if (!o.on) continue;
    add_external(C[p].i, o.f, o.ti, sym_outer(o.n, o.f, o.ri));
    add_external(C[p].j, -o.f, o.tj, sym_outer(o.n, o.f, o.rj));
  }
}

void CpuBackend::ground_pass() {
  auto& G = S_.ground_contacts;
  if (G.empty()) return;
  contact_out_.resize(G.size());
  const ContactPassView cv = contact_pass_view();
  parallel_range(G.size(), [&](std::size_t k) { contact_out_[k] = ground_contact(cv, G[k]); });
  for (std::size_t k = 0; k < G.size(); ++k) {
    const ContactOut& o = contact_out_[k];
    if (o.on) add_external(G[k].automaton, o.f, o.ti, sym_outer(o.n, o.f, o.ri));
  }
}

// Projectiles: contacts with the automata they touch, with the ground and with each other, then their
// motion (a kinematic projectile keeps its velocity and records the work it does).
std::int64_t CpuBackend::projectile_pass() {
  const std::size_t np = M_.projectiles.size();
  if (np == 0) return kAllFinite;
  const float dt = M_.dt;
  const std::size_t n = M_.size();
  std::vector<Vec3> fsum(np), tsum(np);  // contact force and torque on each projectile
  for (std::size_t p = 0; p < np; ++p) {
    const ProjectileParams& P = M_.projectiles[p];
    ProjectileState& ps = S_.projectiles[p];
    // Candidates: automata touching the sphere, found per fixed chunk and joined in chunk order. The
    // last automata pass marked the automata near each projectile (near_): only the chunks it flagged
    // are searched, and only the automata with the projectile's bit tested.
    const std::size_t chunks = (n + kChunk - 1) / kChunk;
    std::vector<std::vector<std::uint32_t>> found(chunks);
    const DVec3 c = ps.position;
    const bool marked = near_valid_;
    const std::uint8_t bit = static_cast<std::uint8_t>(1u << (p % cpu::kNearBits));
    auto search = [&](std::size_t ch, std::size_t b, std::size_t e) {
      for (std::size_t a = b; a < e; ++a) {
        if (marked && !(near_[a] & bit)) continue;
        const Vec3 d = delta(c, pos(a));
        const float reach = P.radius + M_.radius[a];
        if (dot(d, d) < reach * reach) found[ch].push_back(static_cast<std::uint32_t>(a));
      }
    };
    if (marked) {
      for (std::size_t ch = 0; ch < chunks; ++ch)
        if (chunk_near_[ch]) search(ch, ch * kChunk, std::min(n, (ch + 1) * kChunk));
    } else {
      parallel_chunks(n, search);
    }
    std::vector<BodyContact> next;
    std::size_t old = 0;
    for (const auto& list : found)
      for (std::uint32_t a : list) {
        while (old < ps.contacts.size() && ps.contacts[old].automaton < a) ++old;
        const ContactHistory prev =
            (old < ps.contacts.size() && ps.contacts[old].automaton == a) ? ps.contacts[old].h : ContactHistory{};
        const float ra = M_.radius[a];
        const SphereGap gap = sphere_gap(pos(a), c, static_cast<double>(P.radius) + ra);  // automaton to projectile
        if (!gap.valid) continue;
        const Vec3 nrm = gap.n;
        const std::uint8_t g = M_.group[a];
        const ContactSprings springs =
            projectile_contact_springs(MV_, a, M_.projectile_contact(p, g), P.zeta_automata[g],
                                       P.zeta_held.empty() ? 0.0f : P.zeta_held[g], P.radius, P.mass, P.inertia, P.kinematic);
        const ContactResult r = contact_between(nrm, gap.overlap, vel(a), ang(a), ra * nrm, ps.velocity, ps.angular_velocity,
                                                -P.radius * nrm, springs, prev.ut, prev.mr, dt);
        const ContactOutput& o = r.o;
        if (o.fn <= 0.0f && length(o.ut) == 0.0f) continue;
        next.push_back({a, {o.ut, o.mr}});
        add_external(a, o.force_i, r.torque_i, sym_outer(nrm, o.force_i, ra));
        fsum[p] -= o.force_i;
        tsum[p] += r.torque_j;
      }
    ps.contacts.swap(next);
    if (M_.ground) {
      // The ground, as for an automaton: the projectile is the first body.
      const Vec3 nrm = -M_.up;
      const ContactResult r = contact_between(
          nrm, ground_overlap(c, M_.up, M_.ground_height, P.radius), ps.velocity, ps.angular_velocity, P.radius * nrm, {}, {},
          {}, body_contact_springs(M_.projectile_ground_contact(p), P.zeta_ground, P.radius, INFINITY, P.mass, P.inertia),
          ps.ground.ut, ps.ground.mr, dt);
      ps.ground = {r.o.ut, r.o.mr};
      fsum[p] += r.o.force_i;
      tsum[p] += r.torque_i;
    }
  }
  // Projectile pairs (all pairs: scenes hold a few projectiles), in (p, q) order.
  std::vector<ProjectilePair> next_pairs;
  std::size_t old = 0;
  for (std::uint32_t p = 0; p < np; ++p)
    for (std::uint32_t q = p + 1; q < np; ++q) {
      const ProjectileParams &A = M_.projectiles[p], &B = M_.projectiles[q];
      if (A.kinematic && B.kinematic) continue;  // neither can respond
      const ProjectileState &a = S_.projectiles[p], &b = S_.projectiles[q];
      const SphereGap gap = sphere_gap(a.position, b.position, static_cast<double>(A.radius) + B.radius);
      if (gap.overlap <= 0.0f || !gap.valid) continue;
      while (old < S_.projectile_contacts.size() &&
             (S_.projectile_contacts[old].p < p || (S_.projectile_contacts[old].p == p && S_.projectile_contacts[old].q < q)))
        ++old;
      const ContactHistory prev = (old < S_.projectile_contacts.size() && S_.projectile_contacts[old].p == p &&
                                   S_.projectile_contacts[old].q == q)
                                      ? S_.projectile_contacts[old].h
                                      : ContactHistory{};
      const Vec3 nrm = gap.n;
      const ContactSprings springs = body_contact_springs(
          M_.projectile_pair_contact(p, q), M_.zeta_projectiles[p * np + q], A.radius, B.radius,
          contact_reduced(A.mass, A.kinematic, B.mass, B.kinematic), contact_reduced(A.inertia, A.kinematic, B.inertia, B.kinematic));
      const ContactResult r = contact_between(nrm, gap.overlap, a.velocity, a.angular_velocity, A.radius * nrm, b.velocity,
                                              b.angular_velocity, -B.radius * nrm, springs, prev.ut, prev.mr, dt);
      next_pairs.push_back({p, q, {r.o.ut, r.o.mr}});
      fsum[p] += r.o.force_i;
      fsum[q] -= r.o.force_i;
      tsum[p] += r.torque_i;
      tsum[q] += r.torque_j;
    }
  S_.projectile_contacts.swap(next_pairs);
  for (std::size_t p = 0; p < np; ++p) {
    const ProjectileParams& P = M_.projectiles[p];
    ProjectileState& ps = S_.projectiles[p];
    ps.force = fsum[p];
    if (P.kinematic) {
      // Power the projectile puts in: minus that of the forces on it at its own velocities.
      ps.work -= (dot(to_dvec3(fsum[p]), ps.velocity) + dot(to_dvec3(tsum[p]), ps.angular_velocity)) * dt;
    } else {
      ps.velocity += (fsum[p] * (1.0f / P.mass) + M_.gravity) * dt;
      ps.angular_velocity += tsum[p] * (dt / P.inertia);
      ps.orientation = integrate_projectile_orientation(ps.orientation, to_vec3(ps.angular_velocity), dt);
      if (!(projectile_turn(to_vec3(ps.angular_velocity), dt) <= kLargestProjectileTurn))
        return -2 - static_cast<std::int64_t>(p);  // (a turn its orientation does not follow)
    }
    ps.position += ps.velocity * static_cast<double>(dt);
    if (!finite(ps.position) || !finite(ps.velocity) || !finite(ps.angular_velocity) || !finite(ps.orientation))
      return -2 - static_cast<std::int64_t>(p);
  }
  return kAllFinite;
}

// Grip forces: the force the grip exerts is minus what the body pushes on it (the automata kernel leaves
// that in ext_f of the held automata).
void CpuBackend::grip_pass() {
  for (std::size_t g = 0; g < K_.grip_members.size(); ++g) {
    Vec3 f;
    for (std::uint32_t a : K_.grip_members[g]) {
      f -= ext_f_[a];
      ext_f_[a] = Vec3{};
    }
    S_.grip_force[g] = f;
    S_.grip_work[g] += dot(to_dvec3(f), M_.grip_velocity[g]) * M_.dt;
  }
}

void CpuBackend::rebuild_contacts() {
  sync_positions();
  const float skin = M_.skin;
  // Only exposed automata can touch anything but their linked neighbours: one with all six lattice
  // links intact is boxed in by automata at distance ~d, and its diagonal neighbours (1.41 d) are out of
  // reach (r_i + r_j + skin < 1.41 d for skin < 0.41 d, which validation enforces). In a struck wall that
  // is the surface and the damage, a small share of the automata. The same holds for the ground.
  exposed_.clear();
  for (std::size_t a = 0; a < M_.size(); ++a)
    if (intact_count_[a] < 6) exposed_.push_back(static_cast<std::uint32_t>(a));
  const std::size_t n = exposed_.size();
  grid_.build(S_.x.data(), n, 2.0f * K_.r_max + skin, exposed_.data());
  const int face_cells = face_search_cells(K_.r_max, skin);
  const double face_reach = face_search_reach(K_.r_max, skin);
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::vector<ContactPair>> found(chunks);
  parallel_chunks(n, [&](std::size_t ch, std::size_t b, std::size_t e) {
    std::vector<std::uint32_t> js;
    for (std::size_t k = b; k < e; ++k) {
      const std::uint32_t i = exposed_[k];
      const DVec3 xi = S_.x[i];
      js.clear();
      grid_.for_each_candidate_above(xi, i, [&](std::uint32_t j) {
        const Vec3 d = delta(xi, S_.x[j]);
        const float reach = M_.radius[i] + M_.radius[j] + skin;
        if (dot(d, d) < reach * reach && !linked(i, j)) js.push_back(j);
      });
      // An automaton with free sides: the sites of others that may come to touch it as faces (face_candidate).
      if (MV_.face && MV_.face[i]) {
        const Quat qi{qw_[i], qx_[i], qy_[i], qz_[i]};
        grid_.for_each_near_above(xi, i, face_cells, face_reach, [&](std::uint32_t j) {
          if (MV_.face_candidate(i, j, delta(xi, S_.x[j]), qi, Quat{qw_[j], qx_[j], qy_[j], qz_[j]}, skin) &&
              !linked(i, j))
            js.push_back(j);
        });
      }
      // A random-lattice automaton's broken links: their pairs reach their initial distance
      // (Model::contact_reach), up to 2.2 d, beyond the grid's cells of r_i + r_j + skin.
      const auto& E = M_.explicit_links;
      if (M_.random_automaton(i) && !E.first.empty()) {  // (an object of one automaton has no link at all)
        for (std::uint32_t x = E.first[i]; x < E.first[i + 1]; ++x) {
          const std::uint32_t l = E.of[x], j = E.i[l] == i ? E.j[l] : E.i[l];
          if (j <= i || S_.intact[3 * M_.size() + l]) continue;
          const Vec3 d = delta(xi, S_.x[j]);
          const float reach = static_cast<float>(E.r0[l]) + skin;
          if (dot(d, d) < reach * reach) js.push_back(j);
        }
      }
      std::sort(js.begin(), js.end());
      js.erase(std::unique(js.begin(), js.end()), js.end());
      for (std::uint32_t j : js) found[ch].push_back({i, j, {}});
    }
  });
  std::vector<ContactPair> next;
  for (auto& list : found) next.insert(next.end(), list.begin(), list.end());
  // Carry the histories of pairs that stay in the list (both lists sorted by (i, j)).
  std::size_t o = 0;
  for (auto& c : next) {
    while (o < S_.contacts.size() && pair_less(S_.contacts[o], c)) ++o;
    if (o < S_.contacts.size() && S_.contacts[o].i == c.i && S_.contacts[o].j == c.j) c = S_.contacts[o];
  }
  S_.contacts.swap(next);
  if (M_.ground) {
    std::vector<BodyContact> ground;
    std::size_t g = 0;
    for (std::uint32_t a : exposed_) {
      if (!near_ground(a)) continue;
      while (g < S_.ground_contacts.size() && S_.ground_contacts[g].automaton < a) ++g;
      const bool kept = g < S_.ground_contacts.size() && S_.ground_contacts[g].automaton == a;
      ground.push_back({a, kept ? S_.ground_contacts[g].h : ContactHistory{}});
    }
    S_.ground_contacts.swap(ground);
  }
  S_.x_at_rebuild = S_.x;
  reference_positions();
}

// A step: everything that acts on the automata from outside the lattice (explicit links, contacts, the
// ground, projectiles), from the positions at the start of the step; then the lattice's sweep (many-body
// terms, links, automata); then the breaks found.
std::int64_t CpuBackend::one_step() {
  PassTimer timer(profile_);
  const cpu::LatticeView v = view();
  std::vector<std::size_t> explicit_counts;
  if (!M_.explicit_links.i.empty()) {
    explicit_counts = explicit_link_pass(v);
    explicit_gather_pass(v.last);
  }
  timer.lap(0);
  contact_pass();
  ground_pass();
  timer.lap(1);
  const std::int64_t bad_projectile = projectile_pass();
  timer.lap(2);
  float max_move2 = 0;
  std::vector<std::size_t> counts;
  const std::int64_t bad = lattice_sweep(with_projectiles(v), counts, max_move2);
  timer.lap(3);
  grip_pass();
  apply_breaks(counts, explicit_counts, max_move2);
  if (!unsound_.empty()) expose_damaged(max_move2);
  timer.lap(4);
  ++S_.step;
  S_.time = clock_.time(S_.step, M_.dt);
  // Verlet-style list: rebuild once any automaton has moved half the skin since the last rebuild.
  const float half = 0.5f * M_.skin;
  if (max_move2 > half * half) {
    rebuild_contacts();
    ++profile_.rebuilds;
  }
  timer.lap(5);
  return bad != kAllFinite ? bad : bad_projectile;
}

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const Model& model) { return std::make_unique<CpuBackend>(model); }

State initial_state(const Model& m) {
  State s;
  const std::size_t n = m.size(), L = m.link_slots();
  s.x = m.position0;
  s.v = m.velocity0;
  s.w.assign(n, DVec3{});
  s.q.assign(n, Quat{});
  s.s.assign(n, Sym3{});
  s.mean_stress.assign(n, 0.0f);
  s.f.assign(n, Vec3{});
  s.t.assign(n, Vec3{});
  s.intact.resize(L);
  for (std::size_t l = 0; l < L; ++l) s.intact[l] = m.link_exists(l) ? 1 : 0;
  s.link_ut.assign(L, Vec3{});
  s.link_moment.assign(m.explicit_links.size(), Vec3{});
  if (m.softening()) s.link_damage.assign(L, 0.0f);
  for (const auto& p : m.projectiles) {
    ProjectileState ps;
    ps.position = p.position;
    ps.velocity = p.velocity;
    ps.angular_velocity = p.angular_velocity;
    s.projectiles.push_back(ps);
  }
  s.grip_work.assign(m.grip_velocity.size(), 0.0);
  s.grip_force.assign(m.grip_velocity.size(), Vec3{});
  for (std::size_t a = 0; a < n; ++a)
    if (m.grip[a] >= 0) s.v[a] = m.grip_velocity[m.grip[a]];
  return s;
}

}  // namespace mca
