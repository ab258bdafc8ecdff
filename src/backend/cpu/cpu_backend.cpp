// The CPU backend: the reference implementation of a step (physics.md secs. 3-7).
//
// A step is a sequence of passes over index ranges (links, contacts or automata), each a plain loop body
// that a thread pool (oneTBB here) or a CUDA grid can drive:
//   A links:       geometry and strain of intact links
//   B automata:    many-body terms P_i (volumetric strain of each automaton)
//   C links:       pair forces and torques (link_law.hpp), fracture criteria on the step's state
//   contacts:      unlinked pairs, then the ground, written per contact and added to automata in list order
//   projectiles:   their contacts with automata, the ground and each other; projectiles move
//   D automata:    gather forces in a fixed order, averaged stress, gravity, loads, integrate
// Links write their forces; automata gather them in link order. No floating-point atomics, no
// order-dependent reductions: results are bitwise identical for any thread count.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "backend/backend.hpp"
#include "grid/uniform_grid.hpp"
#include "physics/contact_law.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

namespace mca {
namespace {

constexpr std::size_t kChunk = 4096;  // fixed work chunks: per-chunk results are combined in chunk order

template <class F>
void parallel_range(std::size_t n, F&& body) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1024),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t k = r.begin(); k != r.end(); ++k) body(k);
                    });
}

template <class F>
void parallel_chunks(std::size_t n, F&& body) {
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t c) {
    body(c, c * kChunk, std::min(n, (c + 1) * kChunk));
  });
}

