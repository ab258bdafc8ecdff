// simd_compare: the project's link law (link_geometry -> link_force -> link_break_test) per link, with
// the lane type taken from std::experimental::simd (what the project uses), xsimd or Google Highway, on
// AVX2 and AVX-512, timed against the scalar (float/double) run and checked bit for bit against it.
//
// This one file is compiled once per variant (build.sh): -DSC_VARIANT=<n> picks the lane library and
// -DSC_NAME the namespace and symbol suffix; the instruction set comes from the -m flags, as the
// project's kernels_<set>.cpp files get theirs. -DSC_MAIN builds the driver (baseline x86-64 flags).
//
// Every variant runs the SAME kernel text (links_block below, modelled on Block::links of
// src/backend/cpu/lattice_kernels.inl for the common case: one material group, no strengthening, far
// ends as a contiguous run) and the SAME physics headers of the project (src/physics/link_law.hpp,
// src/physics/fracture.hpp, src/core/math.hpp). Only the lane adapter in front of them differs:
//   stdx   : the project's own src/backend/cpu/lanes.hpp, unchanged.
//   xsimd  : xsimd::batch<float> plus a pair of xsimd::batch<double> for the double lanes (xsimd has no
//            batch of 8 doubles on AVX2 or 16 on AVX-512), and to_float / to_double.
//   hwy    : a thin value wrapper around hn::Vec / hn::Mask (Highway's own types have no scalar operands,
//            no construction from a float, no operator! / && / ||), plus the same double pair.
#include <cstddef>
#include <cstdint>
#include <cstring>

namespace sc {

struct Consts {
  float r0, inv_r0;      // lattice spacing
  float G, kt, area;     // pair constants of the one group (PairConstants::G, kt), link area r0^2
  float damp_normal, damp_tangential;
  float dt;
  float stress_coefficient;
};

// Links a = [0, n) join automaton a (first end) to automaton a + stride (second end).
struct Input {
  std::size_t n, stride;
  const double *px, *py, *pz;              // positions of the automata (n + stride)
  const float *vx, *vy, *vz, *wx, *wy, *wz;  // velocities, angular velocities
  const float *tensile, *compressive, *break_strain, *mean_stress, *many_body;
  const float *utx, *uty, *utz;            // tangential displacement of the links (n)
  Consts c;
};

struct Output {
  float *fx, *fy, *fz, *tx, *ty, *tz, *utx, *uty, *utz;
  std::uint8_t* flag;  // 0: intact, 1: broke by displacement, 2: broke by stress
};

}  // namespace sc

#define SC_STR2(x) #x
#define SC_STR(x) SC_STR2(x)
#define SC_CAT2(a, b) a##b
#define SC_CAT(a, b) SC_CAT2(a, b)

#if !defined(SC_MAIN)
// =====================================================================================================
// A kernel variant.
#define SC_SCALAR 0
#define SC_STDX 1
#define SC_XSIMD 2
#define SC_HWY 3

#if SC_VARIANT == SC_SCALAR || SC_VARIANT == SC_STDX
// ---- the project's adapter, as kernel_set.inl includes it.
#include "backend/cpu/lanes.hpp"
namespace SC_NAME {
#if SC_VARIANT == SC_SCALAR
using L = mca::Lanes<float>;
#else
using L = mca::Lanes<mca::stdx::native_simd<float>>;
#endif
inline const char* info() { return SC_VARIANT == SC_SCALAR ? "float/double" : "stdx::native_simd<float>"; }
}  // namespace SC_NAME

