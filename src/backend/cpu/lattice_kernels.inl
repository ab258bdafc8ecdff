





// The lattice kernels of lattice_kernels.hpp, written once for a lane type V (float, or a SIMD vector of
// floats: backend/cpu/lanes.hpp). Included by kernels_<set>.cpp inside its own namespace, after lanes.hpp
// and the physics headers; V is that namespace's lane type.
//
// A block is W consecutive automata (or link slots along one axis), one per lane; what is left at the end
// of a range goes through the same code with V = float, one at a time. A lane computes exactly what the
// scalar code computes (the same formulas, operation by operation); where the scalar code branches, the
// lanes compute both sides and select. Neighbours are loaded as a run when the lanes' neighbours are
// consecutive (inside a box of the lattice, the common case) and gathered otherwise: the same values.

template <class X>
struct Block {
  using L = Lanes<X>;
  using D = typename L::D;
  using U = typename L::U;
  using M = typename L::M;
  static constexpr std::size_t W = L::size;

  // The far ends of the lanes' links in direction dir (0-2: up along x, y, z; 3-5: below): their indices
  // and a 0/1 flag of "there is a neighbour". A block whose run (BlockRun) is known loads its far ends as
  // that run, lanes without a neighbour included (their values are not used); the others, and one lane
  // at a time, read the neighbour table (kNoLink is replaced by the lane's own automaton, so that a
  // gather stays in bounds).
  struct Far {
    U j;
    X has;
    bool run;
    std::size_t j0;
  };
  static MCA_LANE Far far_ends(const LatticeView& v, int dir, std::size_t a0) {
    Far f;
    if constexpr (W > 1) {
      const BlockRun br = v.runs[static_cast<std::size_t>(dir) * v.blocks + a0 / W];
      if (br.offset != BlockRun::kGather) {
        f.run = true;
        f.j0 = static_cast<std::size_t>(static_cast<std::int64_t>(a0) + br.offset);
        f.j = L::iota(f.j0);
        f.has = to_lanes((U(br.has) >> L::iota(0)) & U(1u));
        return f;
      }
    }
    const std::uint32_t* nb = (dir < 3 ? v.up : v.below) + static_cast<std::size_t>(dir % 3) * v.n;
    const U raw = L::load(nb + a0);
    const auto none = raw == U(Model::kNoLink);
    f.j = select(none, L::iota(a0), raw);
    f.has = to_lanes(select(none, U(0u), U(1u)));
    f.run = false;
    f.j0 = 0;
    return f;
  }
  static MCA_LANE X to_lanes(const U& u) { return L::to_lanes(u); }
  template <class T>
  static MCA_LANE auto at(const T* p, const Far& f) {
    return f.run ? L::load(p + f.j0) : L::gather(p, f.j);
  }
  static MCA_LANE X bytes_at(const std::uint8_t* p, const Far& f) {
    return f.run ? L::load_bytes(p + f.j0) : L::gather_bytes(p, f.j);
  }
  // Three arrays (x, y, z) of floats or doubles at the lanes' own elements, or at their far ends.
  template <class T>
  static MCA_LANE auto load3(const T* x, const T* y, const T* z, std::size_t a) {
    return Vec3T<decltype(L::load(x))>{L::load(x + a), L::load(y + a), L::load(z + a)};
  }
  template <class T, class Y>
  static MCA_LANE void store3(const Vec3T<Y>& v, T* x, T* y, T* z, std::size_t a) {
    L::store(v.x, x + a);
    L::store(v.y, y + a);
    L::store(v.z, z + a);
  }
  template <class T>
  static MCA_LANE auto soa_far3(const T* x, const T* y, const T* z, const Far& f) {
    return Vec3T<decltype(at(x, f))>{at(x, f), at(y, f), at(z, f)};
  }
  template <class T>
  static MCA_LANE auto gather3(const T* x, const T* y, const T* z, const U& i) {
    return Vec3T<decltype(L::gather(x, i))>{L::gather(x, i), L::gather(y, i), L::gather(z, i)};
  }
  // Per lane from an array of structs.
  static MCA_LANE Vec3T<X> lanes_of(const Vec3* p, std::size_t a0) {
    return {L::from([&](std::size_t k) { return p[a0 + k].x; }), L::from([&](std::size_t k) { return p[a0 + k].y; }),
            L::from([&](std::size_t k) { return p[a0 + k].z; })};
  }
  template <class T>
  static MCA_LANE X group_value(const LatticeView& v, std::size_t a0, T get) {
    if (v.one_group) return X(get(v.groups[v.group[0]]));
    return L::from([&](std::size_t k) { return get(v.groups[v.group[a0 + k]]); });
  }

