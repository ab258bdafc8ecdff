#pragma once
// The CUDA backend's step: every pass of the CPU backend's step (cpu_backend.cpp) as kernels over device
// arrays (device_kernels.hpp), in the CPU's order of operations, with the device-wide primitives of Dev:
// DeviceBackend<CudaDevice> runs on a GPU (cuda_device.cuh), DeviceBackend<HostDevice> is its host
// emulation (host_device.hpp), which tests every line of this logic on a machine without a GPU.
//
// The host keeps only scalars during a run (the list sizes, the step, the breaks' records). It reads the
// device once a step: the step's status (StepStatus: the largest move since the contact rebuild, the
// first value not finite, the number of breaks, the sizes of the projectiles' next lists). Breaks are
// applied on the device; a step with breaks reads once more (the ground list's growth, the largest move of
// the automata that lost links) unless they are few and follow a step with breaks (apply_breaks), and a
// step that rebuilds the contact lists reads their sizes. The next step's many-body terms are launched
// behind the status's copy, so that the device is not idle while the host reads it. The whole state comes
// back only when asked for (state(), download()).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "backend/backend.hpp"
#include "backend/cuda/device_kernels.hpp"
#include "backend/cuda/draw_kernels.hpp"
#include "backend/step_constants.hpp"

namespace mca::gpu {

template <class Dev>
class DeviceBackend : public StateBackend {
  template <class T>
  using Buf = typename Dev::template Buffer<T>;

 public:
  explicit DeviceBackend(const Model& m) : M_(m), K_(build_step_constants(m)) {
    const std::size_t n = m.size(), L = m.link_slots(), ne = m.explicit_links.size(), G = m.groups.size();
    const auto& E = m.explicit_links;
    // The model.
    Dev::upload(position0_, m.position0);
    Dev::upload(mass_, m.mass);
    Dev::upload(radius_, m.radius);
    Dev::upload(inertia_, m.inertia);
    Dev::upload(volume_, m.volume);
    Dev::upload(group_, m.group);
    Dev::upload(object_, m.object);
    Dev::upload(object_random_, m.object_random);
    Dev::upload(face_, m.face);
    if (!m.face.empty()) {
      std::vector<Vec3> axes;
      for (const auto& o : m.object_axes) axes.insert(axes.end(), o.begin(), o.end());
      Dev::upload(axes_, axes);
    }
    Dev::upload(grip_, m.grip);
    Dev::upload(grip_velocity_, m.grip_velocity);
    Dev::upload(load_, m.load);
    Dev::upload(neighbour_, m.neighbour);
    Dev::upload(neighbour_below_, m.neighbour_below);
    Dev::upload(link_rest_, m.link_rest);
    Dev::upload(link_inv_rest_, m.link_inv_rest);
    Dev::upload(link_strength_, m.link_strength);
    Dev::upload(e_first_, E.first);
    Dev::upload(e_of_, E.of);
    Dev::upload(e_i_, E.i);
    Dev::upload(e_j_, E.j);
    Dev::upload(e_r0_, E.r0);
    Dev::upload(e_area_, E.area);
    Dev::upload(free_face_, m.free_face);
    Dev::upload(groups_, m.groups);
    Dev::upload(contact_, m.contact);
    Dev::upload(ground_contact_, m.ground_contact);
    Dev::upload(zeta_pair_, m.zeta_pair);
    Dev::upload(zeta_ground_, m.zeta_ground);
    Dev::upload(zeta_pair_held_, m.zeta_pair_held);
    // The step's constants.
    Dev::upload(inv_mass_, K_.inv_mass);
    Dev::upload(inv_inertia_, K_.inv_inertia);
    Dev::upload(inv_volume_, K_.inv_volume);
    Dev::upload(tensile_, K_.tensile);
    Dev::upload(compressive_, K_.compressive);
    Dev::upload(break_strain_, K_.break_strain);
    Dev::upload(pairs_, K_.pairs);
    Dev::upload(free_factor_, K_.free_factor);
    Dev::upload(lambda_over_2g_, K_.lambda_over_2g);
    for (auto [to, from] : {std::pair{&ex_r0f_, &K_.ex_r0f}, {&ex_inv_r0_, &K_.ex_inv_r0}, {&ex_area_, &K_.ex_area},
                            {&ex_to_stress_, &K_.ex_to_stress}, {&ex_G_, &K_.ex_G}, {&ex_kt_, &K_.ex_kt},
                            {&ex_damp_n_, &K_.ex_damp_n}, {&ex_damp_t_, &K_.ex_damp_t}, {&ex_soft_, &K_.ex_soft},
                            {&ex_k_twist_, &K_.ex_k_twist}, {&ex_k_in_, &K_.ex_k_in}, {&ex_s_in_, &K_.ex_s_in},
                            {&ex_k_out_, &K_.ex_k_out}, {&ex_s_out_, &K_.ex_s_out}, {&ex_s_twist_, &K_.ex_s_twist},
                            {&ex_m0x_, &K_.ex_m0x}, {&ex_m0y_, &K_.ex_m0y}, {&ex_m0z_, &K_.ex_m0z},
                            {&ex_tensile_, &K_.ex_tensile}, {&ex_compressive_, &K_.ex_compressive},
                            {&ex_strain_, &K_.ex_strain}})
      Dev::upload(*to, *from);
    Dev::upload(ex_bends_, K_.ex_bends);
    Dev::upload(ex_area_r0_, K_.ex_area_r0);
    Dev::upload(explicit_automata_, K_.explicit_automata);
    Dev::upload(ex_ends_, K_.ex_ends);
    Dev::upload(bend_c_, K_.bend_c);
    Dev::upload(pair_springs_, K_.pair_springs);
    Dev::upload(ground_springs_, K_.ground_springs);
    std::vector<std::uint32_t> first{0}, members;
    for (const auto& g : K_.grip_members) {
      members.insert(members.end(), g.begin(), g.end());
      first.push_back(static_cast<std::uint32_t>(members.size()));
    }
    Dev::upload(grip_first_, first);
    Dev::upload(grip_members_, members);
    // Projectiles.
    const std::size_t np = m.projectiles.size();
    std::vector<ProjectileConstants> pc(np);
    std::vector<ContactMaterial> pm(np * G);
    std::vector<float> pz(np * G), pzh(m.grip_velocity.empty() ? 0 : np * G);
    for (std::size_t p = 0; p < np; ++p) {
      const ProjectileParams& P = m.projectiles[p];
      pc[p] = {P.position, P.radius, P.mass, P.inertia, P.kinematic, P.group, P.rolling, P.twisting,
               body_contact_springs(m.projectile_ground_contact(p), P.zeta_ground, P.radius, INFINITY, P.mass, P.inertia)};
      for (std::size_t g = 0; g < G; ++g) {
        pm[p * G + g] = m.projectile_contact(p, g);
        pz[p * G + g] = P.zeta_automata[g];
        if (!pzh.empty()) pzh[p * G + g] = P.zeta_held[g];
      }
    }
    Dev::upload(proj_constants_, pc);
    Dev::upload(proj_material_, pm);
    Dev::upload(proj_zeta_, pz);
    Dev::upload(proj_zeta_held_, pzh);
    Dev::upload(zeta_projectiles_, m.zeta_projectiles);
    fsum_.resize(np);
    tsum_.resize(np);
    segment_.resize(np + 1);
    pair_touch_count_.resize(np);
    pair_offset_.resize(np + 1);
    proj_start_.resize(np + 1);
    proj_start_next_.resize(np + 1);
    touch_count_.resize(n);
    if (np) for (auto* b : {&touch_a_, &touch_p_}) b->resize(first_touch_room);
    touch_offset_.resize(n + 1);
    status_.resize(2);
    // State and scratch.
    for (auto* b : {&px_, &py_, &pz_, &vx_, &vy_, &vz_, &wx_, &wy_, &wz_}) b->resize(n);
    for (auto* b : {&qw_, &qx_, &qy_, &qz_}) b->resize(n);
    ref_.resize(cpu::tiled_size(n, cpu::kRefRows));
    Dev::fill(ref_, 0.0);  // (the tiles' padding, which no kernel writes, is downloaded with the rows)
    for (auto* b : {&utx_, &uty_, &utz_}) b->resize(L);
    many_body_.resize(3 * cpu::scratch_stride(n));
    // The fused lattice kernel where there are no explicit links (their slots would need copying too), with
    // the second copy of what it writes that its neighbours read; else the links' results through memory.
    const CudaLattice how = cuda_lattice();
    fused_ = ne == 0 && M_.lattice_slots() > 0 && how.fused;
    fused_blocks_ = how.blocks;
    // Lattice links (the random lattice and surface mode have none: their many-body terms, which only the
    // lattice links read, are never computed).
    lattice_links_ = m.has_lattice_links();
    if (fused_) {
      for (auto& b : next_d_) b.resize(n);
      next_f_[0].resize(n);
      for (int k = 1; k < 4; ++k) next_f_[k].resize(L);
    } else {  // the links' results and directions (for the averaged stress) through memory
      out_.resize(3 * cpu::tiled_size(n, cpu::kOutRows));
      for (auto* b : {&nx_, &ny_, &nz_}) b->resize(3 * cpu::scratch_stride(n));
    }
    for (auto* b : {&ex_nx_, &ex_ny_, &ex_nz_, &ex_eps_, &ex_mx_, &ex_my_, &ex_mz_}) b->resize(ne);
    if (K_.shells_any) ex_kappa_.resize(ne);
    ex_out_.resize(cpu::tiled_size(ne, cpu::kExplicitOutRows));
    explicit_weight_.resize(n);
    bend_weight_.resize(n);
    has_ext_.resize(n);
    ext_f_.resize(n);
    ext_t_.resize(n);
    ext_s_.resize(n);
    intact_count_.resize(n);
    lost_.resize(n);
    breaks_.resize(L);
    flag_.resize(n + 1);
    place_.resize(n + 1);
    mean_stress_.resize(n);
    stress_.resize(n);
    f_out_.resize(n);
    t_out_.resize(n);
    grip_force_.resize(m.grip_velocity.size());
    grip_work_.resize(m.grip_velocity.size());
    mv_ = model_view();
    // The shells' bending constants for the energies (0 off the explicit automata).
    if (K_.shells_any) {
      std::vector<double> shell_c(n, 0.0);
      for (const std::uint32_t a : K_.explicit_automata) shell_c[a] = shell_check_constant(m, a);
      Dev::upload(shell_c_, shell_c);
    }
  }