#elif SC_VARIANT == SC_XSIMD
// ---- xsimd.
#include <immintrin.h>
#include <xsimd/xsimd.hpp>
#define MCA_LANE inline __attribute__((always_inline))
namespace SC_NAME {
using A = xsimd::default_arch;
using F = xsimd::batch<float, A>;
using DH = xsimd::batch<double, A>;
using FM = xsimd::batch_bool<float, A>;
static_assert(F::size == 2 * DH::size);
// As many double lanes as float lanes: two xsimd batches.
struct D {
  DH lo, hi;
  D() = default;
  D(double s) : lo(s), hi(s) {}
  D(DH l, DH h) : lo(l), hi(h) {}
  friend MCA_LANE D operator+(const D& a, const D& b) { return {a.lo + b.lo, a.hi + b.hi}; }
  friend MCA_LANE D operator-(const D& a, const D& b) { return {a.lo - b.lo, a.hi - b.hi}; }
  friend MCA_LANE D operator*(const D& a, const D& b) { return {a.lo * b.lo, a.hi * b.hi}; }
};
struct L {
  using V = F;
  static constexpr std::size_t size = F::size;
  static MCA_LANE F load(const float* p) { return F::load_unaligned(p); }
  static MCA_LANE D load(const double* p) { return {DH::load_unaligned(p), DH::load_unaligned(p + DH::size)}; }
  static MCA_LANE void store(const F& v, float* p) { v.store_unaligned(p); }
  static MCA_LANE bool any(const FM& m) { return xsimd::any(m); }
  static MCA_LANE bool lane(const FM& m, std::size_t k) {
    alignas(64) bool b[size];
    m.store_unaligned(b);
    return b[k];
  }
};
inline const char* info() { return A::name(); }
}  // namespace SC_NAME
namespace mca {
// select, sqrt, the comparisons and any/all are xsimd's own (found by argument-dependent lookup).
MCA_LANE SC_NAME::F to_float(const SC_NAME::D& d) {
#if defined(__AVX512F__)
  return _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(d.lo)), _mm512_cvtpd_ps(d.hi), 1);
#else
  return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(d.lo)), _mm256_cvtpd_ps(d.hi), 1);
#endif
}
MCA_LANE SC_NAME::D to_double(const SC_NAME::F& f) {
#if defined(__AVX512F__)
  return {_mm512_cvtps_pd(_mm512_castps512_ps256(f)), _mm512_cvtps_pd(_mm512_extractf32x8_ps(f, 1))};
#else
  return {_mm256_cvtps_pd(_mm256_castps256_ps128(f)), _mm256_cvtps_pd(_mm256_extractf128_ps(f, 1))};
#endif
}
}  // namespace mca