  // Row `row` of a tiled array of `rows` rows (tile_index, LatticeView): for the lanes' own automata (a
  // block at a multiple of W lies in one row of one tile), or for the far ends f: a run lies in one row or
  // across the rows of two tiles (two loads, each lane taking its own), else the lanes gather.
  template <class T>
  static MCA_LANE auto own(const T* base, std::size_t rows, std::size_t row, std::size_t a0) {
    return L::load(base + tile_index(a0, rows) + row * kTile);
  }
  template <class T, class Y>
  static MCA_LANE void put(const Y& x, T* base, std::size_t rows, std::size_t row, std::size_t a0) {
    L::store(x, base + tile_index(a0, rows) + row * kTile);
  }
  template <class T>
  static MCA_LANE auto row_far(const T* base, std::size_t rows, std::size_t row, const Far& f) {
    base += row * kTile;
    auto value = [&](std::size_t k) { return base[tile_index(L::lane(f.j, k), rows)]; };
    if constexpr (W == 1) {
      return value(0);
    } else {
      using Y = decltype(L::load(base));
      if (!f.run) {
        alignas(64) T t[W];
        for (std::size_t k = 0; k < W; ++k) t[k] = value(k);
        return static_cast<Y>(L::load_aligned(t));
      }
      const std::size_t o = f.j0 % kTile;
      const T* p = base + tile_index(f.j0, rows);
      if (o + W <= kTile) return L::load(p);
      // Lanes [0, kTile - o) from this tile's row; lane k >= kTile - o at k - (kTile - o) of the next tile's
      // row, which starts kTile * rows - o after p.
      alignas(64) static constexpr T lane_number[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
      static_assert(W <= 16 && kTile % W == 0, "a block of lanes must lie in one row of one tile");
      return select(L::load(lane_number) < static_cast<T>(kTile - o), L::load(p), L::load(p + kTile * (rows - 1)));
    }
  }
  template <class T>
  static MCA_LANE auto own3(const T* base, std::size_t rows, std::size_t row, std::size_t a0) {
    using Y = decltype(own(base, rows, row, a0));
    return Vec3T<Y>{own(base, rows, row, a0), own(base, rows, row + 1, a0), own(base, rows, row + 2, a0)};
  }
  template <class T>
  static MCA_LANE auto far3(const T* base, std::size_t rows, std::size_t row, const Far& f) {
    using Y = decltype(row_far(base, rows, row, f));
    return Vec3T<Y>{row_far(base, rows, row, f), row_far(base, rows, row + 1, f), row_far(base, rows, row + 2, f)};
  }
  template <class T, class Y>
  static MCA_LANE void put3(const Vec3T<Y>& x, T* base, std::size_t rows, std::size_t row, std::size_t a0) {
    put(x.x, base, rows, row, a0);
    put(x.y, base, rows, row + 1, a0);
    put(x.z, base, rows, row + 2, a0);
  }
  // The link results (LatticeView::out) along an axis, as a tiled array.
  static MCA_LANE float* out_of(const LatticeView& v, std::size_t axis) { return v.out + axis * v.ns * kOutRows; }

  // The geometry of the links in slots off + [a0, a0 + W), from the positions: each pass that needs it
  // forms it again (the same bits each time), which costs less than storing it and reading it back.
  // off: the axis's first slot (axis * n), for a jittered lattice's rest lengths.
  static MCA_LANE auto geometry(const LatticeView& v, const Far& f, std::size_t a0, std::size_t off) {
    const Vec3T<D> xi{L::load(v.px + a0), L::load(v.py + a0), L::load(v.pz + a0)};
    const Vec3T<D> xj{at(v.px, f), at(v.py, f), at(v.pz, f)};
    if (v.rest) return link_geometry(xi, xj, L::load(v.rest + off + a0), L::load(v.inv_rest + off + a0));
    return link_geometry(xi, xj, v.r0, v.inv_r0);
  }
  // The same for the links below: from each lane's lower neighbour (the link's first end, whose slot holds
  // the link) to the lane.
  static MCA_LANE auto geometry_below(const LatticeView& v, const Far& f, std::size_t a0, std::size_t off) {
    const Vec3T<D> xi{at(v.px, f), at(v.py, f), at(v.pz, f)};
    const Vec3T<D> xj{L::load(v.px + a0), L::load(v.py + a0), L::load(v.pz + a0)};
    if (v.rest) return link_geometry(xi, xj, at(v.rest + off, f), at(v.inv_rest + off, f));
    return link_geometry(xi, xj, v.r0, v.inv_r0);
  }

  // The strain as the many-body sum of automata of the lanes' groups takes it: strengthened or not.
  static MCA_LANE X summand(const LatticeView& v, std::size_t a0, const X& e) {
    if (!v.strengthening) return e;
    return L::from([&](std::size_t k) {
      return strengthened_strain(v.groups[v.group[a0 + k]].strengthening, L::lane(e, k)).s;
    });
  }

  static MCA_LANE void many_body(const LatticeView& v, std::size_t a0) {
    X sum[3], cnt[3];
    for (int axis = 0; axis < 3; ++axis) {
      const std::size_t off = static_cast<std::size_t>(axis) * v.n;
      // The link below (it is its lower end's), then the automaton's own: the order of the lattice's cells.
      const Far fb = far_ends(v, 3 + axis, a0);
      const auto has_below = bytes_at(v.intact + off, fb) * fb.has != 0.0f;
      X e_below = summand(v, a0, geometry_below(v, fb, a0, off).eps);
      const auto has_own = L::load_bytes(v.intact + off + a0) != 0.0f;
      X e_own = summand(v, a0, geometry(v, far_ends(v, axis, a0), a0, off).eps);
      if (v.softening) {  // a damaged link's strain in tension counts by its undamaged share
        e_below = select(e_below > 0.0f, (1.0f - at(v.damage + off, fb)) * e_below, e_below);
        e_own = select(e_own > 0.0f, (1.0f - L::load(v.damage + off + a0)) * e_own, e_own);
      }
      X s = 0.0f, c = 0.0f;
      s = select(has_below, s + e_below, s);
      c = select(has_below, c + 1.0f, c);
      s = select(has_own, s + e_own, s);
      c = select(has_own, c + 1.0f, c);
      sum[axis] = s;
      cnt[axis] = c;
    }
    X ff[4];
    for (int k = 0; k < 4; ++k) {
      if (v.one_group) ff[k] = v.free_factor[v.group[0]][k];
      else ff[k] = L::from([&](std::size_t l) { return v.free_factor[v.group[a0 + l]][k]; });
    }
    X lam = group_value(v, a0, [](const GroupParams& g) { return g.lame_lambda; });
    if (v.stiffness != 1.0f) lam = lam * v.stiffness;
    const X lam_theta = lam * volumetric_strain(sum, cnt, ff);
    for (int axis = 0; axis < 3; ++axis) {
      const X per_link = lam_theta * select(cnt[axis] == 1.0f, X(1.0f), X(0.5f));
      L::store(select(cnt[axis] > 0.0f, per_link, X(0.0f)), v.many_body + static_cast<std::size_t>(axis) * v.ns + a0);
    }
  }

  // The constants of the lanes' links (pair of groups).
  static MCA_LANE X pair_value(const LatticeView& v, std::size_t a0, const Far& f, float PairConstants::*field,
                               float LinkDashpots::*damping = nullptr) {
    auto get = [&](const PairConstants& p) { return damping ? p.damping.*damping : p.*field; };
    if (v.one_group) return X(get(v.pairs[v.group[0] * (v.group_count + 1)]));
    return L::from([&](std::size_t k) {
      return get(v.pairs[v.group[a0 + k] * v.group_count + v.group[L::lane(f.j, k)]]);
    });
  }

  // What the links in slots axis * n + [a0, a0 + W) give their ends and leave behind: the direction, the
  // force on the first end (the second takes its opposite), the torque on each end, the trace of the stress
  // term; the shear displacement and damage for the next step (the old ones where not alive or broken);
  // which break, and which of those by displacement; the rest length.
  struct LinkTerms {
    Vec3T<X> n, force, torque, ut;
    X trace = 0.0f, damage = 0.0f, r0 = 0.0f;
    M broke{}, by_displacement{};
  };
  // The terms of those links, whose far ends are f and of which `alive` are intact, from the state before
  // the step (the LatticeView's).
  static MCA_LANE LinkTerms link_terms(const LatticeView& v, int axis, std::size_t a0, const Far& f, const M& alive) {
    const std::size_t off = static_cast<std::size_t>(axis) * v.n, l0 = off + a0;
    const auto g = geometry(v, f, a0, off);
    const Vec3T<X> n = g.n;
    const X eps = g.eps;
    // The rest length and its inverse: the lattice's, or each link's (jittered).
    const X r0 = v.rest ? to_float(L::load(v.rest + l0)) : X(v.r0);
    const X inv_r0 = v.rest ? L::load(v.inv_rest + l0) : X(v.inv_r0);
    const std::size_t s0 = static_cast<std::size_t>(axis) * v.ns + a0;  // in the scratch arrays
    const X mb_i = L::load(v.many_body + s0), mb_j = at(v.many_body + (s0 - a0), f);
    const X G = pair_value(v, a0, f, &PairConstants::G);
    X kt = pair_value(v, a0, f, &PairConstants::kt);
    if (v.rest) kt = kt * (v.r0 * inv_r0);  // k_s G S / r0 of the link's own length
    X kt_slope = 0.0f;
    X sigma;
    if (v.strengthening) {
      // Per lane, as the scalar code: the strengthened strains and spring of the two ends.
      float fi[W], fj[W], gi[W], gj[W], k_t[W], k_s[W];
      for (std::size_t k = 0; k < W; ++k) {
        const Strengthening& si = v.groups[v.group[a0 + k]].strengthening;
        const Strengthening& sj = v.groups[v.group[L::lane(f.j, k)]].strengthening;
        const float e = L::lane(eps, k), kt0 = L::lane(kt, k);
        const StrengthenedStrain a = strengthened_strain(si, e), b = strengthened_strain(sj, e);
        fi[k] = a.f;
        fj[k] = b.f;
        gi[k] = a.g;
        gj[k] = b.g;
        k_t[k] = kt0 * 0.5f * (a.f + b.f);
        k_s[k] = kt0 * 0.5f * (strengthening_slope(si, e) + strengthening_slope(sj, e)) * L::lane(inv_r0, k);
      }
      sigma = link_normal_stress<X>(G, eps, L::load(fi), L::load(fj), L::load(gi), L::load(gj), mb_i, mb_j);
      kt = L::load(k_t);
      kt_slope = L::load(k_s);
    } else {
      sigma = link_normal_stress<X>(G, eps, mb_i, mb_j);
    }
    LinkInputT<X> in;
    in.g = {n, r0 * (1.0f + eps), eps};
    in.area = v.area;
    in.sigma = sigma;
    in.kt = kt;
    in.kt_slope = kt_slope;
    in.damp_normal = pair_value(v, a0, f, nullptr, &LinkDashpots::normal);
    in.damp_tangential = pair_value(v, a0, f, nullptr, &LinkDashpots::tangential);
    in.dv = delta(load3(v.vx, v.vy, v.vz, a0), soa_far3(v.vx, v.vy, v.vz, f));
    in.wi = rounded(load3(v.wx, v.wy, v.wz, a0));
    in.wj = rounded(soa_far3(v.wx, v.wy, v.wz, f));
    in.ut = load3(v.utx, v.uty, v.utz, l0);
    in.dt = v.dt;
    const LinkOutputT<X> o = link_force(in);
    // Strengths of the weaker automaton (physics.md sec. 4): std::min(i's, j's), times the link's own
    // factor where the strengths spread (Model::link_strength).
    const X ti = L::load(v.tensile + a0), tj = at(v.tensile, f);
    const X ci = L::load(v.compressive + a0), cj = at(v.compressive, f);
    const X si = L::load(v.break_strain + a0), sj = at(v.break_strain, f);
    X tensile = select(tj < ti, tj, ti), compressive = select(cj < ci, cj, ci);
    X strain = select(sj < si, sj, si);
    if (v.link_strength) {
      const X w = L::load(v.link_strength + l0);
      tensile = tensile * w;
      compressive = compressive * w;
      strain = strain * w;
    }
    const X p = 0.5f * (L::load(v.mean_stress + a0) + at(v.mean_stress, f));
    LinkTerms t;
    t.n = n;
    t.r0 = r0;
    Vec3T<X> force = o.force_i;
    M by_displacement{}, broke{};
    if (v.softening) {
      // The force with this step's damage (the one the many-body terms took), the test on the undamaged
      // stresses, the new damage for the next step.
      const X damage = L::load(v.damage + l0);
      // The pair's 2 G_f E / d, for a jittered link of its own length and the lattice's stiffness factor
      // on E: each link then takes G_f times its cross-section (softening_constant).
      X soft = pair_value(v, a0, f, &PairConstants::soft);
      if (v.rest) soft = soft * (v.stiffness * v.r0 * inv_r0);
      const auto b = link_softening_test(eps * r0, r0, o.sigma, o.tau2, p, tensile, tensile / compressive, strain,
                                         v.stress_coefficient, soft, damage);
      force = softened_force(in, o, damage);
      t.damage = select(alive, b.damage, damage);
      by_displacement = b.displacement;
      broke = alive && (b.displacement || b.stress);
    } else {
      const auto b = link_break_test(eps * r0, r0, o.sigma, o.tau2, p, tensile, tensile / compressive, strain,
                                     v.stress_coefficient);
      by_displacement = b.displacement;
      broke = alive && (b.displacement || b.stress);
    }
    t.broke = broke;
    t.by_displacement = by_displacement;
    // What both ends gather: the force, the torque (r/2) n x F_t = (r/2) n x F (n x n = 0, r = r0 (1 + eps))
    // and the trace of the Love average term (r0/2) sym(n (x) F) of physics.md sec. 3.
    const Vec3T<X> hf = force * (0.5f * r0);
    t.force = force;
    t.torque = cross(n, hf) * (1.0f + eps);
    t.trace = dot(n, hf);
    // A link that breaks keeps its displacement until the caller clears it; a broken one keeps its zero.
    t.ut = select(alive && !broke, o.ut, in.ut);
    return t;
  }

  // links: forces of the links in slots off + [a0, a0 + W); breaks go to out[], in slot order.
  static MCA_LANE std::size_t links(const LatticeView& v, int axis, std::size_t a0, std::uint32_t* out) {
    const std::size_t l0 = static_cast<std::size_t>(axis) * v.n + a0;
    const auto alive = L::load_bytes(v.intact + l0) != 0.0f;
    if (!L::any(alive)) return 0;
    const LinkTerms t = link_terms(v, axis, a0, far_ends(v, axis, a0), alive);
    if (v.last) store3(t.n, v.nx, v.ny, v.nz, static_cast<std::size_t>(axis) * v.ns + a0);  // for the averaged stress
    if (v.softening) L::store(t.damage, v.damage + l0);
    std::size_t count = 0;
    if (L::any(t.broke))
      for (std::size_t k = 0; k < W; ++k)
        if (L::lane(t.broke, k))
          out[count++] = static_cast<std::uint32_t>(l0 + k) | (L::lane(t.by_displacement, k) ? 0u : kBreakByStress);
    float* res = out_of(v, static_cast<std::size_t>(axis));
    put3(t.force, res, kOutRows, kOutFx, a0);
    put3(t.torque, res, kOutRows, kOutTx, a0);
    put(t.trace, res, kOutRows, kOutTrace, a0);
    store3(t.ut, v.utx, v.uty, v.utz, l0);
    return count;
  }

  // Explicit links [k0, k0 + W): direction and strain from the positions of their ends.
  static MCA_LANE void explicit_geometry(const LatticeView& v, const ExplicitView& e, std::size_t k0) {
    const U i = L::load(e.i + k0), j = L::load(e.j + k0);
    const Vec3T<D> xi{L::gather(v.px, i), L::gather(v.py, i), L::gather(v.pz, i)};
    const Vec3T<D> xj{L::gather(v.px, j), L::gather(v.py, j), L::gather(v.pz, j)};
    const auto g = link_geometry(xi, xj, L::load(e.r0 + k0), L::load(e.inv_r0 + k0));
    store3(g.n, e.nx, e.ny, e.nz, k0);
    L::store(g.eps, e.eps + k0);
    if (!L::any(shells(e, k0))) return;  // kappa is read only for a shell's automata
    // The relative rotation about n x m after this step, over r0 (kappa_nn): what the bending spring's
    // moment about that axis will be (link_bending) over k_out r0, for the automata's many-body part.
    const QuatT<X> qi{L::gather(v.qw, i), L::gather(v.qx, i), L::gather(v.qy, i), L::gather(v.qz, i)};
    const QuatT<X> qj{L::gather(v.qw, j), L::gather(v.qx, j), L::gather(v.qy, j), L::gather(v.qz, j)};
    const Vec3T<X> m = shell_normal(qi, qj, load3(e.m0x, e.m0y, e.m0z, k0), g.n);
    const Vec3T<X> wrel = rounded(gather3(v.wx, v.wy, v.wz, j)) - rounded(gather3(v.wx, v.wy, v.wz, i));
    const X k_out = L::load(e.k_out + k0);
    const X mb = L::load(e.mz + k0) + k_out * v.dt * dot(wrel, cross(g.n, m));
    L::store(mb / (k_out * L::load(e.r0f + k0)), e.kappa + k0);
  }

  // Which of the links [k0, k0 + W) have a bending spring (ExplicitView::bends; null: all of them).
  static MCA_LANE M springs(const ExplicitView& e, std::size_t k0) {
    return e.bends ? L::load_bytes(e.bends + k0) != 0.0f : M(true);
  }
  // Which of them are a shell's (surface mode; null: all of them), the others the random lattice's.
  static MCA_LANE M shells(const ExplicitView& e, std::size_t k0) {
    return e.bends ? L::load_bytes(e.bends + k0) == 1.0f : M(true);
  }

  // Explicit links [k0, k0 + W): the lattice links' law with each link's own r0 and S (see links above).
  static MCA_LANE std::size_t explicit_links(const LatticeView& v, const ExplicitView& e, std::size_t k0,
                                             std::uint32_t* out) {
    const std::size_t l0 = e.slot0 + k0;
    const auto alive = L::load_bytes(v.intact + l0) != 0.0f;
    if (!L::any(alive)) return 0;
    const U i = L::load(e.i + k0), j = L::load(e.j + k0);
    const Vec3T<X> n = load3(e.nx, e.ny, e.nz, k0);
    const X eps = L::load(e.eps + k0);
    const X r0 = L::load(e.r0f + k0), inv_r0 = L::load(e.inv_r0 + k0), to_stress = L::load(e.inv_r0_area + k0);
    const X mb_i = L::gather(e.weight, i) * to_stress, mb_j = L::gather(e.weight, j) * to_stress;
    const X G = L::load(e.G + k0);
    X kt = L::load(e.kt + k0);
    X kt_slope = 0.0f;
    X sigma;
    if (v.strengthening) {
      float fi[W], fj[W], gi[W], gj[W], k_t[W], k_s[W];
      for (std::size_t k = 0; k < W; ++k) {
        const Strengthening& si = v.groups[v.group[L::lane(i, k)]].strengthening;
        const Strengthening& sj = v.groups[v.group[L::lane(j, k)]].strengthening;
        const float ek = L::lane(eps, k), kt0 = L::lane(kt, k);
        const StrengthenedStrain a = strengthened_strain(si, ek), b = strengthened_strain(sj, ek);
        fi[k] = a.f;
        fj[k] = b.f;
        gi[k] = a.g;
        gj[k] = b.g;
        k_t[k] = kt0 * 0.5f * (a.f + b.f);
        k_s[k] = kt0 * 0.5f * (strengthening_slope(si, ek) + strengthening_slope(sj, ek)) * L::lane(inv_r0, k);
      }
      sigma = link_normal_stress<X>(G, eps, L::load(fi), L::load(fj), L::load(gi), L::load(gj), mb_i, mb_j);
      kt = L::load(k_t);
      kt_slope = L::load(k_s);
    } else {
      sigma = link_normal_stress<X>(G, eps, mb_i, mb_j);
    }
    LinkInputT<X> in;
    in.g = {n, r0 * (1.0f + eps), eps};
    in.area = L::load(e.area + k0);
    in.sigma = sigma;
    in.kt = kt;
    in.kt_slope = kt_slope;
    in.damp_normal = L::load(e.damp_normal + k0);
    in.damp_tangential = L::load(e.damp_tangential + k0);
    in.dv = delta(gather3(v.vx, v.vy, v.vz, i), gather3(v.vx, v.vy, v.vz, j));
    in.wi = rounded(gather3(v.wx, v.wy, v.wz, i));
    in.wj = rounded(gather3(v.wx, v.wy, v.wz, j));
    in.ut = load3(v.utx, v.uty, v.utz, l0);
    in.dt = v.dt;
    const LinkOutputT<X> o = link_force(in);
    // The bending spring, where a lane has one; without, its moment, torque and stresses are exact zeros
    // (the moment stays +0), and x + 0 = x below, so the block skips it with the same bits. A shell's
    // spring keeps its moment on the pair's frame (link_bending); a random-lattice link's keeps its ends'
    // relative rotation (volume_link_bending: no reference axis), in the same state.
    const M spring = springs(e, k0), shell = shells(e, k0);
    const bool bends = L::any(spring);
    const bool shell_bends = bends && L::any(shell), volume_bends = bends && !L::all(shell);
    LinkBendingInputT<X> bi;
    LinkBendingOutputT<X> bo{};
    if (bends) {
      bi.moment = load3(e.mx, e.my, e.mz, k0);
      const X k_in = L::load(e.k_in + k0), k_twist = L::load(e.k_twist + k0), s_in = L::load(e.s_in + k0);
      if (shell_bends) {
        const QuatT<X> qi{L::gather(v.qw, i), L::gather(v.qx, i), L::gather(v.qy, i), L::gather(v.qz, i)};
        const QuatT<X> qj{L::gather(v.qw, j), L::gather(v.qx, j), L::gather(v.qy, j), L::gather(v.qz, j)};
        bi.n = n;
        bi.m = shell_normal(qi, qj, load3(e.m0x, e.m0y, e.m0z, k0), n);
        bi.wi = in.wi;
        bi.wj = in.wj;
        bi.k_twist = k_twist;
        bi.k_in = k_in;
        bi.k_out = L::load(e.k_out + k0);
        bi.s_in = s_in;
        bi.s_out = L::load(e.s_out + k0);
        bi.s_twist = L::load(e.s_twist + k0);
        bi.extra = (L::gather(e.bend_weight, i) + L::gather(e.bend_weight, j)) * inv_r0;
        bi.dt = v.dt;
        bo = link_bending(bi);
      }
      if (volume_bends) {
        // (A lane of neither kind, the random lattice's at link_bending = 0, keeps the shell's zeros.)
        const M volume = spring && !shell;
        const VolumeBendingT<X> vb = volume_link_bending(VolumeBendingInputT<X>{n, in.wi, in.wj, bi.moment, k_in, k_twist, s_in, v.dt});
        bo.moment = select(volume, vb.phi, bo.moment);
        bo.torque = select(volume, vb.torque, bo.torque);
        bo.sigma = select(volume, vb.sigma, bo.sigma);
        bo.tau = select(volume, vb.tau, bo.tau);
      }
    }
    // The criteria see the section's most loaded fibre: the pair's stress plus the bending's, the pair's
    // shear plus the twist's.
    using std::sqrt;
    const X tau = bends ? sqrt(o.tau2) + bo.tau : sqrt(o.tau2);
    // The weaker end's strengths times the link's own factor, formed once (ExplicitView::tensile).
    const X tensile = L::load(e.tensile + k0), compressive = L::load(e.compressive + k0);
    const X strain = L::load(e.strain + k0);
    const X sigma_f = bends ? o.sigma + bo.sigma : o.sigma;
    // A shell's link is held to the lattice's criterion, a random-lattice link to its own stresses
    // (random_link_effort), softening or not; a block of one kind computes one.
    const M own = !shells(e, k0);
    const X f = v.stress_coefficient * tensile;
    X effort{};
    BreakTest<X> b;
    if (L::any(own)) {
      const X fc = v.stress_coefficient * compressive;
      effort = random_link_effort(sigma_f, tau, f, fc);
      if (bends) {
        // A random-lattice link's section bent: its fibre in tension (above) and the one in compression.
        const X pressed = random_link_effort(o.sigma - bo.sigma, tau, f, fc);
        effort = select(pressed > effort, pressed, effort);
      }
      b = link_break_test_at(eps * r0, r0, effort, strain);
    }
    if (!L::all(own)) {
      // (Only a shell's link reads p: a random-lattice automaton's mean stress is whole only on a call's
      // last step, see the automata kernel.)
      const X p = 0.5f * (L::gather(v.mean_stress, i) + L::gather(v.mean_stress, j));
      const auto lattice = link_break_test(eps * r0, r0, sigma_f, tau * tau, p, tensile, tensile / compressive, strain,
                                           v.stress_coefficient);
      b.displacement = lattice.displacement;
      b.stress = (own && b.stress) || (!own && lattice.stress);
    }
    auto by_displacement = b.displacement;
    auto broke = alive && (b.displacement || b.stress);
    Vec3T<X> force = o.force_i;
    Vec3T<X> bend_torque = bo.torque;
    if (e.soft) {
      // Links that soften (the random lattice's, of a material with a fracture energy), as the lattice
      // links above: the force with this step's damage, the test on the undamaged stresses, the new damage.
      const X soft = L::load(e.soft + k0);
      const auto soft_lanes = soft > 0.0f;
      if (L::any(soft_lanes)) {
        const X damage = L::load(v.damage + l0);
        // Only random links soften (a shell's break at once), so their effort is the one above.
        const auto t = link_softening_test_at(eps * r0, r0, effort, f, strain, soft, damage);
        force = select(soft_lanes, softened_force(in, o, damage), force);
        // The bending spring's moment is carried by the undamaged share of the section, as its shear
        // spring's force (its full moment is kept, as the shear displacement is: the secant).
        if (bends) bend_torque = select(soft_lanes, bo.torque * (1.0f - damage), bend_torque);
        L::store(select(alive && soft_lanes, t.damage, damage), v.damage + l0);
        by_displacement = (soft_lanes && t.displacement) || (!soft_lanes && by_displacement);
        broke = alive && ((soft_lanes && (t.displacement || t.stress)) || (!soft_lanes && (b.displacement || b.stress)));
      }
    }
    std::size_t count = 0;
    if (L::any(broke))
      for (std::size_t k = 0; k < W; ++k)
        if (L::lane(broke, k))
          out[count++] = static_cast<std::uint32_t>(l0 + k) | (L::lane(by_displacement, k) ? 0u : kBreakByStress);
    const Vec3T<X> hf = force * (0.5f * r0);
    put3(force, e.out, kExplicitOutRows, kOutFx, k0);
    put3(cross(n, hf) * (1.0f + eps), e.out, kExplicitOutRows, kOutTx, k0);
    store3(select(alive && !broke, o.ut, in.ut), v.utx, v.uty, v.utz, l0);
    if (bends) {
      store3(select(alive && !broke, bo.moment, bi.moment), e.mx, e.my, e.mz, k0);
      put3(bend_torque, e.out, kExplicitOutRows, kExplicitOutBx, k0);
    }
    return count;
  }

  static MCA_LANE void add_if(const M& m, Sym3T<X>& s, const Sym3T<X>& a) {
    s.xx = select(m, s.xx + a.xx, s.xx);
    s.yy = select(m, s.yy + a.yy, s.yy);
    s.zz = select(m, s.zz + a.zz, s.zz);
    s.xy = select(m, s.xy + a.xy, s.xy);
    s.yz = select(m, s.yz + a.yz, s.yz);
    s.zx = select(m, s.zx + a.zx, s.zx);
  }

  // What an automaton has gathered before its contacts and loads: its weight, then its links' forces,
  // torques and the traces of their stress terms, and on the last step those terms themselves.
  struct Gathered {
    Vec3T<X> f, t;
    Sym3T<X> s_links;
    X trace = 0.0f;
  };
  static MCA_LANE Gathered weight(const LatticeView& v, std::size_t a0) {
    const X m = v.uniform_bodies ? X(v.body[0]) : L::load(v.mass + a0);
    Gathered g;
    g.f = Vec3T<X>{X(v.gravity.x), X(v.gravity.y), X(v.gravity.z)} * m;
    return g;
  }
  // The automata in the lanes `live` take a link's terms: as its upper end (below) the force's opposite,
  // as its first end the force; the torque and trace either way; the stress term on the last step, which
  // `n` gives (a function: the direction is read only then).
  template <class N>
  static MCA_LANE void take(const LatticeView& v, Gathered& g, const M& live, bool below, const Vec3T<X>& F,
                            const Vec3T<X>& torque, const X& trace, const X& half, const N& n) {
    g.f = select(live, below ? g.f - F : g.f + F, g.f);
    g.t = select(live, g.t + torque, g.t);
    g.trace = select(live, g.trace + trace, g.trace);
    if (v.last) add_if(live, g.s_links, sym_outer(n(), F, half));
  }

  // automata: gather, contacts and loads, integrate, for automata [a0, a0 + W).
  static MCA_LANE void automata(const LatticeView& v, std::size_t a0, AutomataResult& r) {
    Gathered g = weight(v, a0);
    const float half_r0 = 0.5f * v.r0;
    // The links below (-z, -y, -x: this automaton is their upper end), then its own (+x, +y, +z).
    for (int axis = 2; axis >= 0; --axis) {
      const std::size_t off = static_cast<std::size_t>(axis) * v.n;
      const std::size_t so = static_cast<std::size_t>(axis) * v.ns;  // in the scratch arrays
      const Far fb = far_ends(v, 3 + axis, a0);
      const auto live = bytes_at(v.intact + off, fb) * fb.has != 0.0f;
      if (!L::any(live)) continue;
      const float* res = out_of(v, static_cast<std::size_t>(axis));
      const X half = v.rest && v.last ? 0.5f * to_float(at(v.rest + off, fb)) : X(half_r0);
      take(v, g, live, true, far3(res, kOutRows, kOutFx, fb), far3(res, kOutRows, kOutTx, fb),
           row_far(res, kOutRows, kOutTrace, fb), half, [&] { return soa_far3(v.nx + so, v.ny + so, v.nz + so, fb); });
    }
    for (int axis = 0; axis < 3; ++axis) {
      const std::size_t l0 = static_cast<std::size_t>(axis) * v.n + a0, s0 = static_cast<std::size_t>(axis) * v.ns + a0;
      const auto live = L::load_bytes(v.intact + l0) != 0.0f;
      if (!L::any(live)) continue;
      const float* res = out_of(v, static_cast<std::size_t>(axis));
      const X half = v.rest && v.last ? 0.5f * to_float(L::load(v.rest + l0)) : X(half_r0);
      take(v, g, live, false, own3(res, kOutRows, kOutFx, a0), own3(res, kOutRows, kOutTx, a0),
           own(res, kOutRows, kOutTrace, a0), half, [&] { return load3(v.nx, v.ny, v.nz, s0); });
    }
    move(v, a0, g, StateNext::in_place(v), r);
  }

  // The rest of the automata kernel, once the links are gathered: contacts and loads, the averaged and mean
  // stress, integration, grips, the checks and marks; the new state goes to o.
  static MCA_LANE void move(const LatticeView& v, std::size_t a0, Gathered& g, const StateNext& o, AutomataResult& r) {
    Vec3T<X>& f = g.f;
    Vec3T<X>& t = g.t;
    const Sym3T<X>& s_links = g.s_links;
    const X& trace = g.trace;
    Sym3T<X> s;  // contacts, ground, projectiles: every step
    const auto ext = L::load_bytes(v.has_ext + a0) != 0.0f;
    if (L::any(ext)) {
      f = select(ext, f + lanes_of(v.ext_f, a0), f);
      t = select(ext, t + lanes_of(v.ext_t, a0), t);
      const Sym3T<X> es{L::from([&](std::size_t k) { return v.ext_s[a0 + k].xx; }),
                        L::from([&](std::size_t k) { return v.ext_s[a0 + k].yy; }),
                        L::from([&](std::size_t k) { return v.ext_s[a0 + k].zz; }),
                        L::from([&](std::size_t k) { return v.ext_s[a0 + k].xy; }),
                        L::from([&](std::size_t k) { return v.ext_s[a0 + k].yz; }),
                        L::from([&](std::size_t k) { return v.ext_s[a0 + k].zx; })};
      add_if(ext, s, es);
      for (std::size_t k = 0; k < W; ++k)
        if (v.has_ext[a0 + k]) {
          v.ext_f[a0 + k] = Vec3{};
          v.ext_t[a0 + k] = Vec3{};
          v.ext_s[a0 + k] = Sym3{};
          v.has_ext[a0 + k] = 0;
        }
    }
    if (v.load) f += lanes_of(v.load, a0);
    const X inv_v = v.uniform_bodies ? X(v.body[3]) : L::load(v.inv_volume + a0);
    if (v.last) {
      Sym3T<X> total = s_links;
      total += s;
      total.xx *= inv_v; total.yy *= inv_v; total.zz *= inv_v;
      total.xy *= inv_v; total.yz *= inv_v; total.zx *= inv_v;
      for (std::size_t k = 0; k < W; ++k)
        v.stress[a0 + k] = {L::lane(total.xx, k), L::lane(total.yy, k), L::lane(total.zz, k),
                            L::lane(total.xy, k), L::lane(total.yz, k), L::lane(total.zx, k)};
    }
    // From the traces on every step, so the dynamics do not depend on how steps are grouped into calls.
    // (A random-lattice automaton's ext_s holds its links' part only on a call's last step, the
    // explicit gather's: its mean stress, read by no criterion, is whole only then.)
    L::store((trace + s.xx + s.yy + s.zz) * inv_v * (1.0f / 3.0f), o.mean_stress + a0);
    BodyT<X, D> body{{L::load(v.px + a0), L::load(v.py + a0), L::load(v.pz + a0)},
                     load3(v.vx, v.vy, v.vz, a0),
                     load3(v.wx, v.wy, v.wz, a0),
                     {L::load(v.qw + a0), L::load(v.qx + a0), L::load(v.qy + a0), L::load(v.qz + a0)}};
    const BodyT<X, D> start = body;
    const Vec3T<X> f_raw = f, t_raw = t;
    integrate_body(body, f, t, v.uniform_bodies ? X(v.body[1]) : L::load(v.inv_mass + a0),
                   v.uniform_bodies ? X(v.body[2]) : L::load(v.inv_inertia + a0), v.dt, v.local_damping);
    // Held automata (grip >= 0) move with their grip and do not turn; ext_f keeps the force the body puts
    // on the grip (the caller sums it per grip).
    const X grip = v.grip ? L::from([&](std::size_t k) { return static_cast<float>(v.grip[a0 + k]); }) : X(-1.0f);
    const auto held = grip >= 0.0f;
    if (v.grip && L::any(held)) {
      // The grips' velocities, lane by lane through memory (0 for the lanes not held).
      alignas(64) double gvx[W], gvy[W], gvz[W];
      for (std::size_t k = 0; k < W; ++k) {
        const int g = v.grip[a0 + k];
        const DVec3 gv = g >= 0 ? v.grip_velocity[g] : DVec3{};
        gvx[k] = gv.x;
        gvy[k] = gv.y;
        gvz[k] = gv.z;
      }
      const Vec3T<D> gv = load3(gvx, gvy, gvz, 0);
      Vec3T<D> x = start.x;
      x += gv * static_cast<double>(v.dt);
      body.x = select(held, x, body.x);
      body.v = select(held, gv, body.v);
      body.w = select(held, Vec3T<D>{}, body.w);
      body.q = {select(held, start.q.w, body.q.w), select(held, start.q.x, body.q.x), select(held, start.q.y, body.q.y),
                select(held, start.q.z, body.q.z)};
      f = select(held, f_raw, f);
      t = select(held, t_raw, t);
      for (std::size_t k = 0; k < W; ++k)
        if (v.grip[a0 + k] >= 0) v.ext_f[a0 + k] = {L::lane(f.x, k), L::lane(f.y, k), L::lane(f.z, k)};
    }
    if (v.last)
      for (std::size_t k = 0; k < W; ++k) {
        v.f_out[a0 + k] = {L::lane(f.x, k), L::lane(f.y, k), L::lane(f.z, k)};
        v.t_out[a0 + k] = {L::lane(t.x, k), L::lane(t.y, k), L::lane(t.z, k)};
      }
    L::store(body.x.x, o.px + a0);
    L::store(body.x.y, o.py + a0);
    L::store(body.x.z, o.pz + a0);
    store3(body.v, o.vx, o.vy, o.vz, a0);
    store3(body.w, o.wx, o.wy, o.wz, a0);
    L::store(body.q.w, v.qw + a0);
    L::store(body.q.x, v.qx + a0);
    L::store(body.q.y, v.qy + a0);
    L::store(body.q.z, v.qz + a0);
    // x - x is 0 for a finite x and NaN for inf or NaN; inf or NaN in any component spreads to the sums.
    // The orientation too: its renormalisation turns a finite spin of more than about 3 rad a step into
    // NaN, which the spin itself does not show.
    const D place = body.x.x + body.x.y + body.x.z;
    const D motion = body.v.x + body.v.y + body.v.z + body.w.x + body.w.y + body.w.z;
    const X turn = body.q.w + body.q.x + body.q.y + body.q.z;
    if (r.first_bad < 0 &&
        !(L::all(place - place == 0.0) && L::all(motion - motion == 0.0) && L::all(turn - turn == 0.0f)))
      for (std::size_t k = 0; k < W && r.first_bad < 0; ++k)
        if (!(std::isfinite(L::lane(body.x.x, k) + L::lane(body.x.y, k) + L::lane(body.x.z, k)) &&
              std::isfinite(L::lane(motion, k)) && std::isfinite(L::lane(turn, k))))
          r.first_bad = static_cast<std::int64_t>(a0 + k);
    // Only exposed automata are in the contact lists (see rebuild_contacts), so only their motion can make
    // them stale.
    if (v.projectiles > 0) {
      // Which projectiles the automata end near: bit p % kNearBits of near[a] (a superset of the contacts
      // the next projectile pass finds, which tests again with each automaton's own radius).
      X bits = 0.0f;
      for (std::size_t k = 0; k < static_cast<std::size_t>(kNearBits) && k < v.projectiles; ++k) {
        X hit = 0.0f;
        for (std::size_t p = k; p < v.projectiles; p += kNearBits) {
          const Vec3T<X> d{to_float(body.x.x - v.proj_x[p]), to_float(body.x.y - v.proj_y[p]),
                           to_float(body.x.z - v.proj_z[p])};
          hit = select(dot(d, d) < v.proj_reach2[p], X(1.0f), hit);
        }
        bits = select(hit != 0.0f, bits + static_cast<float>(1u << k), bits);
      }
      L::store_bytes(bits, v.near + a0);
      r.near = r.near || L::any(bits != 0.0f);
    }
    const auto open = L::load_bytes(v.intact_count + a0) < 6.0f;
    if (L::any(open)) {
      const Vec3T<D> ref = own3(v.ref, kRefRows, 0, a0);
      const Vec3T<X> dm{to_float(body.x.x - ref.x), to_float(body.x.y - ref.y), to_float(body.x.z - ref.z)};
      const float m2 = L::hmax(select(open, dot(dm, dm), X(0.0f)));
      if (m2 > r.max_move2) r.max_move2 = m2;
    }
  }
};

// The kernels over ranges: blocks of W, then one at a time.
// Each range works on its own copy of the view: stores through the byte arrays (flags) could otherwise
// change the caller's view as far as the compiler knows, and every pointer would be reloaded after them.
inline void many_body_range(const LatticeView& view, std::size_t b, std::size_t e) {
  const LatticeView v = view;
  constexpr std::size_t W = Block<V>::W;
  std::size_t a = b;
  for (; a + W <= e; a += W) Block<V>::many_body(v, a);
  for (; a < e; ++a) Block<float>::many_body(v, a);
}

inline std::size_t links_range(const LatticeView& view, int axis, std::size_t b, std::size_t e, std::uint32_t* breaks) {
  const LatticeView v = view;
  constexpr std::size_t W = Block<V>::W;
  std::size_t a = b, count = 0;
  for (; a + W <= e; a += W) count += Block<V>::links(v, axis, a, breaks + count);
  for (; a < e; ++a) count += Block<float>::links(v, axis, a, breaks + count);
  return count;
}

inline AutomataResult automata_range(const LatticeView& view, std::size_t b, std::size_t e) {
  const LatticeView v = view;
  constexpr std::size_t W = Block<V>::W;
  AutomataResult r;
  std::size_t a = b;
  for (; a + W <= e; a += W) Block<V>::automata(v, a, r);
  for (; a < e; ++a) Block<float>::automata(v, a, r);
  return r;
}

inline void explicit_geometry_range(const LatticeView& view, const ExplicitView& ev, std::size_t b, std::size_t e) {
  const LatticeView v = view;
  const ExplicitView x = ev;
  constexpr std::size_t W = Block<V>::W;
  std::size_t k = b;
  for (; k + W <= e; k += W) Block<V>::explicit_geometry(v, x, k);
  for (; k < e; ++k) Block<float>::explicit_geometry(v, x, k);
}

inline std::size_t explicit_links_range(const LatticeView& view, const ExplicitView& ev, std::size_t b, std::size_t e,
                                        std::uint32_t* breaks) {
  const LatticeView v = view;
  const ExplicitView x = ev;
  constexpr std::size_t W = Block<V>::W;
  std::size_t k = b, count = 0;
  for (; k + W <= e; k += W) count += Block<V>::explicit_links(v, x, k, breaks + count);
  for (; k < e; ++k) count += Block<float>::explicit_links(v, x, k, breaks + count);
  return count;
}

constexpr Kernels make_kernels(const char* name) {
  return Kernels{name,           static_cast<int>(Block<V>::W), &many_body_range,     &links_range,
                 &automata_range, &explicit_geometry_range,     &explicit_links_range};
}