  ~DeviceBackend() override { Dev::print_profile(Dev::kName, steps_, static_cast<std::int64_t>(rebuilds_)); }
  std::string name() const override { return Dev::kName; }
  // Whether a step's links and automata are one kernel (FusedLatticeKernel) or two (cuda_lattice).
  bool fused_lattice() const { return fused_; }
  // The steps the fused kernel ran compiled for a plain lattice step (is_plain), and the many-body kernel.
  std::size_t plain_lattice_steps() const { return plain_lattice_steps_; }
  std::size_t plain_many_body_steps() const { return plain_many_body_steps_; }
  // The room in the lattice kernel's list of the projectiles' next candidates at first (then at least twice
  // the last step's candidates); the tests make it small.
  static inline std::size_t first_touch_room = 1024;
  // The most candidates whose contacts, commit and sums take one block (ProjectilePassKernel), the rest
  // four launches; the tests make it small.
  static inline std::size_t small_candidates = kSmallCandidates;
  static inline std::size_t pass_chunks = ProjectilePassKernel::kChunks;  // (its scan's chunks)
  // How many steps took the projectiles' candidates from the lattice kernel's list, and how many wrote them
  // again from the counts (after an upload, or more than the list had room for) (tests: both ways).
  std::size_t candidates_sorted() const { return candidates_sorted_; }
  std::size_t candidates_rewritten() const { return candidates_rewritten_; }
  // How many steps with candidates took one block for their contacts (tests: both ways).
  std::size_t candidates_in_one_block() const { return candidates_in_one_block_; }
  // How many steps had more breaks than SmallBreaksKernel takes (tests: both ways are the CPU's).
  std::size_t large_break_steps() const { return large_break_steps_; }
  // How many steps had their many-body terms launched by the step before (tests: which do).
  std::size_t early_many_body_steps() const { return early_many_body_steps_; }
  // How many times the contact lists were rebuilt (tests: what a step reads from the device).
  std::size_t contact_rebuilds() const { return rebuilds_; }
  // (check_usable: after a failed step the device arrays may be gone. The energy check's own arrays grow on
  // the device too, so a full GPU can stop the simulation here as well.)
  Energies energies() const override {
    check_usable();
    auto* self = const_cast<DeviceBackend*>(this);
    return self->or_fail([&] { return self->device_energies(); },
                         [&] { return "at step " + std::to_string(S_.step) + ", computing its energies"; });
  }
  // The state's breaks and those logged on the device since it was last read.
  std::int64_t broken_links() const override {
    return StateBackend::broken_links() + static_cast<std::int64_t>(logged_);
  }
  // The draw list built on the device (draw_kernels.hpp); the links mode is left to the host.
  bool draw_list(const render::SnapshotOptions& o, const std::array<double, 3>& origin, render::DrawList& out,
                 render::DrawTarget* target) const override {
    if (o.draw == render::DrawMode::links) return false;
    check_usable();
    const_cast<DeviceBackend*>(this)->draw(o, origin, out, target);
    return true;
  }

  void upload(State s) override {
    check_usable();
    or_fail([&] { upload_state(std::move(s)); },
            [] { return std::string("as its state went to the device, which left the device's copy part of it"); });
  }

 protected:
  std::int64_t one_step() override;
  void sync_state() const override { const_cast<DeviceBackend*>(this)->sync(); }
  void draw(const render::SnapshotOptions& o, const std::array<double, 3>& origin, render::DrawList& out,
            render::DrawTarget* target);

 private:
  void upload_state(State s) {
    S_ = std::move(s);
    logged_ = 0;
    logged_steps_.clear();
    broke_last_step_ = false;
    early_many_body_ = false;
    clock_.start(S_, M_.dt);
    const std::size_t n = M_.size(), L = M_.link_slots();
    upload3(S_.x, px_, py_, pz_);
    upload3(S_.v, vx_, vy_, vz_);
    upload3(S_.w, wx_, wy_, wz_);
    std::vector<float> qw(n), qx(n), qy(n), qz(n);
    for (std::size_t a = 0; a < n; ++a) {
      qw[a] = S_.q[a].w;
      qx[a] = S_.q[a].x;
      qy[a] = S_.q[a].y;
      qz[a] = S_.q[a].z;
    }
    Dev::upload(qw_, qw);
    Dev::upload(qx_, qx);
    Dev::upload(qy_, qy);
    Dev::upload(qz_, qz);
    std::vector<std::uint8_t> count(n);
    sound_link_counts(M_, S_, count.data());
    Dev::upload(intact_count_, count);
    Dev::upload(intact_, S_.intact);
    Dev::upload(damage_, S_.link_damage);
    upload3(S_.link_ut, utx_, uty_, utz_);
    upload3(S_.link_moment, ex_mx_, ex_my_, ex_mz_);
    softening_ = !S_.link_damage.empty();
    if (fused_) next_f_[4].resize(S_.link_damage.size());
    if (softening_) {
      std::vector<std::uint8_t> unsound(L);
      for (std::size_t l = 0; l < L; ++l) unsound[l] = !S_.intact[l] || S_.link_damage[l] > 0;
      Dev::upload(unsound_, unsound);
    }
    Dev::upload(mean_stress_, S_.mean_stress);
    Dev::upload(stress_, S_.s);
    Dev::upload(f_out_, S_.f);
    Dev::upload(t_out_, S_.t);
    for (auto* b : {&ext_f_, &ext_t_}) Dev::fill(*b, Vec3{});
    Dev::fill(ext_s_, Sym3{});
    Dev::fill(has_ext_, std::uint8_t{0});
    Dev::fill(lost_, 0u);
    Dev::upload(contacts_, S_.contacts);
    contact_count_ = S_.contacts.size();
    Dev::upload(ground_, S_.ground_contacts);
    ground_count_ = S_.ground_contacts.size();
    const std::size_t np = S_.projectiles.size();
    std::vector<DeviceProjectile> dp(np);
    std::vector<BodyContact> lists;
    std::vector<std::uint32_t> start{0};
    for (std::size_t p = 0; p < np; ++p) {
      const ProjectileState& ps = S_.projectiles[p];
      dp[p] = {ps.position, ps.velocity, ps.angular_velocity, ps.orientation, ps.force, ps.ground, ps.work};
      lists.insert(lists.end(), ps.contacts.begin(), ps.contacts.end());
      start.push_back(static_cast<std::uint32_t>(lists.size()));
    }
    Dev::upload(proj_, dp);
    Dev::upload(proj_lists_, lists);
    if (np) Dev::upload(proj_start_, start);
    pair_count_ = S_.projectile_contacts.size();
    Dev::upload(proj_pairs_, S_.projectile_contacts);
    Dev::upload(grip_work_, S_.grip_work);
    Dev::upload(grip_force_, S_.grip_force);
    stale_ = false;
    if (S_.x_at_rebuild.size() != S_.x.size()) {
      rebuild_contacts();
      stale_ = true;  // the state's contact lists are the device's
    } else {
      std::vector<double> ref(cpu::tiled_size(n, cpu::kRefRows));
      for (std::size_t a = 0; a < n; ++a) {
        double* r = ref.data() + cpu::tile_index(a, cpu::kRefRows);
        r[0] = S_.x_at_rebuild[a].x;
        r[cpu::kTile] = S_.x_at_rebuild[a].y;
        r[2 * cpu::kTile] = S_.x_at_rebuild[a].z;
      }
      Dev::upload(ref_, ref);
      incidence();
    }
    // What the first step's projectile pass needs: the candidates and the pairs touching now.
    // (The other status, cleared, is the first step's.)
    StepStatus st[2];
    st[status_at_].pair_count = static_cast<std::uint32_t>(pair_count_);
    Dev::upload(status_, st, 2);
    end_of_step(true);
    read_status();
  }

  template <class T>
  static T* d(Buf<T>& b) {
    return b.data();
  }
  template <class T>
  static const T* c(const Buf<T>& b) {
    return b.data();
  }
  template <class T>
  static const T* opt(const Buf<T>& b) {
    return b.size() ? b.data() : nullptr;
  }

  ModelView model_view() {
    ModelView v;
    v.n = M_.size();
    v.groups = M_.groups.size();
    v.group = c(group_);
    v.object = c(object_);
    v.object_random = opt(object_random_);
    v.radius = c(radius_);
    v.mass = c(mass_);
    v.inertia = c(inertia_);
    v.position0 = c(position0_);
    if (!M_.explicit_links.first.empty()) {
      v.first = c(e_first_);
      v.of = c(e_of_);
    }
    v.ei = c(e_i_);
    v.ej = c(e_j_);
    v.r0 = c(e_r0_);
    v.area = c(e_area_);
    v.group_params = c(groups_);
    v.contact = c(contact_);
    v.grip = M_.grip_velocity.empty() ? nullptr : c(grip_);
    v.lattice_stiffness = M_.lattice_stiffness;
    v.lattice_lambda = M_.lattice_lambda;
    if (!M_.face.empty()) {
      v.face = c(face_);
      v.axes = c(axes_);
    }
    return v;
  }

  cpu::LatticeView view() {
    const Model& m = M_;
    cpu::LatticeView v = lattice_view_numbers(m, K_);
    v.up = c(neighbour_);
    v.below = c(neighbour_below_);
    v.runs = nullptr;  // one lane per thread: the neighbour tables
    v.blocks = 0;
    v.group = c(group_);
    v.tensile = c(tensile_);
    v.compressive = c(compressive_);
    v.break_strain = c(break_strain_);
    v.mass = c(mass_);
    v.inv_mass = c(inv_mass_);
    v.inv_inertia = c(inv_inertia_);
    v.inv_volume = c(inv_volume_);
    v.grip = m.grip_velocity.empty() ? nullptr : c(grip_);
    v.grip_velocity = c(grip_velocity_);
    v.load = m.load.empty() ? nullptr : c(load_);
    v.groups = c(groups_);
    v.free_factor = reinterpret_cast<const float(*)[4]>(c(free_factor_));
    v.pairs = c(pairs_);
    v.softening = softening_;
    v.damage = softening_ ? d(damage_) : nullptr;
    v.link_strength = opt(link_strength_);
    v.rest = opt(link_rest_);
    v.inv_rest = opt(link_inv_rest_);
    v.last = last_step_;
    v.px = d(px_); v.py = d(py_); v.pz = d(pz_);
    v.vx = d(vx_); v.vy = d(vy_); v.vz = d(vz_);
    v.wx = d(wx_); v.wy = d(wy_); v.wz = d(wz_);
    v.qw = d(qw_); v.qx = d(qx_); v.qy = d(qy_); v.qz = d(qz_);
    v.mean_stress = d(mean_stress_);
    v.stress = d(stress_);
    v.f_out = d(f_out_);
    v.t_out = d(t_out_);
    v.intact = d(intact_);
    v.utx = d(utx_); v.uty = d(uty_); v.utz = d(utz_);
    v.nx = d(nx_); v.ny = d(ny_); v.nz = d(nz_);
    v.many_body = d(many_body_);
    v.out = d(out_);
    v.has_ext = d(has_ext_);
    v.ext_f = d(ext_f_);
    v.ext_t = d(ext_t_);
    v.ext_s = d(ext_s_);
    v.projectiles = 0;  // no marks: the automata kernel counts the touches itself (AutomataKernel)
    v.intact_count = c(intact_count_);
    v.ref = c(ref_);
    return v;
  }