#elif SC_VARIANT == SC_HWY
// ---- Google Highway, static target (the one the -m flags and HWY_DISABLE_* of build.sh select).
#include <hwy/highway.h>
#define MCA_LANE inline __attribute__((always_inline))
namespace SC_NAME {
namespace hn = hwy::HWY_NAMESPACE;
using DF = hn::ScalableTag<float>;
using DFh = hn::Half<DF>;
using DDh = hn::Repartition<double, DF>;  // half as many doubles as floats
static_assert(hn::MaxLanes(DF()) == 2 * hn::MaxLanes(DDh()));
struct M;
struct F {
  hn::Vec<DF> v;
  F() = default;
  F(float s) : v(hn::Set(DF(), s)) {}
  explicit F(hn::Vec<DF> x) : v(x) {}
  friend MCA_LANE F operator+(const F& a, const F& b) { return F(a.v + b.v); }
  friend MCA_LANE F operator-(const F& a, const F& b) { return F(a.v - b.v); }
  friend MCA_LANE F operator*(const F& a, const F& b) { return F(a.v * b.v); }
  friend MCA_LANE F operator/(const F& a, const F& b) { return F(a.v / b.v); }
  friend MCA_LANE F operator-(const F& a) { return F(hn::Neg(a.v)); }
  friend MCA_LANE F sqrt(const F& a) { return F(hn::Sqrt(a.v)); }
  friend MCA_LANE M operator<(const F& a, const F& b);
  friend MCA_LANE M operator>(const F& a, const F& b);
  friend MCA_LANE M operator<=(const F& a, const F& b);
  friend MCA_LANE M operator>=(const F& a, const F& b);
  friend MCA_LANE M operator==(const F& a, const F& b);
};
struct M {
  hn::Mask<DF> m;
  friend MCA_LANE M operator!(const M& a) { return {hn::Not(a.m)}; }
  friend MCA_LANE M operator&&(const M& a, const M& b) { return {hn::And(a.m, b.m)}; }
  friend MCA_LANE M operator||(const M& a, const M& b) { return {hn::Or(a.m, b.m)}; }
};
MCA_LANE M operator<(const F& a, const F& b) { return {a.v < b.v}; }
MCA_LANE M operator>(const F& a, const F& b) { return {a.v > b.v}; }
MCA_LANE M operator<=(const F& a, const F& b) { return {a.v <= b.v}; }
MCA_LANE M operator>=(const F& a, const F& b) { return {a.v >= b.v}; }
MCA_LANE M operator==(const F& a, const F& b) { return {a.v == b.v}; }
struct D {
  hn::Vec<DDh> lo, hi;
  D() = default;
  D(double s) : lo(hn::Set(DDh(), s)), hi(hn::Set(DDh(), s)) {}
  D(hn::Vec<DDh> l, hn::Vec<DDh> h) : lo(l), hi(h) {}
  friend MCA_LANE D operator+(const D& a, const D& b) { return {a.lo + b.lo, a.hi + b.hi}; }
  friend MCA_LANE D operator-(const D& a, const D& b) { return {a.lo - b.lo, a.hi - b.hi}; }
  friend MCA_LANE D operator*(const D& a, const D& b) { return {a.lo * b.lo, a.hi * b.hi}; }
};
struct L {
  using V = F;
  static constexpr std::size_t size = hn::MaxLanes(DF());
  static MCA_LANE F load(const float* p) { return F(hn::LoadU(DF(), p)); }
  static MCA_LANE D load(const double* p) { return {hn::LoadU(DDh(), p), hn::LoadU(DDh(), p + size / 2)}; }
  static MCA_LANE void store(const F& v, float* p) { hn::StoreU(v.v, DF(), p); }
  static MCA_LANE bool any(const M& m) { return !hn::AllFalse(DF(), m.m); }
  static MCA_LANE bool lane(const M& m, std::size_t k) {
    std::uint8_t bits[8] = {};
    hn::StoreMaskBits(DF(), m.m, bits);
    return (bits[k / 8] >> (k % 8)) & 1u;
  }
};
inline const char* info() { return hwy::TargetName(HWY_TARGET); }
}  // namespace SC_NAME
namespace mca {
MCA_LANE SC_NAME::F select(const SC_NAME::M& m, const SC_NAME::F& a, const SC_NAME::F& b) {
  return SC_NAME::F(SC_NAME::hn::IfThenElse(m.m, a.v, b.v));
}
MCA_LANE SC_NAME::F to_float(const SC_NAME::D& d) {
  namespace hn = SC_NAME::hn;
  const SC_NAME::DFh h;
  return SC_NAME::F(hn::Combine(SC_NAME::DF(), hn::DemoteTo(h, d.hi), hn::DemoteTo(h, d.lo)));
}
MCA_LANE SC_NAME::D to_double(const SC_NAME::F& f) {
  namespace hn = SC_NAME::hn;
  const SC_NAME::DFh h;
  return {hn::PromoteTo(SC_NAME::DDh(), hn::LowerHalf(h, f.v)), hn::PromoteTo(SC_NAME::DDh(), hn::UpperHalf(h, f.v))};
}
}  // namespace mca
#else
#error "SC_VARIANT"
#endif

// ---- the project's formulas, unchanged.
#include "core/math.hpp"
#include "physics/fracture.hpp"
#include "physics/link_law.hpp"