// Wall time per pass, summed over steps, printed when the backend is destroyed if MCA_PROFILE is set.
struct PassProfile {
  static constexpr int kPasses = 8;
  bool on = std::getenv("MCA_PROFILE") != nullptr;
  double seconds[kPasses] = {};
  std::int64_t steps = 0;
  ~PassProfile() {
    if (!on || steps == 0) return;
    static const char* names[kPasses] = {"link geometry", "many-body", "link forces", "contacts", "projectiles",
                                         "automata", "fracture", "contact list"};
    double total = 0;
    for (double t : seconds) total += t;
    std::fprintf(stderr, "cpu backend profile over %lld steps (%.3f s):\n", static_cast<long long>(steps), total);
    for (int k = 0; k < kPasses; ++k)
      std::fprintf(stderr, "  %-14s %8.3f ms/step  %5.1f %%\n", names[k], 1e3 * seconds[k] / steps,
                   100 * seconds[k] / total);
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

bool finite(Vec3 a) { return std::isfinite(a.x + a.y + a.z); }
bool finite(DVec3 a) { return std::isfinite(a.x + a.y + a.z); }

bool pair_less(const ContactPair& a, const ContactPair& b) { return a.i != b.i ? a.i < b.i : a.j < b.j; }

class CpuBackend final : public Backend {
 public:
  explicit CpuBackend(const Model& m) : M_(m) {
    const std::size_t n = m.size(), L = m.link_count();
    link_n_.resize(L);
    link_eps_.resize(L);
    link_out_.resize(L);
    // Pair constants that do not change during the run (without strengthening).
    link_G_.resize(L);
    link_kt_.resize(L);
    link_strength_.resize(L);
    link_inv_r0_.resize(L);
    for (std::size_t l = 0; l < L; ++l) link_inv_r0_[l] = 1.0f / m.link_r0[l];
    free_factor_.resize(m.groups.size());
    for (std::size_t g = 0; g < m.groups.size(); ++g)
      free_axis_factors(m.groups[g].lame_lambda, m.groups[g].shear_modulus, free_factor_[g].data());
    inv_mass_.resize(n);
    inv_inertia_.resize(n);
    inv_volume_.resize(n);
    for (std::size_t a = 0; a < n; ++a) {
      inv_mass_[a] = 1.0f / m.mass[a];
      inv_inertia_[a] = 1.0f / m.inertia[a];
      inv_volume_[a] = 1.0f / m.volume[a];
    }
    for (std::size_t l = 0; l < L; ++l) {
      const GroupParams& gi = m.groups[m.group[m.link_i[l]]];
      const GroupParams& gj = m.groups[m.group[m.link_j[l]]];
      link_G_[l] = harmonic(gi.shear_modulus, gj.shear_modulus);
      link_kt_[l] = kShearFactor * link_G_[l] * m.link_area[l] / m.link_r0[l];
      // Strengths of the weaker automaton (physics.md sec. 4), scaled by the class factors.
      const std::uint32_t i = m.link_i[l], j = m.link_j[l];
      const float ki = m.class_factor[i], kj = m.class_factor[j];
      const float tensile = std::min(ki * gi.tensile_strength, kj * gj.tensile_strength);
      const float compressive = std::min(ki * gi.compressive_strength, kj * gj.compressive_strength);
      link_strength_[l] = {tensile, tensile / compressive, std::min(ki * gi.fracture_strain, kj * gj.fracture_strain)};
      const float tau = 0.5f * (gi.damping_time + gj.damping_time);
      if (m.link_damping > 0.0f || tau > 0.0f) {
        if (link_c_.empty()) link_c_.resize(L);
        const float k = link_normal_stiffness(link_G_[l], gi.lame_lambda, gj.lame_lambda, m.link_area[l], m.link_r0[l]);
        link_c_[l] = link_dashpots(k, m.mass[i], m.mass[j], tau, m.link_damping);
      }
    }
    for (const auto& g : m.groups) strengthening_ = strengthening_ || g.strengthening.law != 0;
    // Adjacency with the link's axis and which end the automaton is packed in (no extra reads).
    adj_code_.resize(m.adj_link.size());
    for (std::size_t a = 0; a < n; ++a)
      for (std::uint32_t k = m.adj_begin[a]; k < m.adj_begin[a + 1]; ++k) {
        const std::uint32_t l = m.adj_link[k];
        adj_code_[k] = l | (static_cast<std::uint32_t>(m.link_axis[l]) << kAxisShift) | (m.link_j[l] == a ? kIsJ : 0u);
      }
    intact_count_.resize(n);
    many_body_.resize(n * 3);
    ext_f_.resize(n);
    ext_t_.resize(n);
    ext_s_.resize(n);
    has_ext_.assign(n, 0);
    grip_members_.resize(m.grip_velocity.size());
    for (std::size_t a = 0; a < n; ++a)
      if (m.grip[a] >= 0) grip_members_[m.grip[a]].push_back(static_cast<std::uint32_t>(a));
    r_max_ = 0;
    for (float r : m.radius) r_max_ = std::max(r_max_, r);
  }

  std::string name() const override { return "cpu"; }
  void upload(State s) override {
    S_ = std::move(s);
    for (std::size_t a = 0; a < M_.size(); ++a) {
      std::uint32_t c = 0;
      for (std::uint32_t k = M_.adj_begin[a]; k < M_.adj_begin[a + 1]; ++k) c += S_.intact[M_.adj_link[k]];
      intact_count_[a] = static_cast<std::uint8_t>(std::min<std::uint32_t>(c, 255));
    }
    if (S_.x_at_rebuild.size() != S_.x.size()) rebuild_contacts();
  }
  void download(State& s) const override { s = S_; }
  void set_initial_energy(double energy) override { S_.initial_energy = energy; }
  const State& state() const override { return S_; }

  StepHealth step(int steps) override {
    StepHealth h;
    for (int k = 0; k < steps; ++k) {
      // What is only read between calls (the averaged stress tensor, the applied forces) is written on
      // the last step; every step needs only the mean stress.
      last_step_ = k + 1 == steps;
      const std::int64_t bad = one_step();
      if (bad != kAllFinite) {
        h.flags |= kNonFinite;
        h.step = S_.step;
        if (bad >= 0) h.automaton = bad;
        else h.projectile = -2 - bad;
        break;
      }
    }
    return h;
  }

 private:
  // one_step's result when every position and velocity is finite; -2 - p flags projectile p.
  static constexpr std::int64_t kAllFinite = -1;

  std::int64_t one_step();
  void link_geometry_pass();
  void many_body_pass();
  void link_force_pass();
  void apply_breaks(const std::vector<std::vector<std::pair<std::uint32_t, std::uint8_t>>>& found);
  void contact_pass();
  void ground_pass();
  std::int64_t projectile_pass();
  std::int64_t automaton_pass(float& max_move2);
  void rebuild_contacts();
  bool linked(std::uint32_t i, std::uint32_t j) const;
  bool near_ground(std::uint32_t a) const;
  void add_external(std::uint32_t a, Vec3 f, Vec3 t, const Sym3& s) {
    ext_f_[a] += f;
    ext_t_[a] += t;
    ext_s_[a] += s;
    has_ext_[a] = 1;
  }

  const Model& M_;
  State S_;
  // scratch, rebuilt every step
  // Per link, written by the link pass and gathered by both ends in the automaton pass.
  struct LinkGather {
    Vec3 force;   // on i; j gets the opposite
    Vec3 torque;  // on both
    float trace;  // (r0/2) n . F: the link's share of the trace of both automata's averaged stress
    float unused;
  };
  // A contact's result, written in parallel and added to its bodies in list order.
  struct ContactOut {
    Vec3 f, ti, tj, n;
    float ri, rj;
    bool on;
  };
  bool last_step_ = true;
  std::vector<Vec3> link_n_;
  std::vector<LinkGather> link_out_;
  std::vector<float> link_eps_, many_body_;
  std::vector<float> link_G_, link_kt_;  // pair shear modulus, shear spring
  std::vector<LinkDashpots> link_c_;     // dashpots (empty when the scene has none)
  std::vector<float> inv_mass_, inv_inertia_, inv_volume_;
  std::vector<PairStrength> link_strength_;
  std::vector<float> link_inv_r0_;
  std::vector<std::uint8_t> intact_count_;  // intact links per automaton (6: boxed in, see rebuild)
  std::vector<std::uint32_t> exposed_;
  // adj_link with bits 29-30 = the link's axis and bit 31 = "this automaton is the link's j".
  static constexpr std::uint32_t kLinkMask = (1u << 29) - 1, kAxisShift = 29, kIsJ = 1u << 31;
  std::vector<std::uint32_t> adj_code_;
  std::vector<std::array<float, 4>> free_factor_;  // per group, see volumetric_strain
  bool strengthening_ = false;
  std::vector<Vec3> ext_f_, ext_t_;
  std::vector<Sym3> ext_s_;
  std::vector<std::uint8_t> has_ext_;
  std::vector<std::vector<std::uint32_t>> grip_members_;
  std::vector<ContactOut> contact_out_;
  UniformGrid grid_;
  float r_max_ = 0;
  PassProfile profile_;
};

bool CpuBackend::linked(std::uint32_t i, std::uint32_t j) const {
  for (std::uint32_t k = M_.adj_begin[i]; k < M_.adj_begin[i + 1]; ++k) {
    const std::uint32_t l = M_.adj_link[k];
    if (S_.intact[l] && (M_.link_i[l] == j || M_.link_j[l] == j)) return true;
  }
  return false;
}

// Whether automaton a is within reach of the ground: its height above it is below r + skin.
bool CpuBackend::near_ground(std::uint32_t a) const {
  const DVec3& x = S_.x[a];
  const double above = x.x * M_.up.x + x.y * M_.up.y + x.z * M_.up.z - M_.ground_height;
  return above < static_cast<double>(M_.radius[a]) + M_.skin;
}

void CpuBackend::link_geometry_pass() {
  const std::uint8_t* __restrict intact = S_.intact.data();
  const std::uint32_t* __restrict li = M_.link_i.data();
  const std::uint32_t* __restrict lj = M_.link_j.data();
  const DVec3* __restrict x = S_.x.data();
  const float* __restrict r0 = M_.link_r0.data();
  const float* __restrict inv_r0 = link_inv_r0_.data();
  Vec3* __restrict ln = link_n_.data();
  float* __restrict leps = link_eps_.data();
  parallel_range(M_.link_count(), [=](std::size_t l) {  // pointers by value: no reload per link
    if (!intact[l]) return;
    const LinkGeometry g = link_geometry(x[li[l]], x[lj[l]], r0[l], inv_r0[l]);
    ln[l] = g.n;
    leps[l] = g.eps;
  });
}

void CpuBackend::many_body_pass() {
  const std::uint32_t* __restrict adj_begin = M_.adj_begin.data();
  const std::uint32_t* __restrict adj_code = adj_code_.data();
  const std::uint8_t* __restrict intact = S_.intact.data();
  const float* __restrict leps = link_eps_.data();
  const std::uint8_t* __restrict group = M_.group.data();
  float* __restrict mb = many_body_.data();
  const GroupParams* groups = M_.groups.data();
  const std::array<float, 4>* free_factor = free_factor_.data();
  const bool strengthening = strengthening_;
  parallel_range(M_.size(), [=](std::size_t a) {  // pointers by value: no reload per automaton
    float sum[3] = {0, 0, 0};
    int cnt[3] = {0, 0, 0};
    const int grp = group[a];
    for (std::uint32_t k = adj_begin[a]; k < adj_begin[a + 1]; ++k) {
      const std::uint32_t code = adj_code[k];
      const std::uint32_t l = code & kLinkMask;
      if (!intact[l]) continue;
      const int ax = static_cast<int>((code >> kAxisShift) & 3u);
      // With strengthening, theta is built from this automaton's strengthened strains (link_law.hpp).
      sum[ax] += strengthening ? strengthened_strain(groups[grp].strengthening, leps[l]).s : leps[l];
      ++cnt[ax];
    }
    const float lam_theta = groups[grp].lame_lambda * volumetric_strain(sum, cnt, free_factor[grp].data());
    for (int ax = 0; ax < 3; ++ax) mb[3 * a + ax] = cnt[ax] ? lam_theta * inverse_count(cnt[ax]) : 0.0f;
  });
}

void CpuBackend::link_force_pass() {
  const float dt = M_.dt;
  const std::size_t L = M_.link_count();
  std::vector<std::vector<std::pair<std::uint32_t, std::uint8_t>>> found((L + kChunk - 1) / kChunk);
  parallel_chunks(L, [&](std::size_t ch, std::size_t b, std::size_t e_end) {
    const std::uint8_t* __restrict intact = S_.intact.data();
    const std::uint32_t* __restrict li = M_.link_i.data();
    const std::uint32_t* __restrict lj = M_.link_j.data();
    const float* __restrict leps = link_eps_.data();
    const Vec3* __restrict ln = link_n_.data();
    const float* __restrict mb = many_body_.data();
    const Vec3* __restrict v = S_.v.data();
    const Vec3* __restrict w = S_.w.data();
    Vec3* __restrict ut = S_.link_ut.data();
    LinkGather* __restrict lf = link_out_.data();
    const float* __restrict ms = S_.mean_stress.data();
    const std::uint8_t* __restrict axis = M_.link_axis.data();
    const float* __restrict r0s = M_.link_r0.data();
    const float* __restrict inv_r0s = link_inv_r0_.data();
    const float* __restrict areas = M_.link_area.data();
    const float* __restrict Gs = link_G_.data();
    const float* __restrict kts = link_kt_.data();
    const LinkDashpots* __restrict damps = link_c_.empty() ? nullptr : link_c_.data();
    const PairStrength* __restrict strengths = link_strength_.data();
    const std::uint8_t* __restrict group = M_.group.data();
    const GroupParams* groups = M_.groups.data();
    const bool strengthening = strengthening_;
    const float kv = M_.stress_coefficient;
    for (std::size_t l = b; l < e_end; ++l) {
      if (!intact[l]) continue;
      const std::uint32_t i = li[l], j = lj[l];
      const float eps = leps[l];
      const int ax = axis[l];
      const float r0 = r0s[l];
      StrengthenedStrain si{eps, 1.0f, 1.0f}, sj = si;
      float kt = kts[l], kt_slope = 0.0f;
      if (strengthening) {
        const Strengthening& gi = groups[group[i]].strengthening;
        const Strengthening& gj = groups[group[j]].strengthening;
        si = strengthened_strain(gi, eps);
        sj = strengthened_strain(gj, eps);
        kt = kts[l] * 0.5f * (si.f + sj.f);
        kt_slope = kts[l] * 0.5f * (strengthening_slope(gi, eps) + strengthening_slope(gj, eps)) * inv_r0s[l];
      }
      LinkInput in;
      in.g = {ln[l], r0 * (1.0f + eps), eps};
      in.area = areas[l];
      in.sigma = link_normal_stress(Gs[l], eps, si, sj, mb[3 * i + ax], mb[3 * j + ax]);
      in.kt = kt;
      in.kt_slope = kt_slope;
      in.damping = damps ? damps[l] : LinkDashpots{0.0f, 0.0f};
      in.vi = v[i];
      in.vj = v[j];
      in.wi = w[i];
      in.wj = w[j];
      in.ut = ut[l];
      in.dt = dt;
      const LinkOutput out = link_force(in);
      const float p = 0.5f * (ms[i] + ms[j]);
      const int crit = link_break_criterion(eps * r0, r0, out.sigma, out.tau2, p, strengths[l], kv);
      if (crit >= 0) {
        found[ch].push_back({static_cast<std::uint32_t>(l), static_cast<std::uint8_t>(crit)});
        continue;  // S_.intact[l] is cleared below, in link order
      }
      // What both ends gather: the force, the torque (r/2) n x F_t = (r/2) n x F (n x n = 0, r = r0 (1 + eps))
      // and the trace of the Love average term (r0/2) sym(n (x) F) of physics.md sec. 3.
      const Vec3 hf = out.force_i * (0.5f * r0);
      const Vec3 nl = in.g.n;
      lf[l] = {out.force_i, cross(nl, hf) * (1.0f + eps), dot(nl, hf), 0.0f};
      ut[l] = out.ut;
    }
  });
  apply_breaks(found);
}

// Breaks found in the link pass, in link order: the link stops carrying force from this step on, and the
// broken pair touches at once, so it joins the contact list (and the ground list, when near it) now, not
// at the next rebuild.
void CpuBackend::apply_breaks(const std::vector<std::vector<std::pair<std::uint32_t, std::uint8_t>>>& found) {
  std::vector<ContactPair> fresh;
  std::vector<std::uint32_t> ground_fresh;
  for (const auto& list : found)
    for (const auto& [l, crit] : list) {
      const std::uint32_t i = M_.link_i[l], j = M_.link_j[l];
      S_.intact[l] = 0;
      --intact_count_[i];
      --intact_count_[j];
      S_.link_ut[l] = Vec3{};
      S_.breaks.push_back({S_.step, l, static_cast<BreakCriterion>(crit)});
      ++S_.broken_by[crit];
      fresh.push_back({i, j, {}});
      if (M_.ground) {
        if (near_ground(i)) ground_fresh.push_back(i);
        if (near_ground(j)) ground_fresh.push_back(j);
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
  const float dt = M_.dt;
  parallel_range(C.size(), [&](std::size_t p) {
    ContactPair& cp = C[p];
    const std::uint32_t i = cp.i, j = cp.j;
    const float ri = M_.radius[i], rj = M_.radius[j];
    const SphereGap gap = sphere_gap(S_.x[i], S_.x[j], static_cast<double>(ri) + rj);
    if (gap.overlap <= 0.0f || !gap.valid) {
      cp.h = {};
      contact_out_[p].on = false;
      return;
    }
    const Vec3 n = gap.n;
    ContactInput in;
    in.n = n;
    in.overlap = gap.overlap;
    in.vrel = (S_.v[j] + cross(S_.w[j], -rj * n)) - (S_.v[i] + cross(S_.w[i], ri * n));
    in.wrel = S_.w[j] - S_.w[i];
    in.s = body_contact_springs(M_.contact_material(M_.group[i], M_.group[j]), M_.zeta_pair[M_.group[i] * M_.groups.size() + M_.group[j]], ri, rj, reduced(M_.mass[i], M_.mass[j]),
                      reduced(M_.inertia[i], M_.inertia[j]));
    in.ut = cp.h.ut;
    in.mr = cp.h.mr;
    in.dt = dt;
    const ContactOutput o = contact_force(in);
    cp.h = {o.ut, o.mr};
    contact_out_[p] = {o.force_i, cross(ri * n, o.ft) + o.torque_i, cross(rj * n, o.ft) - o.torque_i, n, ri, rj, true};
  });
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
  const float dt = M_.dt;
  const Vec3 nrm = -M_.up;  // from the automaton to the ground
  parallel_range(G.size(), [&](std::size_t k) {
    BodyContact& bc = G[k];
    const std::uint32_t a = bc.automaton;
    const float r = M_.radius[a];
    const float overlap = ground_overlap(S_.x[a], M_.up, M_.ground_height, r);
    if (overlap <= 0.0f) {
      bc.h = {};
      contact_out_[k].on = false;
      return;
    }
    ContactInput in;
    in.n = nrm;
    in.overlap = overlap;
    in.vrel = -(S_.v[a] + cross(S_.w[a], r * nrm));
    in.wrel = -S_.w[a];
    in.s = body_contact_springs(M_.ground_contact[M_.group[a]], M_.zeta_ground[M_.group[a]], r, INFINITY, M_.mass[a], M_.inertia[a]);
    in.ut = bc.h.ut;
    in.mr = bc.h.mr;
    in.dt = dt;
    const ContactOutput o = contact_force(in);
    bc.h = {o.ut, o.mr};
    contact_out_[k] = {o.force_i, cross(r * nrm, o.ft) + o.torque_i, {}, nrm, r, 0.0f, true};
  });
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
    // Candidates: automata touching the sphere, found per fixed chunk and joined in chunk order.
    const std::size_t chunks = (n + kChunk - 1) / kChunk;
    std::vector<std::vector<std::uint32_t>> found(chunks);
    const DVec3 c = ps.position;
    parallel_chunks(n, [&](std::size_t ch, std::size_t b, std::size_t e) {
      for (std::size_t a = b; a < e; ++a) {
        const Vec3 d = delta(c, S_.x[a]);
        const float reach = P.radius + M_.radius[a];
        if (dot(d, d) < reach * reach) found[ch].push_back(static_cast<std::uint32_t>(a));
      }
    });
    std::vector<BodyContact> next;
    std::size_t old = 0;
    for (const auto& list : found)
      for (std::uint32_t a : list) {
        while (old < ps.contacts.size() && ps.contacts[old].automaton < a) ++old;
        const ContactHistory prev =
            (old < ps.contacts.size() && ps.contacts[old].automaton == a) ? ps.contacts[old].h : ContactHistory{};
        const float ra = M_.radius[a];
        const SphereGap gap = sphere_gap(S_.x[a], c, static_cast<double>(P.radius) + ra);  // automaton to projectile
        if (!gap.valid) continue;
        const Vec3 nrm = gap.n;
        ContactInput in;
        in.n = nrm;
        in.overlap = gap.overlap;
        in.vrel = (ps.velocity + cross(ps.angular_velocity, -P.radius * nrm)) - (S_.v[a] + cross(S_.w[a], ra * nrm));
        in.wrel = ps.angular_velocity - S_.w[a];
        in.s = body_contact_springs(M_.projectile_contact(p, M_.group[a]), P.zeta_automata[M_.group[a]], ra, P.radius,
                          P.kinematic ? M_.mass[a] : reduced(M_.mass[a], P.mass),
                          P.kinematic ? M_.inertia[a] : reduced(M_.inertia[a], P.inertia));
        in.ut = prev.ut;
        in.mr = prev.mr;
        in.dt = dt;
        const ContactOutput o = contact_force(in);
        if (o.fn <= 0.0f && length(o.ut) == 0.0f) continue;
        next.push_back({a, {o.ut, o.mr}});
        add_external(a, o.force_i, cross(ra * nrm, o.ft) + o.torque_i, sym_outer(nrm, o.force_i, ra));
        fsum[p] -= o.force_i;
        tsum[p] += cross(P.radius * nrm, o.ft) - o.torque_i;
      }
    ps.contacts.swap(next);
    if (M_.ground) {
      // The ground, as for an automaton: the projectile is the first body.
      const Vec3 nrm = -M_.up;
      ContactInput in;
      in.n = nrm;
      in.overlap = ground_overlap(c, M_.up, M_.ground_height, P.radius);
      in.vrel = -(ps.velocity + cross(ps.angular_velocity, P.radius * nrm));
      in.wrel = -ps.angular_velocity;
      in.s = body_contact_springs(M_.projectile_ground_contact(p), P.zeta_ground, P.radius, INFINITY, P.mass, P.inertia);
      in.ut = ps.ground.ut;
      in.mr = ps.ground.mr;
      in.dt = dt;
      const ContactOutput o = contact_force(in);
      ps.ground = {o.ut, o.mr};
      fsum[p] += o.force_i;
      tsum[p] += cross(P.radius * nrm, o.ft) + o.torque_i;
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
      const float m_eff = A.kinematic ? B.mass : (B.kinematic ? A.mass : reduced(A.mass, B.mass));
      const float j_eff = A.kinematic ? B.inertia : (B.kinematic ? A.inertia : reduced(A.inertia, B.inertia));
      ContactInput in;
      in.n = nrm;
      in.overlap = gap.overlap;
      in.vrel = (b.velocity + cross(b.angular_velocity, -B.radius * nrm)) - (a.velocity + cross(a.angular_velocity, A.radius * nrm));
      in.wrel = b.angular_velocity - a.angular_velocity;
      in.s = body_contact_springs(M_.projectile_pair_contact(p, q), M_.zeta_projectiles[p * np + q], A.radius, B.radius, m_eff, j_eff);
      in.ut = prev.ut;
      in.mr = prev.mr;
      in.dt = dt;
      const ContactOutput o = contact_force(in);
      next_pairs.push_back({p, q, {o.ut, o.mr}});
      fsum[p] += o.force_i;
      fsum[q] -= o.force_i;
      tsum[p] += cross(A.radius * nrm, o.ft) + o.torque_i;
      tsum[q] += cross(B.radius * nrm, o.ft) - o.torque_i;
    }
  S_.projectile_contacts.swap(next_pairs);
  for (std::size_t p = 0; p < np; ++p) {
    const ProjectileParams& P = M_.projectiles[p];
    ProjectileState& ps = S_.projectiles[p];
    ps.force = fsum[p];
    if (P.kinematic) {
      // Power the projectile puts in: minus that of the forces on it at its own velocities.
      ps.work -= (static_cast<double>(dot(fsum[p], ps.velocity)) + dot(tsum[p], ps.angular_velocity)) * dt;
    } else {
      ps.velocity += (fsum[p] * (1.0f / P.mass) + M_.gravity) * dt;
      ps.angular_velocity += tsum[p] * (dt / P.inertia);
      ps.orientation = integrate_orientation(ps.orientation, ps.angular_velocity, dt);
    }
    ps.position += ps.velocity * dt;
    if (!finite(ps.position) || !finite(ps.velocity) || !finite(ps.angular_velocity))
      return -2 - static_cast<std::int64_t>(p);
  }
  return kAllFinite;
}

std::int64_t CpuBackend::automaton_pass(float& max_move2) {
  const float dt = M_.dt;
  const std::size_t n = M_.size();
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<float> chunk_move(chunks, 0.0f);
  std::vector<std::int64_t> chunk_bad(chunks, kAllFinite);
  parallel_chunks(n, [&](std::size_t ch, std::size_t b, std::size_t e) {
    float move2 = 0;
    // Plain local pointers: the compiler cannot keep vector internals in registers across the stores.
    // Every access to an array goes through its one pointer (restrict forbids reaching it otherwise).
    const std::uint32_t* __restrict adj_begin = M_.adj_begin.data();
    const std::uint32_t* __restrict adj_code = adj_code_.data();
    const std::uint8_t* __restrict intact = S_.intact.data();
    const LinkGather* __restrict lf = link_out_.data();
    const Vec3* __restrict ln = link_n_.data();
    const float* __restrict r0s = M_.link_r0.data();
    const float* __restrict mass = M_.mass.data();
    const std::int16_t* __restrict grip = M_.grip.data();
    const float* __restrict inv_mass = inv_mass_.data();
    const float* __restrict inv_inertia = inv_inertia_.data();
    const float* __restrict inv_volume = inv_volume_.data();
    const Vec3* __restrict loads = M_.load.empty() ? nullptr : M_.load.data();
    DVec3* __restrict xs = S_.x.data();
    Vec3* __restrict vs = S_.v.data();
    Vec3* __restrict ws = S_.w.data();
    Quat* __restrict qs = S_.q.data();
    Sym3* __restrict stress = S_.s.data();
    Vec3* __restrict f_out = S_.f.data();
    Vec3* __restrict t_out = S_.t.data();
    const DVec3* __restrict x_ref = S_.x_at_rebuild.data();
    std::uint8_t* __restrict has_ext = has_ext_.data();
    Vec3* __restrict ext_f = ext_f_.data();
    Vec3* __restrict ext_t = ext_t_.data();
    Sym3* __restrict ext_s = ext_s_.data();
    const std::uint8_t* __restrict intact_count = intact_count_.data();
    float* __restrict mean_s = S_.mean_stress.data();
    const Vec3 gravity = M_.gravity;
    const bool last = last_step_;
    const float alpha = M_.local_damping;
    for (std::size_t a = b; a < e; ++a) {
      const float m = mass[a];
      Vec3 f = gravity * m;
      Vec3 t;
      Sym3 s;               // contacts, ground, projectiles: every step
      Sym3 s_links;         // links: on the last step only
      float trace = 0;      // trace of the links' part: every step
      for (std::uint32_t k = adj_begin[a]; k < adj_begin[a + 1]; ++k) {
        const std::uint32_t code = adj_code[k];
        const std::uint32_t l = code & kLinkMask;
        if (!intact[l]) continue;
        const LinkGather& g = lf[l];
        if (code & kIsJ) f -= g.force;
        else f += g.force;
        t += g.torque;
        trace += g.trace;
        if (last) s_links += sym_outer(ln[l], g.force, 0.5f * r0s[l]);
      }
      if (has_ext[a]) {
        f += ext_f[a];
        t += ext_t[a];
        s += ext_s[a];
        ext_f[a] = Vec3{};
        ext_t[a] = Vec3{};
        ext_s[a] = Sym3{};
        has_ext[a] = 0;
      }
      if (loads) f += loads[a];
      const float inv_v = inv_volume[a];
      if (last) {
        Sym3 total = s_links;
        total += s;
        total.xx *= inv_v; total.yy *= inv_v; total.zz *= inv_v;
        total.xy *= inv_v; total.yz *= inv_v; total.zx *= inv_v;
        stress[a] = total;
      }
      // From the traces on every step, so the dynamics do not depend on how steps are grouped into calls.
      mean_s[a] = (trace + s.xx + s.yy + s.zz) * inv_v * (1.0f / 3.0f);
      Body body{xs[a], vs[a], ws[a], qs[a]};
      if (grip[a] >= 0) {
        // Held: moves with the grip, does not turn. ext_f keeps the force the body puts on the grip.
        body.v = M_.grip_velocity[grip[a]];
        body.x += body.v * dt;
        body.w = Vec3{};
        ext_f[a] = f;
      } else {
        integrate_body(body, f, t, inv_mass[a], inv_inertia[a], dt, alpha);
      }
      if (last) {
        f_out[a] = f;
        t_out[a] = t;
      }
      if (!(finite(body.x) && finite(body.v) && finite(body.w))) {
        if (chunk_bad[ch] == kAllFinite) chunk_bad[ch] = static_cast<std::int64_t>(a);
      }
      xs[a] = body.x;
      vs[a] = body.v;
      ws[a] = body.w;
      qs[a] = body.q;
      // Only exposed automata are in the contact lists (see rebuild_contacts), so only their motion
      // can make them stale.
      if (intact_count[a] < 6) {
        const Vec3 dm = delta(x_ref[a], body.x);
        move2 = std::max(move2, dot(dm, dm));
      }
    }
    chunk_move[ch] = move2;
  });
  max_move2 = 0;
  for (float v : chunk_move) max_move2 = std::max(max_move2, v);
  // Grip forces: the force the grip exerts is minus what the body pushes on it.
  for (std::size_t g = 0; g < grip_members_.size(); ++g) {
    Vec3 f;
    for (std::uint32_t a : grip_members_[g]) {
      f -= ext_f_[a];
      ext_f_[a] = Vec3{};
    }
    S_.grip_force[g] = f;
    S_.grip_work[g] += static_cast<double>(dot(f, M_.grip_velocity[g])) * dt;
  }
  for (std::int64_t b : chunk_bad)
    if (b != kAllFinite) return b;
  return kAllFinite;
}

void CpuBackend::rebuild_contacts() {
  const float skin = M_.skin;
  // Only exposed automata can touch anything but their linked neighbours: one with all six lattice
  // links intact is boxed in by automata at distance ~d, and its diagonal neighbours (1.41 d) are out of
  // reach (r_i + r_j + skin < 1.41 d for skin < 0.41 d, which validation enforces). In a struck wall that
  // is the surface and the damage, a small share of the automata. The same holds for the ground.
  exposed_.clear();
  for (std::size_t a = 0; a < M_.size(); ++a)
    if (intact_count_[a] < 6) exposed_.push_back(static_cast<std::uint32_t>(a));
  const std::size_t n = exposed_.size();
  grid_.build(S_.x.data(), n, 2.0f * r_max_ + skin, exposed_.data());
  const std::size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<std::vector<ContactPair>> found(chunks);
  parallel_chunks(n, [&](std::size_t ch, std::size_t b, std::size_t e) {
    std::vector<std::uint32_t> js;
    for (std::size_t k = b; k < e; ++k) {
      const std::uint32_t i = exposed_[k];
      const DVec3 xi = S_.x[i];
      js.clear();
      grid_.for_each_candidate(xi, [&](std::uint32_t j) {
        if (j <= i) return;
        const Vec3 d = delta(xi, S_.x[j]);
        const float reach = M_.radius[i] + M_.radius[j] + skin;
        if (dot(d, d) < reach * reach && !linked(i, j)) js.push_back(j);
      });
      std::sort(js.begin(), js.end());
      for (std::uint32_t j : js) found[ch].push_back({i, j, {}});
    }
  });
  std::vector<ContactPair> next;
  for (auto& list : found) next.insert(next.end(), list.begin(), list.end());
  // Carry the histories of pairs that stay in the list (both lists sorted by (i, j)).
  std::size_t o = 0;
  for (auto& c : next) {
    while (o < S_.contacts.size() && pair_less(S_.contacts[o], c)) ++o;
    if (o < S_.contacts.size() && S_.contacts[o].i == c.i && S_.contacts[o].j == c.j) c.h = S_.contacts[o].h;
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
}

std::int64_t CpuBackend::one_step() {
  PassTimer timer(profile_);
  link_geometry_pass();
  timer.lap(0);
  many_body_pass();
  timer.lap(1);
  link_force_pass();
  timer.lap(2);
  contact_pass();
  ground_pass();
  timer.lap(3);
  const std::int64_t bad_projectile = projectile_pass();
  timer.lap(4);
  float max_move2 = 0;
  const std::int64_t bad = automaton_pass(max_move2);
  timer.lap(5);
  ++S_.step;
  S_.time = static_cast<double>(S_.step) * M_.dt;
  // Verlet-style list: rebuild once any automaton has moved half the skin since the last rebuild.
  const float half = 0.5f * M_.skin;
  if (max_move2 > half * half) rebuild_contacts();
  timer.lap(7);
  return bad != kAllFinite ? bad : bad_projectile;
}

}  // namespace

std::unique_ptr<Backend> make_cpu_backend(const Model& model) { return std::make_unique<CpuBackend>(model); }

State initial_state(const Model& m) {
  State s;
  const std::size_t n = m.size(), L = m.link_count();
  s.x = m.position0;
  s.v = m.velocity0;
  s.w.assign(n, Vec3{});
  s.q.assign(n, Quat{});
  s.s.assign(n, Sym3{});
  s.mean_stress.assign(n, 0.0f);
  s.f.assign(n, Vec3{});
  s.t.assign(n, Vec3{});
  s.intact.assign(L, 1);
  s.link_ut.assign(L, Vec3{});
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