  cpu::ExplicitView explicit_view() {
    cpu::ExplicitView e;
    e.slot0 = 3 * M_.size();
    e.i = c(e_i_);
    e.j = c(e_j_);
    e.r0 = c(e_r0_);
    e.r0f = c(ex_r0f_);
    e.inv_r0 = c(ex_inv_r0_);
    e.area = c(ex_area_);
    e.inv_r0_area = c(ex_to_stress_);
    e.G = c(ex_G_);
    e.kt = c(ex_kt_);
    e.damp_normal = c(ex_damp_n_);
    e.damp_tangential = c(ex_damp_t_);
    e.soft = opt(ex_soft_);
    e.weight = c(explicit_weight_);
    e.tensile = c(ex_tensile_);
    e.compressive = c(ex_compressive_);
    e.strain = c(ex_strain_);
    e.nx = d(ex_nx_); e.ny = d(ex_ny_); e.nz = d(ex_nz_); e.eps = d(ex_eps_);
    e.out = d(ex_out_);
    e.k_twist = c(ex_k_twist_); e.k_in = c(ex_k_in_); e.k_out = opt(ex_k_out_);
    e.s_in = c(ex_s_in_); e.s_out = opt(ex_s_out_); e.s_twist = opt(ex_s_twist_);
    e.m0x = opt(ex_m0x_); e.m0y = opt(ex_m0y_); e.m0z = opt(ex_m0z_);
    e.mx = d(ex_mx_); e.my = d(ex_my_); e.mz = d(ex_mz_);
    e.kappa = ex_kappa_.size() ? d(ex_kappa_) : nullptr;
    e.bend_weight = c(bend_weight_);
    e.bends = M_.object_random.empty() ? nullptr : c(ex_bends_);
    return e;
  }

  ExplicitPassView explicit_pass_view() {
    const std::size_t slot0 = 3 * M_.size();
    ExplicitPassView v;
    v.m = mv_;
    v.first = c(e_first_);
    v.ends = c(ex_ends_);
    v.intact = d(intact_) + slot0;
    v.damage = softening_ ? d(damage_) + slot0 : nullptr;
    v.free_face = opt(free_face_);
    v.volume = c(volume_);
    v.area_r0 = c(ex_area_r0_);
    v.eps = c(ex_eps_);
    v.kappa = opt(ex_kappa_);
    v.lambda_over_2g = c(lambda_over_2g_);
    v.free_factor = reinterpret_cast<const float(*)[4]>(c(free_factor_));
    v.bend_c = c(bend_c_);
    v.lattice_lambda = M_.lattice_lambda;
    v.lattice_bending = M_.lattice_bending;
    v.out = c(ex_out_);
    v.nx = c(ex_nx_);
    v.ny = c(ex_ny_);
    v.nz = c(ex_nz_);
    v.r0f = c(ex_r0f_);
    return v;
  }

  ContactPassView contact_pass_view() {
    ContactPassView v;
    v.m = mv_;
    v.px = c(px_); v.py = c(py_); v.pz = c(pz_);
    v.vx = c(vx_); v.vy = c(vy_); v.vz = c(vz_);
    v.wx = c(wx_); v.wy = c(wy_); v.wz = c(wz_);
    v.qw = c(qw_); v.qx = c(qx_); v.qy = c(qy_); v.qz = c(qz_);
    v.pair_springs = K_.uniform_bodies ? c(pair_springs_) : nullptr;
    v.ground_springs = K_.uniform_bodies ? c(ground_springs_) : nullptr;
    v.zeta_pair = c(zeta_pair_);
    v.zeta_ground = c(zeta_ground_);
    v.zeta_pair_held = opt(zeta_pair_held_);
    v.ground_contact = c(ground_contact_);
    v.up = M_.up;
    v.ground_height = M_.ground_height;
    v.dt = M_.dt;
    return v;
  }

  // Vectors (of floats or doubles) as three device arrays, one per component, and back.
  template <class T>
  static void upload3(const std::vector<Vec3T<T>>& v, Buf<T>& x, Buf<T>& y, Buf<T>& z) {
    std::vector<T> c[3];
    for (auto& a : c) a.resize(v.size());
    for (std::size_t k = 0; k < v.size(); ++k) {
      c[0][k] = v[k].x;
      c[1][k] = v[k].y;
      c[2][k] = v[k].z;
    }
    Dev::upload(x, c[0]);
    Dev::upload(y, c[1]);
    Dev::upload(z, c[2]);
  }
  template <class T>
  static void download3(std::vector<Vec3T<T>>& v, const Buf<T>& x, const Buf<T>& y, const Buf<T>& z) {
    std::vector<T> c[3];
    for (auto& a : c) a.resize(v.size());
    Dev::download(c[0].data(), x, v.size());
    Dev::download(c[1].data(), y, v.size());
    Dev::download(c[2].data(), z, v.size());
    for (std::size_t k = 0; k < v.size(); ++k) v[k] = {c[0][k], c[1][k], c[2][k]};
  }

  External external() { return {d(ext_f_), d(ext_t_), d(ext_s_), d(has_ext_)}; }
  GroundReach ground_reach() { return {c(px_), c(py_), c(pz_), c(radius_), M_.up, M_.ground_height, M_.skin}; }

  // The exclusive scan of in[0 .. n - 1] into out[0 .. n], and its total, read from the device.
  std::uint32_t scan_total(const std::uint32_t* in, Buf<std::uint32_t>& out, std::size_t n) {
    Dev::exclusive_scan(in, d(out), n);
    std::uint32_t total = 0;
    Dev::download(&total, out, 1, n);
    return total;
  }
  // Indices k < n with flag[k] set, in order, into out; returns their number.
  std::uint32_t compact(const std::uint32_t* flag, std::size_t n, std::uint32_t* out) {
    const std::uint32_t total = scan_total(flag, place_, n);
    Dev::launch(n, CompactKernel{flag, c(place_), out});
    return total;
  }
  // A field of a struct on the device (the step's status, the energies' sums).
  template <class T, class S>
  static T* field(Buf<S>& b, std::size_t offset) {
    return reinterpret_cast<T*>(reinterpret_cast<unsigned char*>(b.data()) + offset);
  }
  template <class T>
  T* status_field(std::size_t offset) {
    return field<T>(status_, status_at_ * sizeof(StepStatus) + offset);
  }
  Touch touch() {
    return {c(proj_), c(proj_constants_), static_cast<std::uint32_t>(M_.projectiles.size()), c(px_), c(py_), c(pz_),
            c(radius_)};
  }
  // The fused kernel's results become the state (the order of next_d_ and next_f_: StateNext's).
  void swap_next() {
    Buf<double>* const d[9] = {&px_, &py_, &pz_, &vx_, &vy_, &vz_, &wx_, &wy_, &wz_};
    Buf<float>* const f[5] = {&mean_stress_, &utx_, &uty_, &utz_, &damage_};
    for (int k = 0; k < 9; ++k) std::swap(*d[k], next_d_[k]);
    for (int k = 0; k < 5; ++k) std::swap(*f[k], next_f_[k]);
  }
  // Clears the step's broken links (BreakKernel), their lost links counted at their ends.
  BreakKernel clear_links() {
    return {c(breaks_), link_ends(), d(intact_), softening_ ? d(unsound_) : nullptr, d(utx_), d(uty_), d(utz_),
            d(ex_mx_), d(ex_my_), d(ex_mz_), d(lost_)};
  }
  TouchList touch_list() { return {d(touch_a_), d(touch_p_), static_cast<std::uint32_t>(touch_a_.size())}; }
  LinkEnds link_ends() { return {M_.size(), M_.lattice_slots(), c(neighbour_), c(e_i_), c(e_j_)}; }
  BreakList break_list() { return {d(breaks_), status_field<std::uint32_t>(offsetof(StepStatus, breaks))}; }
  // The sound-link counts less the links lost (lost_); *largest becomes the largest of it and the moves
  // since the rebuild of the automata among them that were boxed in.
  void lose_links(float* largest) {
    const std::size_t n = M_.size();
    Dev::launch_reduce(n, LoseLinksKernel{d(lost_), d(intact_count_), c(px_), c(py_), c(pz_), c(ref_)}, largest, nullptr);
  }
  // The bits of the values 0 .. largest.
  static int bits_for(std::size_t largest) {
    int b = 1;
    while (b < 64 && (largest >> b)) ++b;
    return b;
  }
  // b holds `used` values and room for `need` (kept: the new room is a copy). (On a GPU the old memory is
  // freed when `bigger` goes, with the copy from it queued: cudaFree waits for the device first. Memory
  // freed in stream order, cudaFreeAsync or a pool, would need the copy's stream.)
  template <class T>
  static void grow_keeping(Buf<T>& b, std::size_t used, std::size_t need) {
    if (b.size() >= need) return;
    Buf<T> bigger;
    bigger.resize(std::max(need, 2 * b.size()));
    Dev::copy(bigger.data(), b.data(), used);
    std::swap(b, bigger);
  }
  ProjectilePairs projectile_pairs() {
    return {c(proj_constants_), static_cast<std::uint32_t>(M_.projectiles.size()), c(contact_), M_.groups.size(),
            c(zeta_projectiles_)};
  }