namespace SC_NAME {
using namespace mca;

template <class X>
MCA_HD Vec3T<X> load3(const float* x, const float* y, const float* z, std::size_t a) {
  return {L::load(x + a), L::load(y + a), L::load(z + a)};
}
template <class X>
MCA_HD void store3(const Vec3T<X>& v, float* x, float* y, float* z, std::size_t a) {
  L::store(v.x, x + a);
  L::store(v.y, y + a);
  L::store(v.z, z + a);
}

// Links [a0, a0 + W): the common case of Block::links (lattice_kernels.inl) without strengthening.
MCA_HD void links_block(const sc::Input& in, const sc::Output& out, std::size_t a0) {
  using X = decltype(L::load(static_cast<const float*>(nullptr)));
  using Dl = decltype(L::load(static_cast<const double*>(nullptr)));
  constexpr std::size_t W = L::size;
  const sc::Consts& c = in.c;
  const std::size_t b0 = a0 + in.stride;  // the far ends, a run
  const Vec3T<Dl> xi{L::load(in.px + a0), L::load(in.py + a0), L::load(in.pz + a0)};
  const Vec3T<Dl> xj{L::load(in.px + b0), L::load(in.py + b0), L::load(in.pz + b0)};
  const auto g = link_geometry(xi, xj, c.r0, c.inv_r0);
  const Vec3T<X> n = g.n;
  const X eps = g.eps;
  const X mb_i = L::load(in.many_body + a0), mb_j = L::load(in.many_body + b0);
  const X G = X(c.G);
  const X kt = X(c.kt);
  const X sigma = G * eps * 2.0f + mb_i + mb_j;  // link_normal_stress with f = g = 1
  LinkInputT<X> li;
  li.g = {n, c.r0 * (1.0f + eps), eps};
  li.area = c.area;
  li.sigma = sigma;
  li.kt = kt;
  li.kt_slope = 0.0f;
  li.damp_normal = c.damp_normal;
  li.damp_tangential = c.damp_tangential;
  li.vi = load3<X>(in.vx, in.vy, in.vz, a0);
  li.vj = load3<X>(in.vx, in.vy, in.vz, b0);
  li.wi = load3<X>(in.wx, in.wy, in.wz, a0);
  li.wj = load3<X>(in.wx, in.wy, in.wz, b0);
  li.ut = load3<X>(in.utx, in.uty, in.utz, a0);
  li.dt = c.dt;
  const LinkOutputT<X> o = link_force(li);
  const X ti = L::load(in.tensile + a0), tj = L::load(in.tensile + b0);
  const X ci = L::load(in.compressive + a0), cj = L::load(in.compressive + b0);
  const X si = L::load(in.break_strain + a0), sj = L::load(in.break_strain + b0);
  const X tensile = select(tj < ti, tj, ti), compressive = select(cj < ci, cj, ci);
  const X strain = select(sj < si, sj, si);
  const X p = 0.5f * (L::load(in.mean_stress + a0) + L::load(in.mean_stress + b0));
  const auto b = link_break_test(eps * c.r0, c.r0, o.sigma, o.tau2, p, tensile, tensile / compressive, strain,
                                 c.stress_coefficient);
  const auto broke = b.displacement || b.stress;
  if (L::any(broke)) {
    for (std::size_t k = 0; k < W; ++k)
      out.flag[a0 + k] = L::lane(broke, k) ? (L::lane(b.displacement, k) ? 1 : 2) : 0;
  } else {
    std::memset(out.flag + a0, 0, W);
  }
  const Vec3T<X> hf = o.force_i * (0.5f * c.r0);
  const Vec3T<X> torque = cross(n, hf) * (1.0f + eps);
  store3(o.force_i, out.fx, out.fy, out.fz, a0);
  store3(torque, out.tx, out.ty, out.tz, a0);
  store3(select(!broke, o.ut, li.ut), out.utx, out.uty, out.utz, a0);
}

}  // namespace SC_NAME

namespace sc {
std::size_t SC_CAT(lanes_, SC_NAME)() { return SC_NAME::L::size; }
const char* SC_CAT(info_, SC_NAME)() { return SC_NAME::info(); }
// noinline: one call per pass, the loop inside.
__attribute__((noinline)) void SC_CAT(run_, SC_NAME)(const Input& in, const Output& out) {
  for (std::size_t a0 = 0; a0 < in.n; a0 += SC_NAME::L::size) SC_NAME::links_block(in, out, a0);
}
}  // namespace sc

#else
// =====================================================================================================
// The driver.
#include <algorithm>
#include <chrono>
#include <cinttypes>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#define SC_DECLARE(name)                                       \
  namespace sc {                                               \
  std::size_t lanes_##name();                                  \
  const char* info_##name();                                   \
  void run_##name(const Input& in, const Output& out);        \
  }
SC_DECLARE(scalar)
SC_DECLARE(stdx_avx2)
SC_DECLARE(stdx_avx512)
SC_DECLARE(xsimd_avx2)
SC_DECLARE(xsimd_avx512)
SC_DECLARE(hwy_avx2)
SC_DECLARE(hwy_avx512)

namespace sc {

struct Variant {
  const char* name;
  std::size_t (*lanes)();
  const char* (*info)();
  void (*run)(const Input&, const Output&);
  bool avx512;
};

const Variant kVariants[] = {
    {"scalar", lanes_scalar, info_scalar, run_scalar, false},
    {"stdx AVX2", lanes_stdx_avx2, info_stdx_avx2, run_stdx_avx2, false},
    {"stdx AVX-512", lanes_stdx_avx512, info_stdx_avx512, run_stdx_avx512, true},
    {"xsimd AVX2", lanes_xsimd_avx2, info_xsimd_avx2, run_xsimd_avx2, false},
    {"xsimd AVX-512", lanes_xsimd_avx512, info_xsimd_avx512, run_xsimd_avx512, true},
    {"Highway AVX2", lanes_hwy_avx2, info_hwy_avx2, run_hwy_avx2, false},
    {"Highway AVX-512", lanes_hwy_avx512, info_hwy_avx512, run_hwy_avx512, true},
};
constexpr std::size_t kCount = sizeof(kVariants) / sizeof(kVariants[0]);

// One allocation for many arrays, each starting 64-byte aligned at a different offset within a 4 KiB
// page (a 320-byte step), so that the ~30 streams of a pass do not all share their low 12 address bits
// (4K aliasing of loads against stores, L1 set conflicts), whatever the allocator would have done.
struct Arena {
  std::vector<unsigned char> buf;
  std::size_t used = 0, count = 0;
  explicit Arena(std::size_t bytes) : buf(bytes) {}
  template <class T>
  T* take(std::size_t n) {
    const std::uintptr_t base = reinterpret_cast<std::uintptr_t>(buf.data());
    std::uintptr_t p = (base + used + 4095) / 4096 * 4096 + (count++ % 12) * 320;
    used = p - base + n * sizeof(T);
    if (used > buf.size()) std::abort();
    return reinterpret_cast<T*>(p);
  }
};

// The arrays behind an Input.
struct Data {
  Arena arena;
  double *px, *py, *pz;
  float *vx, *vy, *vz, *wx, *wy, *wz, *tensile, *compressive, *break_strain, *mean_stress, *many_body;
  float *utx, *uty, *utz;
  Input in{};
  explicit Data(std::size_t n, std::size_t stride) : arena((n + stride) * 68 + n * 12 + 40 * 4096) {}
};

// A lattice of automata, nx wide and nx deep, spacing r0, positions perturbed; links along the lattice
// axis whose neighbour is `stride` automata on (stride = nx: y, stride = nx * nx: z).
void make(Data& d, std::size_t n, std::size_t nx, std::size_t stride, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::size_t na = n + stride;
  const double r0 = 0.02;
  for (auto* v : {&d.px, &d.py, &d.pz}) *v = d.arena.take<double>(na);
  for (auto* v : {&d.vx, &d.vy, &d.vz, &d.wx, &d.wy, &d.wz, &d.tensile, &d.compressive, &d.break_strain,
                  &d.mean_stress, &d.many_body})
    *v = d.arena.take<float>(na);
  for (auto* v : {&d.utx, &d.uty, &d.utz}) *v = d.arena.take<float>(n);
  for (std::size_t a = 0; a < na; ++a) {
    // Most automata within 2e-7 m of their lattice site (strains ~1e-5); one in 200 off by up to 1e-5 m
    // (strains up to ~5e-4: past the breaking strain, or a stress past the strength).
    const double amp = rng() % 200 == 0 ? 1e-5 : 2e-7;
    const double ix = static_cast<double>(a % nx), iy = static_cast<double>((a / nx) % nx),
                 iz = static_cast<double>(a / (nx * nx));
    d.px[a] = 0.1 + ix * r0 + amp * u(rng);
    d.py[a] = 0.2 + iy * r0 + amp * u(rng);
    d.pz[a] = 0.3 + iz * r0 + amp * u(rng);
    d.vx[a] = static_cast<float>(0.1 * u(rng));
    d.vy[a] = static_cast<float>(0.1 * u(rng));
    d.vz[a] = static_cast<float>(0.1 * u(rng));
    d.wx[a] = static_cast<float>(5.0 * u(rng));
    d.wy[a] = static_cast<float>(5.0 * u(rng));
    d.wz[a] = static_cast<float>(5.0 * u(rng));
    d.tensile[a] = static_cast<float>(3e6 * (1.0 + 0.1 * u(rng)));
    d.compressive[a] = static_cast<float>(30e6 * (1.0 + 0.1 * u(rng)));
    d.break_strain[a] = static_cast<float>(2e-4 * (1.0 + 0.1 * u(rng)));
    d.mean_stress[a] = static_cast<float>(1e6 * u(rng));
    d.many_body[a] = static_cast<float>(2e5 * u(rng));
  }
  for (std::size_t l = 0; l < n; ++l) {
    d.utx[l] = static_cast<float>(1e-7 * u(rng));
    d.uty[l] = static_cast<float>(1e-7 * u(rng));
    d.utz[l] = static_cast<float>(1e-7 * u(rng));
  }
  // Concrete-like: E = 30 GPa, nu = 0.2 (G = 12.5 GPa, lambda = 8.33 GPa), 2400 kg/m^3.
  Consts c;
  c.r0 = 0.02f;
  c.inv_r0 = 1.0f / c.r0;
  c.G = 12.5e9f;
  c.area = c.r0 * c.r0;
  c.kt = 2.0f * c.G * c.area / c.r0;  // kShearFactor G S / r0
  c.damp_normal = 920.0f;             // tau k + critical share (tau = 1e-6 s, 5 % of critical)
  c.damp_tangential = 253.0f;
  c.dt = 2e-7f;
  c.stress_coefficient = 1.0f;
  d.in = Input{n,       stride,  d.px,        d.py,           d.pz,           d.vx,
               d.vy,    d.vz,    d.wx,        d.wy,           d.wz,           d.tensile,
               d.compressive,    d.break_strain, d.mean_stress, d.many_body, d.utx, d.uty, d.utz, c};
}

struct Result {
  Arena arena;
  std::size_t n;
  float* f[9];
  std::uint8_t* flag;
  Output out{};
  explicit Result(std::size_t n_) : arena(n_ * 37 + 12 * 4096), n(n_) {
    for (auto& v : f) v = arena.take<float>(n);
    flag = arena.take<std::uint8_t>(n);
    out = Output{f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7], f[8], flag};
  }
  void poison() {
    for (auto& v : f) std::memset(v, 0xff, n * sizeof(float));
    std::memset(flag, 0xee, n);
  }
};