  EnergyView energy_view() {
    EnergyView v;
    v.m = mv_;
    v.neighbour = c(neighbour_);
    v.link_rest = opt(link_rest_);
    v.link_inv_rest = opt(link_inv_rest_);
    v.spacing = M_.spacing;
    v.lattice_bending = M_.lattice_bending;
    v.volume = c(volume_);
    v.grip = c(grip_);
    v.load = opt(load_);
    v.k_twist = opt(ex_k_twist_);
    v.k_in = opt(ex_k_in_);
    v.k_out = opt(ex_k_out_);
    v.free_face = opt(free_face_);
    v.gravity = M_.gravity;
    v.dt = M_.dt;
    v.x = {c(px_), c(py_), c(pz_), 1};
    v.v = {c(vx_), c(vy_), c(vz_), 1};
    v.w = {c(wx_), c(wy_), c(wz_), 1};
    v.qw = c(qw_);
    v.qx = c(qx_);
    v.qy = c(qy_);
    v.qz = c(qz_);
    v.f = c(f_out_);
    v.t = c(t_out_);
    v.intact = c(intact_);
    v.damage = softening_ ? c(damage_) : nullptr;
    v.ut = {c(utx_), c(uty_), c(utz_), 1};
    v.moment = {c(ex_mx_), c(ex_my_), c(ex_mz_), 1};
    v.sync = S_.f.size() == M_.size() && S_.step > 0;  // (compute_energies')
    return v;
  }
  Energies device_energies();
  void explicit_pass(const cpu::LatticeView& v);
  void contact_pass();
  void projectile_pass();
  void end_of_step(bool count_touches);
  // The step's status into status_h_; after_copy() launches what the device may do while the host waits.
  template <class F>
  void read_status(F&& after_copy);
  void read_status() {
    read_status([] {});
  }
  // The next step's many-body terms, launched behind the copy of a step's last status (the links and
  // positions they read are then the next step's).
  void launch_next_many_body() {
    if (!lattice_links_) return;
    launch_many_body(view());
    early_many_body_ = true;
  }
  // A lattice kernel K<true> where the view is plain (is_plain), else K<false>: f(std::bool_constant<...>).
  template <class F>
  void plain_or_not(const cpu::LatticeView& v, F&& f) {
    if (is_plain(v)) f(std::true_type{});
    else f(std::false_type{});
  }
  // (The many-body terms do not read `last`: a call's last step is plain for them.)
  void launch_many_body(cpu::LatticeView v) {
    v.last = false;
    plain_or_not(v, [&](auto plain) {
      if (plain()) ++plain_many_body_steps_;
      Dev::launch(M_.size(), ManyBodyKernel<plain()>{v});
    });
  }
  float apply_breaks(const StepStatus& st, bool launched);
  void rebuild_contacts();
  void incidence();
  void merge_incidence(std::size_t old, std::size_t fresh, const ContactPair* old_pairs, std::uint32_t fresh_pairs);
  void launch_small_breaks();
  float finish_small_breaks(const StepStatus& st);
  float merged_ground(const StepStatus& st);
  void sync();