// Count of output elements (of 10 n) whose bits differ.
std::size_t mismatches(const Result& a, const Result& b) {
  std::size_t bad = 0;
  for (int k = 0; k < 9; ++k)
    for (std::size_t i = 0; i < a.n; ++i) bad += std::memcmp(&a.f[k][i], &b.f[k][i], sizeof(float)) != 0;
  for (std::size_t i = 0; i < a.n; ++i) bad += a.flag[i] != b.flag[i];
  return bad;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

struct Case {
  const char* name;
  std::size_t n, nx, stride, inner;  // links, lattice width, far-end stride, passes per timed repetition
};

}  // namespace sc

int main(int argc, char** argv) {
  using namespace sc;
  const int reps = argc > 1 ? std::atoi(argv[1]) : 15;
  const bool have512 = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
                       __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
  const bool have2 = __builtin_cpu_supports("avx2");
  std::printf("variants:\n");
  for (const Variant& v : kVariants) std::printf("  %-16s %2zu lanes  %s\n", v.name, v.lanes(), v.info());
  // One axis of a wall-sized lattice: 1,048,576 links along z (far end 128 x 128 automata on), streamed
  // from memory; and a small lattice 16 x 16 x 17 (4096 links along z, ~0.5 MB of data) computed over and
  // over from L2, where the arithmetic rather than the memory sets the pace.
  const Case cases[] = {{"stream 1M links (z axis, stride 16384)", 1u << 20, 128, 128 * 128, 1},
                        {"L2-resident 4096 links (z axis, stride 256) x 256 passes", 4096, 16, 256, 256}};
  bool all_equal = true;
  for (const Case& cs : cases) {
    Data d(cs.n, cs.stride);
    make(d, cs.n, cs.nx, cs.stride, 12345);
    for (const Variant& v : kVariants)
      if (cs.n % v.lanes() != 0) return std::fprintf(stderr, "n not a multiple of the lanes\n"), 1;
    Result ref(cs.n), work(cs.n);
    ref.poison();
    run_scalar(d.in, ref.out);
    std::size_t by_disp = 0, by_stress = 0;
    for (std::size_t i = 0; i < cs.n; ++i) by_disp += ref.flag[i] == 1, by_stress += ref.flag[i] == 2;
    std::printf("\n== %s\n   breaks in the scalar run: %zu by displacement, %zu by stress (of %zu links)\n", cs.name,
                by_disp, by_stress, cs.n);
    bool runnable[kCount];
    for (std::size_t k = 0; k < kCount; ++k) {
      const Variant& v = kVariants[k];
      runnable[k] = v.avx512 ? have512 : (k == 0 || have2);
      if (!runnable[k]) continue;
      work.poison();
      v.run(d.in, work.out);
      const std::size_t bad = mismatches(ref, work);
      if (bad) all_equal = false;
      std::printf("   bitwise check %-16s: %s (%zu of %zu output values differ)\n", v.name, bad ? "MISMATCH" : "identical",
                  bad, 10 * cs.n);
    }
    // Timing: every repetition runs each variant once, the order rotated by one each repetition.
    std::vector<double> t[kCount];
    for (int r = 0; r < reps; ++r)
      for (std::size_t j = 0; j < kCount; ++j) {
        const std::size_t k = (j + static_cast<std::size_t>(r)) % kCount;
        if (!runnable[k]) continue;
        const auto t0 = std::chrono::steady_clock::now();
        for (std::size_t i = 0; i < cs.inner; ++i) kVariants[k].run(d.in, work.out);
        const auto t1 = std::chrono::steady_clock::now();
        t[k].push_back(std::chrono::duration<double, std::nano>(t1 - t0).count() /
                       static_cast<double>(cs.n * cs.inner));
      }
    const double base = median(t[0]);
    std::printf("   %-16s %10s %10s %10s %12s\n", "variant", "median", "min", "max", "vs scalar");
    for (std::size_t k = 0; k < kCount; ++k) {
      if (!runnable[k]) continue;
      const double m = median(t[k]);
      std::printf("   %-16s %7.3f ns %7.3f ns %7.3f ns %11.2fx\n", kVariants[k].name, m,
                  *std::min_element(t[k].begin(), t[k].end()), *std::max_element(t[k].begin(), t[k].end()),
                  base / m);
    }
    std::printf("   (ns per link, %d interleaved repetitions)\n", reps);
  }
  std::printf("\nall outputs bitwise identical to scalar: %s\n", all_equal ? "yes" : "NO");
  return all_equal ? 0 : 2;
}
#endif