  const Model& M_;
  const StepConstants K_;
  ModelView mv_;
  bool softening_ = false;
  // Model.
  Buf<DVec3> position0_, grip_velocity_;
  Buf<float> mass_, radius_, inertia_, volume_, link_inv_rest_, link_strength_, e_area_, free_face_, zeta_pair_, zeta_ground_,
      zeta_pair_held_;
  Buf<std::uint8_t> group_, object_random_, face_;
  Buf<Vec3> axes_;  // Model::object_axes, with faces
  Buf<std::int32_t> object_;
  Buf<std::int16_t> grip_;
  Buf<Vec3> load_;
  Buf<std::uint32_t> neighbour_, neighbour_below_, e_first_, e_of_, e_i_, e_j_;
  Buf<double> link_rest_, e_r0_;
  Buf<GroupParams> groups_;
  Buf<ContactMaterial> contact_, ground_contact_;
  // The step's constants (StepConstants).
  Buf<float> inv_mass_, inv_inertia_, inv_volume_, tensile_, compressive_, break_strain_, lambda_over_2g_;
  Buf<cpu::PairConstants> pairs_;
  Buf<std::array<float, 4>> free_factor_;
  Buf<float> ex_r0f_, ex_inv_r0_, ex_area_, ex_to_stress_, ex_G_, ex_kt_, ex_damp_n_, ex_damp_t_, ex_soft_, ex_k_twist_,
      ex_k_in_, ex_s_in_, ex_k_out_, ex_s_out_, ex_s_twist_, ex_m0x_, ex_m0y_, ex_m0z_, ex_tensile_, ex_compressive_,
      ex_strain_, ex_area_r0_, bend_c_;
  Buf<std::uint8_t> ex_bends_;
  Buf<std::uint32_t> explicit_automata_, ex_ends_, grip_first_, grip_members_;
  Buf<ContactSprings> pair_springs_, ground_springs_;
  // State.
  Buf<double> px_, py_, pz_, vx_, vy_, vz_, wx_, wy_, wz_, ref_;
  Buf<float> qw_, qx_, qy_, qz_, utx_, uty_, utz_, damage_, mean_stress_, ex_mx_, ex_my_, ex_mz_;
  Buf<std::uint8_t> intact_, unsound_, intact_count_, has_ext_;
  Buf<Sym3> stress_, ext_s_;
  Buf<Vec3> f_out_, t_out_, ext_f_, ext_t_, grip_force_;
  Buf<double> grip_work_;
  // The fused lattice kernel's other copy of what it writes (StateNext): positions, velocities and spins;
  // mean stress, shear displacements and damage; swapped with the state's after it (swap_next).
  bool fused_ = false;
  int fused_blocks_ = 3;  // its blocks per multiprocessor (FusedLatticeKernel::sm_blocks)
  std::size_t plain_lattice_steps_ = 0;  // the steps it ran as FusedLatticeKernel<true> (is_plain)
  std::size_t plain_many_body_steps_ = 0;  // the launches of ManyBodyKernel<true>
  Buf<double> next_d_[9];
  Buf<float> next_f_[5];
  // Scratch.
  Buf<float> nx_, ny_, nz_, many_body_, out_, ex_nx_, ex_ny_, ex_nz_, ex_eps_, ex_out_, ex_kappa_, explicit_weight_,
      bend_weight_;
  Buf<std::uint32_t> lost_, breaks_, flag_, place_;
  Buf<StepStatus> status_;
  // The draw list's (made at the first draw): the model's, then the fragments, values, colours and lists.
  bool draw_ready_ = false;
  Buf<std::uint8_t> strength_class_, boxed_, carries_;
  Buf<std::uint32_t> object_size_, surface_automaton_, surface_corner_, first_corner_, corners_of_;
  Buf<Vec3> surface_offset_;
  Buf<std::uint32_t> parent_, label_, fragment_size_;
  Buf<float> draw_value_, draw_radius_;
  Buf<render::Rgba> colour_;
  Buf<DrawStatus> draw_status_;
  Buf<render::Instance> instances_;
  Buf<render::SurfaceVertex> surface_out_;
  // The step's status: status_[status_at_]. Steps use the two in turn, each clearing the next one's (the
  // lattice kernel's first thread), after the host has read it and before anything writes it.
  std::size_t status_at_ = 0;
  StepStatus status_h_;  // the last status read
  std::size_t rebuilds_ = 0;
  std::int64_t steps_ = 0;  // stepped by this backend (the profile's)
  // The energies' terms and sums.
  Buf<double> shell_c_, e_kinetic_, e_gravity_, e_load_, e_links_, e_many_body_, e_pairs_, e_ground_, e_level_;
  Buf<LinkEnergy> e_link_;
  Buf<EnergySums> e_sums_;
  // Contact lists (sizes on the host), and the incidence list: (automaton, 2 p + side) sorted (and the
  // next one, for its merge).
  Buf<ContactPair> contacts_, contacts_next_;
  // A step's breaks: their pairs sorted, and their ends sorted with which join the ground list.
  Buf<std::uint64_t> fresh_key_;
  Buf<std::uint32_t> fresh_value_, ends_, ends_value_, ends_flag_, ends_place_;
  // The breaks' records: their codes, kept on the device until the state is read, and the steps they came in.
  Buf<std::uint32_t> break_log_;
  std::size_t logged_ = 0;
  std::vector<std::pair<std::int64_t, std::uint32_t>> logged_steps_;
  Buf<ContactOut> contact_out_;
  std::size_t contact_count_ = 0;
  Buf<BodyContact> ground_, ground_next_, ground_fresh_;
  std::size_t ground_count_ = 0;
  Buf<std::uint32_t> inc_key_, inc_value_, inc_key_next_, inc_value_next_;
  // apply_breaks' merge: the fresh pairs' incidence entries.
  Buf<std::uint32_t> fresh_inc_key_, fresh_inc_value_;
  // SmallBreaksKernel's unsorted keys, ends and incidence entries; whether the last step broke links
  // (one_step then launches it before the status is read); the steps with more breaks than it takes.
  Buf<std::uint64_t> raw_key_;
  Buf<std::uint32_t> raw_end_, raw_inc_key_, raw_inc_value_;
  bool broke_last_step_ = false;
  std::size_t large_break_steps_ = 0;
  // Whether this step's many-body terms were launched by the last step, behind the copy of its last status
  // (after which nothing changes the links and positions they read; an upload does).
  bool early_many_body_ = false;
  std::size_t early_many_body_steps_ = 0;
  bool lattice_links_ = false;
  // Projectiles.
  Buf<ProjectileConstants> proj_constants_;
  Buf<ContactMaterial> proj_material_;
  Buf<float> proj_zeta_, proj_zeta_held_;
  Buf<float> zeta_projectiles_;
  Buf<DeviceProjectile> proj_;
  // The projectiles' contact lists, one after another (projectile p's from proj_start_[p]).
  Buf<BodyContact> proj_lists_, proj_lists_next_;
  Buf<std::uint32_t> proj_start_, proj_start_next_;
  // The lattice kernel's list of the next candidates (touch_a_, touch_p_; TouchList) and how many entries it
  // had room for (0: the touches were counted without it); the steps that sorted it or wrote it again, and
  // those that took one block for their contacts.
  Buf<std::uint32_t> touch_a_, touch_p_;
  std::size_t appended_ = 0;
  std::size_t candidates_sorted_ = 0, candidates_rewritten_ = 0, candidates_in_one_block_ = 0;
  // The candidates: touching counts per automaton and their scan, the (automaton, projectile) entries, the
  // projectile order (keys, order, where), each one's contact and whether it is kept, and each projectile's
  // first candidate.
  Buf<std::uint32_t> touch_count_, touch_offset_, cand_a_, cand_p_, cand_key_, cand_order_, cand_where_, cand_keep_,
      cand_place_, segment_, chunk_sum_;
  Buf<BodyContact> cand_next_;
  Buf<ContactOut> cand_out_;
  Buf<Vec3> fsum_, tsum_;
  Buf<ProjectilePair> proj_pairs_, proj_pairs_next_;
  std::size_t pair_count_ = 0;
  Buf<std::uint32_t> pair_touch_count_, pair_offset_;  // per projectile: its touching pairs (q > p), their scan
  Buf<ContactOut> pair_out_;
  // Contact search.
  Buf<std::uint32_t> exposed_, grid_value_, bucket_begin_, bucket_end_, cand_count_, raw_offset_, raw_;
  Buf<std::uint64_t> grid_key_;
};

// --- The step ---

template <class Dev>
std::int64_t DeviceBackend<Dev>::one_step() {
  ++steps_;
  const cpu::LatticeView v = view();
  const std::size_t n = M_.size(), ne = M_.explicit_links.size();
  status_at_ ^= 1;
  // The lattice's many-body terms, unless the last step launched them (early_many_body_). Before the
  // explicit, contact and projectile passes, where the CPU computes them after: those do not write what
  // they read, nor read what they write.
  if (early_many_body_) ++early_many_body_steps_;
  else if (lattice_links_) launch_many_body(v);
  early_many_body_ = false;
  if (ne) explicit_pass(v);
  contact_pass();
  projectile_pass();
  // The lattice: links (their breaks into the list) and automata.
  StepStatus* const next_status = d(status_) + (status_at_ ^ 1);
  const std::size_t np = M_.projectiles.size();
  std::uint32_t* const touch_count = np ? d(touch_count_) : nullptr;
  std::uint32_t* const touches = status_field<std::uint32_t>(offsetof(StepStatus, touches));
  float* const move2 = status_field<float>(offsetof(StepStatus, move2));
  std::uint32_t* const bad = status_field<std::uint32_t>(offsetof(StepStatus, bad));
  if (fused_) {
    const cpu::StateNext next{d(next_d_[0]), d(next_d_[1]), d(next_d_[2]), d(next_d_[3]), d(next_d_[4]),
                              d(next_d_[5]), d(next_d_[6]), d(next_d_[7]), d(next_d_[8]), d(next_f_[0]),
                              d(next_f_[1]), d(next_f_[2]), d(next_f_[3]), softening_ ? d(next_f_[4]) : nullptr};
    Touch t = touch();
    t.px = next.px;
    t.py = next.py;
    t.pz = next.pz;
    plain_or_not(v, [&](auto plain) {
      if (plain()) ++plain_lattice_steps_;
      Dev::launch_reduce(n, FusedLatticeKernel<plain()>{v, next, break_list(), t, touch_count, touches, touch_list(),
                                                        next_status, fused_blocks_},
                         move2, bad);
    });
    swap_next();
  } else {
    if (M_.lattice_slots()) Dev::launch(n, LinksKernel{v, break_list()});  // (3 n slots: 3 per automaton)
    Dev::launch_reduce(n, AutomataKernel{v, touch(), touch_count, touches, touch_list(), next_status}, move2, bad);
  }
  appended_ = np ? touch_a_.size() : 0;
  if (!M_.grip_velocity.empty())
    Dev::launch(M_.grip_velocity.size(), GripKernel{c(grip_first_), c(grip_members_), d(ext_f_), d(grip_force_),
                                                    d(grip_work_), c(grip_velocity_), M_.dt});
  const LinkEnds ends = link_ends();
  if (softening_) {
    // Links damaged this step leave their ends' counts of sound links. (Before this step's breaks are
    // applied, where the CPU does it after: a link counts once either way, the one that comes first marking
    // it unsound, and the counts and largest move come out the same.)
    Dev::launch(M_.link_slots(), ExposeDamagedKernel{ends, c(damage_), d(unsound_), d(lost_)});
    lose_links(status_field<float>(offsetof(StepStatus, move2_lost)));
  }
  end_of_step(false);
  // Breaks come in runs of steps: after a step with breaks, the next one's (if few) are applied before
  // the status is read, so the step reads the device once.
  const bool launched = broke_last_step_;
  if (launched) launch_small_breaks();
  // The one read of a step without breaks, or with few after a step with breaks. The next step's many-body
  // terms are launched behind the copy, so that the device computes them while the host waits for it and
  // decides what to launch next (again behind apply_breaks' read, where it changes the links after this one).
  read_status([&] { launch_next_many_body(); });
  const StepStatus st = status_h_;
  broke_last_step_ = st.breaks != 0;
  float max_move2 = std::max(st.move2, softening_ ? st.move2_lost : 0.0f);
  if (st.breaks) max_move2 = std::max(max_move2, apply_breaks(st, launched));
  ++S_.step;
  S_.time = clock_.time(S_.step, M_.dt);
  // Verlet-style list: rebuild once any automaton has moved half the skin since the last rebuild.
  const float half = 0.5f * M_.skin;
  if (max_move2 > half * half) rebuild_contacts();
  if (st.bad != kNone) return st.bad;
  return !M_.projectiles.empty() && st.bad_projectile != kNone ? -2 - static_cast<std::int64_t>(st.bad_projectile)
                                                                : kAllFinite;
}

// What the next step's projectile pass needs from this step's positions: the candidates counted (the
// status's touches: the automata kernel counts them in a step, `count_touches` here after an upload) and
// the projectile pairs touching.
template <class Dev>
void DeviceBackend<Dev>::end_of_step(bool count_touches) {
  const std::size_t np = M_.projectiles.size();
  if (np == 0) return;
  if (count_touches) {
    Dev::launch(M_.size(), TouchCountKernel{touch(), d(touch_count_), status_field<std::uint32_t>(offsetof(StepStatus, touches))});
    appended_ = 0;  // counted, not listed
  }
  if (np > 1)
    Dev::launch(np, ProjectilePairCountKernel{c(proj_), projectile_pairs(), d(pair_touch_count_),
                                              status_field<std::uint32_t>(offsetof(StepStatus, touching_pairs))});
}

template <class Dev>
template <class F>
void DeviceBackend<Dev>::read_status(F&& after_copy) {
  Dev::download_then(&status_h_, status_, 1, status_at_, after_copy);
  pair_count_ = M_.projectiles.empty() ? 0 : status_h_.pair_count;
}

template <class Dev>
void DeviceBackend<Dev>::explicit_pass(const cpu::LatticeView& v) {
  const std::size_t ne = M_.explicit_links.size(), na = K_.explicit_automata.size();
  const cpu::ExplicitView ev = explicit_view();
  Dev::launch(ne, ExplicitGeometryKernel{v, ev});
  const ExplicitPassView pv = explicit_pass_view();
  Dev::launch(na, ExplicitWeightKernel{pv, c(explicit_automata_), d(explicit_weight_), d(bend_weight_)});
  Dev::launch(ne, ExplicitLinksKernel{v, ev, break_list()});
  Dev::launch(na, ExplicitGatherKernel{pv, c(explicit_automata_), external(), v.last});
}

template <class Dev>
void DeviceBackend<Dev>::contact_pass() {
  const ContactPassView cv = contact_pass_view();
  if (contact_count_) {
    if (contact_out_.size() < contact_count_) contact_out_.resize(contact_count_);
    Dev::launch(contact_count_, PairContactKernel{cv, d(contacts_), d(contact_out_)});
  }
  const std::size_t e = 2 * contact_count_;
  Dev::launch(e + ground_count_,
              ContactsOntoAutomataKernel{ContactGatherKernel{c(inc_key_), c(inc_value_), static_cast<std::uint32_t>(e),
                                                             c(contact_out_), external()},
                                         GroundKernel{cv, d(ground_), external()}, static_cast<std::uint32_t>(ground_count_)});
}

// The projectiles' pass (CpuBackend::projectile_pass): the candidates the last step's end counted (the
// status's touches), in projectile order, each one's contact; the kept ones make the new lists and add to
// their automata in projectile order; each projectile sums its contacts in list order; one thread does the
// pairs and the motion.
template <class Dev>
void DeviceBackend<Dev>::projectile_pass() {
  const std::size_t np = M_.projectiles.size(), n = M_.size();
  if (np == 0) return;
  const std::uint32_t T = status_h_.touches;
  // The lattice kernel's list of the candidates, where it had room for them all (sorted below), else
  // written again from the counts; then room for at least twice as many in the next one (the list's
  // capacity is a 32-bit count).
  const bool listed = T <= appended_;
  if (listed && T) {
    std::swap(cand_a_, touch_a_);
    std::swap(cand_p_, touch_p_);
  } else if (!listed) {
    for (auto* b : {&cand_a_, &cand_p_}) b->resize(T);
  }
  const std::size_t room = std::min<std::size_t>(2 * std::size_t{T}, UINT32_MAX);
  if (touch_a_.size() < room)
    for (auto* b : {&touch_a_, &touch_p_}) b->resize(room);
  cand_keep_.resize(T);
  cand_place_.resize(T + 1);
  cand_next_.resize(T);
  cand_out_.resize(T);
  Candidates cand{c(cand_a_), c(cand_p_), nullptr, nullptr, T};
  if (T) {
    if (listed) {
      // Each automaton's entries in projectile order, the automata in no order: a stable sort by automaton
      // gives the (automaton, projectile) order.
      Dev::stable_sort_by_key(d(cand_a_), d(cand_p_), T, bits_for(n - 1));
      ++candidates_sorted_;
    } else {
      ++candidates_rewritten_;
      Dev::exclusive_scan(c(touch_count_), d(touch_offset_), n);
      Dev::launch(n, TouchWriteKernel{touch(), c(touch_offset_), d(cand_a_), d(cand_p_)});
    }
    if (np > 1) {
      for (auto* b : {&cand_key_, &cand_order_, &cand_where_}) b->resize(T);
      Dev::launch(T, OrderKeysKernel{c(cand_p_), d(cand_key_), d(cand_order_)});
      Dev::stable_sort_by_key(d(cand_key_), d(cand_order_), T, bits_for(np - 1));
      Dev::launch(T, InvertKernel{c(cand_order_), d(cand_where_)});
      cand.order = c(cand_order_);
      cand.key = c(cand_key_);
    }
  }
  const ContactPassView cv = contact_pass_view();
  proj_lists_next_.resize(T);
  const ProjectileContactKernel contact{c(proj_), c(proj_constants_), cand, c(proj_lists_), c(proj_start_), cv,
                                        c(proj_material_), c(proj_zeta_), opt(proj_zeta_held_), M_.groups.size(), d(cand_next_), d(cand_out_),
                                        d(cand_keep_)};
  const ProjectileCommitExternalKernel commit{
      ProjectileCommitKernel{c(cand_keep_), c(cand_place_), c(cand_next_), d(proj_lists_next_)},
      ProjectileExternalKernel{cand, np > 1 ? c(cand_where_) : nullptr, c(cand_keep_), c(cand_out_), external()}};
  // The pairs the last step's end counted touching, in (p, q) order, each one's contact (its history from
  // the previous list); then one thread sums them in order and moves the projectiles: in the block of the
  // projectiles' sums where no pairs touch, else after the pairs' contacts.
  const std::uint32_t TP = np > 1 ? status_h_.touching_pairs : 0;
  const ProjectileMotionKernel motion{d(proj_), c(proj_constants_), static_cast<std::uint32_t>(np), c(proj_pairs_next_),
                                      c(pair_out_), TP, status_field<std::uint32_t>(offsetof(StepStatus, pair_count)),
                                      d(fsum_), d(tsum_), M_.gravity, M_.dt,
                                      status_field<std::uint32_t>(offsetof(StepStatus, bad_projectile))};
  const ProjectileSumsKernel sums{ProjectileSegmentKernel{cand, c(cand_place_), d(segment_), d(proj_start_next_)},
                                  ProjectileSumKernel{d(proj_), c(proj_constants_), c(segment_), c(cand_keep_), c(cand_out_),
                                                      d(fsum_), d(tsum_), M_.ground, M_.up, M_.ground_height, M_.dt},
                                  motion, static_cast<std::uint32_t>(np), TP == 0};
  // The contacts, the scan of those kept, their commit and the sums: in one block where the candidates are
  // few, else in four launches.
  if (T <= small_candidates) {
    if (T) ++candidates_in_one_block_;
    chunk_sum_.resize(pass_chunks);
    Dev::launch_block(ProjectilePassKernel{contact, static_cast<std::uint32_t>(pass_chunks), d(chunk_sum_), d(cand_place_), T,
                                           commit, sums});
  } else {
    Dev::launch(T, contact);
    Dev::exclusive_scan(c(cand_keep_), d(cand_place_), T);
    Dev::launch(T, commit);
    Dev::launch_block(sums);
  }
  std::swap(proj_lists_, proj_lists_next_);
  std::swap(proj_start_, proj_start_next_);
  if (TP) {
    Dev::exclusive_scan(c(pair_touch_count_), d(pair_offset_), np);
    proj_pairs_next_.resize(TP);
    pair_out_.resize(TP);
    Dev::launch(np, ProjectilePairWriteKernel{c(proj_), projectile_pairs(), c(pair_offset_), d(proj_pairs_next_)});
    Dev::launch(TP, ProjectilePairContactKernel{c(proj_), projectile_pairs(), c(proj_pairs_), static_cast<std::uint32_t>(pair_count_),
                                                d(proj_pairs_next_), d(pair_out_), M_.dt});
    ProjectileMotionKernel after = motion;  // on the pair lists as resized
    after.list = c(proj_pairs_next_);
    after.out = c(pair_out_);
    Dev::launch(1, after);
  }
  std::swap(proj_pairs_, proj_pairs_next_);
}

// The step's breaks (st.breaks of them: the break list, in no order), applied at its end
// (CpuBackend::apply_breaks), all on the device: the links cleared, their pairs into the contact list, their
// ends near the ground into the ground list, the codes kept for the records (in slot order when the state is
// read). Up to kSmallBreaks of them take launch_small_breaks' two launches, made before the status was
// read where `launched` (no more reads), else now (one more read); more take some eleven launches and one
// more read. Returns the largest move since the rebuild of an automaton that was boxed in and lost a link.
template <class Dev>
float DeviceBackend<Dev>::apply_breaks(const StepStatus& st, bool launched) {
  const std::uint32_t nb = st.breaks;
  if (nb <= kSmallBreaks && launched) return finish_small_breaks(st);
  if (nb <= kSmallBreaks) {
    launch_small_breaks();
    StepStatus after;
    Dev::download_then(&after, status_, 1, status_at_, [&] { launch_next_many_body(); });
    return finish_small_breaks(after);
  }
  const std::size_t n = M_.size(), old_pairs = contact_count_;
  const LinkEnds ends = link_ends();
  grow_keeping(break_log_, logged_, logged_ + nb);
  fresh_key_.resize(nb);
  fresh_value_.resize(nb);
  const std::size_t e = 2 * std::size_t{nb};
  ++large_break_steps_;
  if (M_.ground)
    for (auto* b : {&ends_, &ends_value_, &ends_flag_}) b->resize(e);
  Dev::launch(nb, BreaksKernel{d(break_log_) + logged_, clear_links(), BrokenPairKeysKernel{c(breaks_), ends, d(fresh_key_), d(fresh_value_)},
                               BrokenEndsKernel{c(breaks_), ends, M_.ground ? d(ends_) : nullptr, M_.ground ? d(ends_value_) : nullptr}});
  logged_ += nb;
  logged_steps_.push_back({S_.step, nb});
  // The broken pairs join the contact list (sorted), their ends the incidence list (merged below).
  Dev::stable_sort_by_key(d(fresh_key_), d(fresh_value_), nb, 32 + bits_for(n - 1));
  contacts_next_.resize(old_pairs + nb);
  fresh_inc_key_.resize(e);
  fresh_inc_value_.resize(e);
  Dev::launch(old_pairs + nb, MergeFreshPairsKernel{c(contacts_), c(fresh_key_), static_cast<std::uint32_t>(old_pairs), nb,
                                                    d(contacts_next_), d(fresh_inc_key_), d(fresh_inc_value_)});
  std::swap(contacts_, contacts_next_);
  contact_count_ += nb;
  // Their ends near the ground join the ground list (sorted, once each): as many as the status counts.
  if (M_.ground) {
    ends_place_.resize(e + 1);
    ground_fresh_.resize(e);
    Dev::stable_sort_by_key(d(ends_), d(ends_value_), e, bits_for(n - 1));
    Dev::launch(e, GroundJoinFlagKernel{ground_reach(), c(ends_), c(ground_), static_cast<std::uint32_t>(ground_count_),
                                        d(ends_flag_), status_field<std::uint32_t>(offsetof(StepStatus, ground_joins))});
    Dev::exclusive_scan(c(ends_flag_), d(ends_place_), e);
    Dev::launch(e, GroundJoinWriteKernel{c(ends_), c(ends_flag_), c(ends_place_), d(ground_fresh_)});
    ground_next_.resize(ground_count_ + e);
    Dev::launch(ground_count_ + e, MergeBodiesKernel{c(ground_), c(ground_fresh_), static_cast<std::uint32_t>(ground_count_),
                                                     c(ends_place_) + e, d(ground_next_)});
  }
  merge_incidence(2 * old_pairs, e, c(contacts_next_), nb);  // (the old list, swapped out above)
  lose_links(status_field<float>(offsetof(StepStatus, move2_lost)));
  StepStatus after;
  Dev::download_then(&after, status_, 1, status_at_, [&] { launch_next_many_body(); });
  return merged_ground(after);
}

// After a step's breaks, with a status read after them: the merged ground list becomes the list. Returns the
// largest move since the rebuild of an automaton that was boxed in and lost a link.
template <class Dev>
float DeviceBackend<Dev>::merged_ground(const StepStatus& st) {
  if (M_.ground) {
    std::swap(ground_, ground_next_);
    ground_count_ += st.ground_joins;
  }
  return st.move2_lost;
}

// A step's breaks where there are at most kSmallBreaks: SmallBreaksKernel, then the merges into the contact,
// ground and incidence lists (MergeBreaksKernel), sized for that many and taking their number from the step's
// status on the device, so that they can be launched before the host has read it (they do nothing where there
// are none or more); the lists stay the old ones until finish_small_breaks.
template <class Dev>
void DeviceBackend<Dev>::launch_small_breaks() {
  const std::size_t old_pairs = contact_count_, e = 2 * std::size_t{kSmallBreaks};
  const LinkEnds ends = link_ends();
  grow_keeping(break_log_, logged_, logged_ + kSmallBreaks);
  for (auto* b : {&fresh_key_, &raw_key_}) b->resize(kSmallBreaks);
  fresh_value_.resize(kSmallBreaks);
  for (auto* b : {&raw_end_, &ends_, &ends_value_, &ends_flag_, &raw_inc_key_, &raw_inc_value_, &fresh_inc_key_,
                  &fresh_inc_value_})
    b->resize(e);
  ground_fresh_.resize(e);
  ends_place_.resize(e + 1);
  const std::uint32_t* const count = status_field<std::uint32_t>(offsetof(StepStatus, breaks));
  std::uint32_t* const joins = status_field<std::uint32_t>(offsetof(StepStatus, ground_joins));
  Dev::launch_block(SmallBreaksKernel{
      BreaksKernel{d(break_log_) + logged_, clear_links(), BrokenPairKeysKernel{c(breaks_), ends, d(raw_key_), d(fresh_value_)},
                   BrokenEndsKernel{c(breaks_), ends, d(raw_end_), d(ends_value_)}},
      count, c(raw_key_), d(fresh_key_), c(raw_end_), d(ends_), c(contacts_), static_cast<std::uint32_t>(old_pairs),
      d(raw_inc_key_), d(raw_inc_value_), d(fresh_inc_key_), d(fresh_inc_value_),
      GroundJoinFlagKernel{ground_reach(), c(ends_), c(ground_), static_cast<std::uint32_t>(ground_count_),
                           M_.ground ? d(ends_flag_) : nullptr, joins},
      d(ends_place_), GroundJoinWriteKernel{c(ends_), c(ends_flag_), c(ends_place_), d(ground_fresh_)},
      LoseLinksKernel{d(lost_), d(intact_count_), c(px_), c(py_), c(pz_), c(ref_)},
      status_field<float>(offsetof(StepStatus, move2_lost))});
  contacts_next_.resize(old_pairs + kSmallBreaks);
  const std::size_t ground_threads = M_.ground ? ground_count_ + e : 0;
  if (M_.ground) ground_next_.resize(ground_threads);
  for (auto* b : {&inc_key_next_, &inc_value_next_}) b->resize(2 * old_pairs + e);
  const MergeIncidenceKernel incidence{c(inc_key_), c(inc_value_), static_cast<std::uint32_t>(2 * old_pairs),
                                       c(fresh_inc_key_), c(fresh_inc_value_), 0, d(inc_key_next_), d(inc_value_next_),
                                       c(contacts_), c(fresh_key_), 0};
  Dev::launch(old_pairs + kSmallBreaks + ground_threads + 2 * old_pairs + e,
              MergeBreaksKernel{count,
                                MergeFreshPairsKernel{c(contacts_), c(fresh_key_), static_cast<std::uint32_t>(old_pairs), 0,
                                                      d(contacts_next_), nullptr, nullptr},
                                old_pairs + kSmallBreaks,
                                MergeBodiesKernel{c(ground_), c(ground_fresh_), static_cast<std::uint32_t>(ground_count_),
                                                  joins, d(ground_next_)},
                                ground_threads, incidence});
}

// After launch_small_breaks, with a status read after it (st.breaks of them, at most kSmallBreaks): the
// merged lists become the lists, the breaks' records are kept (the return: merged_ground's).
template <class Dev>
float DeviceBackend<Dev>::finish_small_breaks(const StepStatus& st) {
  logged_ += st.breaks;
  logged_steps_.push_back({S_.step, st.breaks});
  std::swap(contacts_, contacts_next_);
  contact_count_ += st.breaks;
  std::swap(inc_key_, inc_key_next_);
  std::swap(inc_value_, inc_value_next_);
  return merged_ground(st);
}

// The contact lists from the exposed automata (CpuBackend::rebuild_contacts): a hashed grid of them sorted
// by bucket, each one's candidates above it counted, written, sorted and made unique, then placed in order:
// the list comes out sorted by (i, j), as the CPU's. The histories of pairs that stay are carried over.
template <class Dev>
void DeviceBackend<Dev>::rebuild_contacts() {
  const std::size_t n = M_.size();
  ++rebuilds_;
  Dev::launch(n, ExposedFlagKernel{c(intact_count_), d(flag_)});
  if (exposed_.size() < n + 1) exposed_.resize(n + 1);
  const std::uint32_t nx = compact(c(flag_), n, d(exposed_));
  std::size_t buckets = 16;
  while (buckets < 2 * static_cast<std::size_t>(nx)) buckets *= 2;
  HashGrid grid;
  grid.inv_h = 1.0 / (2.0 * static_cast<double>(K_.r_max) + M_.skin);
  grid.mask = buckets - 1;
  grid_key_.resize(nx);
  grid_value_.resize(nx);
  Dev::launch(nx, GridKeysKernel{grid, c(exposed_), c(px_), c(py_), c(pz_), d(grid_key_), d(grid_value_)});
  Dev::stable_sort_by_key(d(grid_key_), d(grid_value_), nx, bits_for(buckets - 1));
  bucket_begin_.resize(buckets);
  bucket_end_.resize(buckets);
  Dev::fill(bucket_begin_, 0u);
  Dev::fill(bucket_end_, 0u);
  Dev::launch(nx, BucketRangeKernel{c(grid_key_), nx, d(bucket_begin_), d(bucket_end_)});
  const Linked linked{n, c(neighbour_), c(neighbour_below_), c(intact_), mv_.first, mv_.of, c(e_i_), c(e_j_)};
  CandidatesKernel k{grid, c(exposed_), c(grid_value_), c(bucket_begin_), c(bucket_end_), c(px_), c(py_), c(pz_),
                     c(radius_), M_.skin, linked, mv_, c(e_r0_), nullptr, nullptr, nullptr,
                     c(qw_), c(qx_), c(qy_), c(qz_), face_search_cells(K_.r_max, M_.skin),
                     face_search_reach(K_.r_max, M_.skin)};
  cand_count_.resize(nx + 1);
  raw_offset_.resize(nx + 1);
  k.count = d(cand_count_);
  Dev::launch(nx, k);
  const std::uint32_t raw = scan_total(c(cand_count_), raw_offset_, nx);
  raw_.resize(raw);
  k.offset = c(raw_offset_);
  k.out = d(raw_);
  Dev::launch(nx, k);
  const std::uint32_t total = scan_total(c(cand_count_), place_, nx);
  contacts_next_.resize(total);
  Dev::launch(nx, WritePairsKernel{c(exposed_), c(raw_), c(raw_offset_), c(cand_count_), c(place_), c(contacts_),
                                   static_cast<std::uint32_t>(contact_count_), d(contacts_next_)});
  std::swap(contacts_, contacts_next_);
  contact_count_ = total;
  if (M_.ground) {
    Dev::launch(nx, NearGroundFlagKernel{ground_reach(), c(exposed_), d(flag_)});
    const std::uint32_t ng = scan_total(c(flag_), place_, nx);
    ground_next_.resize(ng);
    Dev::launch(nx, WriteGroundKernel{c(exposed_), c(flag_), c(place_), c(ground_), static_cast<std::uint32_t>(ground_count_),
                                      d(ground_next_)});
    std::swap(ground_, ground_next_);
    ground_count_ = ng;
  }
  Dev::launch(n, ReferenceKernel{c(px_), c(py_), c(pz_), d(ref_)});
  incidence();
}

// The incidence list of the contact list: each automaton's entries (2 p + side) in pair order.
template <class Dev>
void DeviceBackend<Dev>::incidence() {
  const std::size_t e = 2 * contact_count_;
  if (e == 0) return;
  for (auto* b : {&inc_key_, &inc_value_}) b->resize(e);
  Dev::launch(contact_count_, IncidenceKeysKernel{c(contacts_), d(inc_key_), d(inc_value_)});
  Dev::stable_sort_by_key(d(inc_key_), d(inc_value_), e, bits_for(M_.size() - 1));
}

// The same after apply_breaks merged fresh pairs into the list: the old list's `old` entries renamed and
// merged with the `fresh` ones (MergeFreshPairsKernel's), which are sorted here (a few per step, where
// sorting the whole list again would take the step's longest sort).
template <class Dev>
void DeviceBackend<Dev>::merge_incidence(std::size_t old, std::size_t fresh, const ContactPair* old_pairs,
                                         std::uint32_t fresh_pairs) {
  const std::size_t e = old + fresh;
  if (fresh == 0) return;
  Dev::stable_sort_by_key(d(fresh_inc_key_), d(fresh_inc_value_), fresh, bits_for(M_.size() - 1));
  for (auto* b : {&inc_key_next_, &inc_value_next_}) b->resize(e);
  Dev::launch(e, MergeIncidenceKernel{c(inc_key_), c(inc_value_), static_cast<std::uint32_t>(old), c(fresh_inc_key_),
                                      c(fresh_inc_value_), static_cast<std::uint32_t>(fresh), d(inc_key_next_),
                                      d(inc_value_next_), old_pairs, c(fresh_key_), fresh_pairs});
  std::swap(inc_key_, inc_key_next_);
  std::swap(inc_value_, inc_value_next_);
}

// The energies for Engine's check (Backend::energies): each term on the device with compute_energies'
// functions, the arrays summed there by chunk_sum's fixed tree and put together as check_energies does, so
// the check decides on the CPU's bits; one read.
template <class Dev>
Energies DeviceBackend<Dev>::device_energies() {
  const std::size_t n = M_.size(), L = M_.link_slots(), np = M_.projectiles.size();
  const EnergyView ev = energy_view();
  for (auto* b : {&e_kinetic_, &e_gravity_, &e_many_body_}) b->resize(n);
  if (!M_.load.empty()) e_load_.resize(n);
  e_links_.resize(L);
  e_link_.resize(L);
  e_pairs_.resize(contact_count_);
  e_ground_.resize(ground_count_);
  e_sums_.resize(1);
  Dev::launch(n, AutomatonEnergyKernel{ev, d(e_kinetic_), d(e_gravity_), M_.load.empty() ? nullptr : d(e_load_)});
  Dev::launch(L, LinkEnergyKernel{ev, d(e_link_), d(e_links_)});
  Dev::launch(n, ManyBodyEnergyKernel{ev, c(neighbour_below_), c(e_link_), opt(shell_c_), d(e_many_body_)});
  Dev::launch(contact_count_, PairEnergyKernel{ev, c(contacts_), d(e_pairs_)});
  Dev::launch(ground_count_, GroundEnergyKernel{ev, c(ground_), c(ground_contact_), M_.up, M_.ground_height, d(e_ground_)});
  Dev::launch(1, SerialEnergyKernel{ev, c(proj_), projectile_pairs(), opt(proj_lists_), np ? c(proj_start_) : nullptr,
                                    opt(proj_material_), M_.ground ? c(ground_contact_) : nullptr, M_.up, M_.ground_height,
                                    opt(proj_pairs_), static_cast<std::uint32_t>(pair_count_), opt(grip_work_),
                                    M_.grip_velocity.size(), d(e_sums_)});
  // Each array by chunk_sum's fixed tree (energy_terms.hpp), as check_energies sums it: the levels of chunk
  // sums in e_level_ (its two halves in turn), the last chunk's sum into the field.
  e_level_.resize(2 * sum_chunks(std::max<std::size_t>({n, L, contact_count_, ground_count_})));
  const auto sum = [&](const Buf<double>& x, std::size_t count, std::size_t offset) {
    const double* from = c(x);
    for (int half = 0; count > kSumChunk; half ^= 1) {
      double* to = d(e_level_) + half * (e_level_.size() / 2);
      Dev::launch(sum_chunks(count), ChunkSumKernel{from, count, to});
      from = to;
      count = sum_chunks(count);
    }
    Dev::launch(1, ChunkSumKernel{from, count, field<double>(e_sums_, offset)});
  };
  sum(e_kinetic_, n, offsetof(EnergySums, kinetic));
  sum(e_gravity_, n, offsetof(EnergySums, gravity_work));
  if (!M_.load.empty()) sum(e_load_, n, offsetof(EnergySums, load_work));
  sum(e_links_, L, offsetof(EnergySums, links));
  sum(e_many_body_, n, offsetof(EnergySums, many_body));
  sum(e_pairs_, contact_count_, offsetof(EnergySums, pairs));
  sum(e_ground_, ground_count_, offsetof(EnergySums, ground));
  EnergySums s;
  Dev::download(&s, e_sums_, 1);
  Energies e;
  e.kinetic = s.kinetic;
  e.contact = s.pairs + s.ground + s.projectile_contact;
  e.elastic = s.links + s.many_body + e.contact;
  e.projectile_kinetic = s.projectile_kinetic;
  e.gravity_work = s.gravity_work + s.projectile_gravity;
  e.grip_work = s.grip_work;
  e.load_work = M_.load.empty() ? 0.0 : s.load_work;
  e.projectile_work = s.projectile_work;
  return e;
}

// The draw list of the current state (render::make_snapshot's automata, surface, fragments and scale), on
// the device; then written into the target's buffers where it can be (zero copy), else copied to the host:
// the drawn automata and triangles, not the state.
template <class Dev>
void DeviceBackend<Dev>::draw(const render::SnapshotOptions& o, const std::array<double, 3>& origin,
                              render::DrawList& out, render::DrawTarget* target) {
  const Model& m = M_;
  const std::size_t n = m.size(), L = m.link_slots(), corners = m.surface.corner.size();
  if (!draw_ready_) {
    Dev::upload(strength_class_, m.strength_class);
    Dev::upload(boxed_, m.boxed);
    Dev::upload(object_size_, render::object_sizes(m));
    if (corners) {
      Dev::upload(carries_, render::carrying_automata(m));
      Dev::upload(surface_automaton_, m.surface.automaton);
      Dev::upload(surface_corner_, m.surface.corner);
      Dev::upload(first_corner_, m.surface.first_corner);
      Dev::upload(corners_of_, m.surface.corners_of);
      Dev::upload(surface_offset_, m.surface.offset);
      surface_out_.resize(corners);
    }
    for (auto* b : {&parent_, &label_, &fragment_size_}) b->resize(n);
    draw_value_.resize(n);
    colour_.resize(n);
    draw_status_.resize(1);
    draw_ready_ = true;
  }
  const bool surface = o.draw == render::DrawMode::surface && corners > 0;
  const bool scaled = o.colour == render::ColourMode::stress || o.colour == render::ColourMode::speed;
  const DrawStatus zero;
  Dev::upload(draw_status_, &zero, 1);
  // Fragments: each automaton's smallest, their sizes and number.
  const FragmentRoots roots{d(parent_)};
  Dev::launch(n, FragmentStartKernel{d(parent_), d(fragment_size_)});
  Dev::launch(L, FragmentUniteKernel{roots, link_ends(), c(intact_)});
  Dev::launch(n, FragmentLabelKernel{roots, d(label_), d(fragment_size_),
                                     field<std::uint32_t>(draw_status_, offsetof(DrawStatus, fragments))});
  if (scaled)
    Dev::launch_reduce(n, DrawValueKernel{o.colour == render::ColourMode::stress, c(stress_), c(vx_), c(vy_), c(vz_), d(draw_value_)},
                       field<float>(draw_status_, offsetof(DrawStatus, largest)), nullptr);
  DrawStatus st;
  Dev::download(&st, draw_status_, 1);
  // Colours, then the automata drawn (in automaton order) and the surface's corners.
  const AutomatonLinks links{n, c(neighbour_), c(neighbour_below_), m.explicit_links.first.empty() ? nullptr : c(e_first_),
                             c(e_of_)};
  Dev::launch(n, DrawColourKernel{o.colour, links, c(intact_), softening_ ? c(damage_) : nullptr, c(strength_class_),
                                  c(group_), c(object_), c(label_), c(fragment_size_), c(object_size_), c(draw_value_),
                                  render::colour_scale(o, st.largest), d(colour_)});
  Dev::launch(n, DrawFlagKernel{links, c(intact_), opt(boxed_), surface ? c(carries_) : nullptr, o.all_automata, d(flag_)});
  const std::uint32_t drawn = scan_total(c(flag_), place_, n);
  // Where the list goes: the target's buffers (zero copy), or the device's, then copied to the host.
  render::Instance* instances = nullptr;
  render::SurfaceVertex* vertices = nullptr;
  using W = render::DrawTarget;
  // What is mapped is unmapped also where a map or a launch between throws: a buffer left mapped is refused
  // by every later map, and OpenGL must not draw from or delete a buffer CUDA holds. (The error thrown is
  // the first one's.)
  struct Mapped {
    W* target = nullptr;
    bool automata = false, surface = false;
    ~Mapped() {
      for (const auto& [held, which] : {std::pair{surface, W::surface}, std::pair{automata, W::automata}}) {
        try {
          if (held) Dev::unmap_gl(*target, which);
        } catch (...) {
        }
      }
    }
  } mapped{target};
  if (target && o.draw != render::DrawMode::spheres && target->refused().empty()) {
    std::string& why = target->refused();  // set where the device cannot share them: not tried again
    instances = static_cast<render::Instance*>(
        Dev::map_gl(*target, W::automata, std::max<std::size_t>(drawn, 1) * sizeof(render::Instance), why));
    mapped.automata = instances != nullptr;
    if (instances && surface) {
      vertices = static_cast<render::SurfaceVertex*>(
          Dev::map_gl(*target, W::surface, corners * sizeof(render::SurfaceVertex), why));
      mapped.surface = vertices != nullptr;
      if (!vertices) {
        mapped.automata = false;
        Dev::unmap_gl(*target, W::automata);
        instances = nullptr;
      }
    }
  }
  const bool shared = instances != nullptr;
  if (!shared) {
    if (instances_.size() < drawn) {
      instances_.resize(drawn + drawn / 2);
      draw_radius_.resize(drawn + drawn / 2);
    }
    instances = d(instances_);
    vertices = surface ? d(surface_out_) : nullptr;
  }
  const DrawOrigin at{origin[0], origin[1], origin[2]};
  Dev::launch(n, DrawAutomataKernel{c(flag_), c(place_), c(px_), c(py_), c(pz_), c(qw_), c(qx_), c(qy_), c(qz_), c(radius_),
                                    c(colour_), at, instances, shared ? nullptr : d(draw_radius_)});
  if (surface) {
    const SurfaceCorners S{c(surface_automaton_), c(surface_corner_), c(first_corner_), c(corners_of_), c(surface_offset_)};
    Dev::launch(corners, DrawSurfaceKernel{S, c(label_), c(px_), c(py_), c(pz_), c(qw_), c(qx_), c(qy_), c(qz_), c(colour_),
                                           at, vertices});
  }
  if (shared) {
    mapped.automata = false;
    Dev::unmap_gl(*target, W::automata);
    mapped.surface = false;
    if (surface) Dev::unmap_gl(*target, W::surface);
    out.shared_automata = drawn;
    out.shared_corners = surface ? corners : 0;
  } else {
    out.automata.resize(drawn);
    out.radius.resize(drawn);
    Dev::download(out.automata.data(), instances_, drawn);
    Dev::download(out.radius.data(), draw_radius_, drawn);
    out.surface.resize(surface ? corners : 0);
    if (surface) Dev::download(out.surface.data(), surface_out_, corners);
  }
  out.shared_why =
      target && !shared ? (target->refused().empty() ? "the spheres mode is drawn from a copy" : target->refused()) : "";
  const std::size_t np = m.projectiles.size();
  std::vector<DeviceProjectile> dp(np);
  Dev::download(dp.data(), proj_, np);
  out.projectiles.resize(np);
  for (std::size_t p = 0; p < np; ++p) out.projectiles[p] = dp[p].position;
  out.fragments = static_cast<std::int32_t>(st.fragments);
  out.largest = st.largest;
  out.softening = softening_;
}

// The host's State from the device arrays.
template <class Dev>
void DeviceBackend<Dev>::sync() {
  const std::size_t n = M_.size(), L = M_.link_slots();
  download3(S_.x, px_, py_, pz_);
  download3(S_.v, vx_, vy_, vz_);
  download3(S_.w, wx_, wy_, wz_);
  std::vector<float> qw(n), qx(n), qy(n), qz(n);
  Dev::download(qw.data(), qw_, n);
  Dev::download(qx.data(), qx_, n);
  Dev::download(qy.data(), qy_, n);
  Dev::download(qz.data(), qz_, n);
  for (std::size_t a = 0; a < n; ++a) S_.q[a] = {qw[a], qx[a], qy[a], qz[a]};
  Dev::download(S_.s.data(), stress_, n);
  Dev::download(S_.mean_stress.data(), mean_stress_, n);
  Dev::download(S_.f.data(), f_out_, n);
  Dev::download(S_.t.data(), t_out_, n);
  Dev::download(S_.intact.data(), intact_, L);
  if (softening_) Dev::download(S_.link_damage.data(), damage_, L);
  download3(S_.link_ut, utx_, uty_, utz_);
  download3(S_.link_moment, ex_mx_, ex_my_, ex_mz_);
  S_.contacts.resize(contact_count_);
  Dev::download(S_.contacts.data(), contacts_, contact_count_);
  S_.ground_contacts.resize(ground_count_);
  Dev::download(S_.ground_contacts.data(), ground_, ground_count_);
  std::vector<double> ref(cpu::tiled_size(n, cpu::kRefRows));
  Dev::download(ref.data(), ref_, ref.size());
  S_.x_at_rebuild.resize(n);
  for (std::size_t a = 0; a < n; ++a) {
    const double* r = ref.data() + cpu::tile_index(a, cpu::kRefRows);
    S_.x_at_rebuild[a] = {r[0], r[cpu::kTile], r[2 * cpu::kTile]};
  }
  const std::size_t np = S_.projectiles.size();
  std::vector<DeviceProjectile> dp(np);
  Dev::download(dp.data(), proj_, np);
  for (std::size_t p = 0; p < np; ++p) {
    ProjectileState& ps = S_.projectiles[p];
    ps.position = dp[p].position;
    ps.velocity = dp[p].velocity;
    ps.angular_velocity = dp[p].angular_velocity;
    ps.orientation = dp[p].orientation;
    ps.force = dp[p].force;
    ps.ground = dp[p].ground;
    ps.work = dp[p].work;
  }
  if (np) {
    std::vector<std::uint32_t> start(np + 1);
    Dev::download(start.data(), proj_start_, np + 1);
    for (std::size_t p = 0; p < np; ++p) {
      std::vector<BodyContact>& list = S_.projectiles[p].contacts;
      list.resize(start[p + 1] - start[p]);
      Dev::download(list.data(), proj_lists_, list.size(), start[p]);
    }
  }
  S_.projectile_contacts.resize(pair_count_);
  Dev::download(S_.projectile_contacts.data(), proj_pairs_, pair_count_);
  Dev::download(S_.grip_work.data(), grip_work_, S_.grip_work.size());
  Dev::download(S_.grip_force.data(), grip_force_, S_.grip_force.size());
  // The breaks' records, each step's in slot order (the CPU's).
  std::vector<std::uint32_t> codes(logged_);
  Dev::download(codes.data(), break_log_, logged_);
  auto code = codes.begin();
  for (const auto& [step, count] : logged_steps_) {
    std::sort(code, code + count,
              [](std::uint32_t a, std::uint32_t b) { return (a & ~cpu::kBreakByStress) < (b & ~cpu::kBreakByStress); });
    for (const auto end = code + count; code != end; ++code) {
      const int crit = *code & cpu::kBreakByStress ? 1 : 0;
      S_.breaks.push_back({step, *code & ~cpu::kBreakByStress, static_cast<BreakCriterion>(crit)});
      ++S_.broken_by[crit];
    }
  }
  logged_ = 0;
  logged_steps_.clear();
}

}  // namespace mca::gpu
