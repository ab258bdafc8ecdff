#pragma once
#define MCA_CORE_MATH_HPP
// Small vector, quaternion and symmetric-tensor types used by every backend. Functions are MCA_HD so
// the CUDA backend can call the same code (paper sec. 5.3); arithmetic is float32 on all backends, but
// for positions, velocities and angular velocities and their differences (double).
//
// The formulas are written once for a number type T: float (the CPU's scalar code and a GPU thread) or a
// SIMD vector of floats, one lane per link or automaton (src/backend/cpu/lanes.hpp adds the vector forms
// of select, to_float and the like, and must come before this header where they are used). Each lane does
// the same IEEE operations in the same order as the scalar code, so every backend computes the same bits.
// Branches on values are written as select(mask, a, b), which computes both sides.
#include <cmath>
#include <cstdint>
#include <type_traits>

#if defined(__CUDACC__)
#define MCA_HD __host__ __device__ __forceinline__
#else
// Always inlined: the SIMD kernels are compiled once per instruction set, and an out-of-line copy of a
// helper made for one could be picked by the linker for another (tests/check_kernel_symbols.sh).
#define MCA_HD inline __attribute__((always_inline))
#endif
// A function of both backends called, not inlined: a rare path whose code, inlined, slowed the common one.
// Never one a SIMD kernel file calls (tests/check_kernel_symbols.sh).
#if defined(__CUDACC__)
#define MCA_HD_CALLED __host__ __device__ __noinline__
#else
#define MCA_HD_CALLED inline __attribute__((noinline))
#endif

namespace mca {

// The largest finite float (std::numeric_limits<float>::max(), spelled out for device code): x <= kFloatMax
// is false for inf and NaN.
inline constexpr float kFloatMax = 3.4028235e38f;

// The cell of coordinate v in a grid of cells 1 / inv wide (the contact search's, on every backend), clamped
// to +-2^52 cells, far beyond any position a run reaches (a damaged checkpoint or the step that found a
// non-finite position may hold one; NaN goes to the lowest), so that the conversion and the neighbour
// offsets cannot overflow (a conversion out of range is undefined, and a GPU and a CPU give different
// integers for it). Far points share the edge cells, which costs only time: callers test the distance of
// every candidate.
MCA_HD std::int64_t grid_cell(double v, double inv) {
  constexpr double kLimit = 4503599627370496.0;  // 2^52
  const double c = std::floor(v * inv);
  if (!(c >= -kLimit)) return static_cast<std::int64_t>(-kLimit);  // NaN too
  return static_cast<std::int64_t>(kLimit < c ? kLimit : c);
}

// Where coordinate v lies in its cell of a grid of cells 1 / inv wide (grid_cell), from 0 to 1; and how
// many cells lie between it, at f, and the cell o cells from its own: 0 for its own, else the gap to that
// cell's nearer side. The contact search skips the cells farther than it reaches (face_search_reach).
MCA_HD double grid_fraction(double v, double inv) { return v * inv - std::floor(v * inv); }
MCA_HD double grid_cell_gap(double f, int o) { return o > 0 ? o - f : o < 0 ? f - (o + 1) : 0.0; }
// Calls f(dx, dy, dz) for each cell of the (2 cells + 1)^3 around a point's own, at fractions fx, fy, fz of
// it (grid_fraction), that lies nearer to the point than reach cells, z slowest.
template <class F>
MCA_HD void for_each_cell_within(double fx, double fy, double fz, int cells, double reach, F&& f) {
  const double r2 = reach * reach;
  for (int dz = -cells; dz <= cells; ++dz) {
    const double gz = grid_cell_gap(fz, dz), gz2 = gz * gz;
    if (gz2 > r2) continue;
    for (int dy = -cells; dy <= cells; ++dy) {
      const double gy = grid_cell_gap(fy, dy), gzy2 = gz2 + gy * gy;
      if (gzy2 > r2) continue;
      for (int dx = -cells; dx <= cells; ++dx) {
        const double gx = grid_cell_gap(fx, dx);
        if (gzy2 + gx * gx <= r2) f(dx, dy, dz);
      }
    }
  }
}

// Scalar forms of the lane helpers.
MCA_HD float select(bool m, float a, float b) { return m ? a : b; }
MCA_HD double select(bool m, double a, double b) { return m ? a : b; }
MCA_HD float to_float(double a) { return static_cast<float>(a); }
MCA_HD double to_double(float a) { return a; }

template <class T>
struct Vec3T {
  T x{}, y{}, z{};
};
using Vec3 = Vec3T<float>;
// Positions are double: a float32 position 0.5 m from the origin resolves 3e-8 m, which is a strain of
// 3e-6 on a 1 cm link (3 % of a concrete's breaking strain) and swallows the per-step motion of a slow
// pull (measured: a grip at 2 mm/s with dt = 5e-7 s did not move at all). Differences of positions are
// taken in double and then rounded, so everything else stays float32.
using DVec3 = Vec3T<double>;

// A factor of a vector: of its own number type (a float times a float vector, a lane vector times a lane
// vector), deduced from the vector alone so that a plain float converts to lanes.
template <class T>
using Scalar = std::type_identity_t<T>;

template <class T>
MCA_HD Vec3T<T> operator+(const Vec3T<T>& a, const Vec3T<T>& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
template <class T>
MCA_HD Vec3T<T> operator-(const Vec3T<T>& a, const Vec3T<T>& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
template <class T>
MCA_HD Vec3T<T> operator-(const Vec3T<T>& a) { return {-a.x, -a.y, -a.z}; }
template <class T>
MCA_HD Vec3T<T> operator*(const Scalar<T>& s, const Vec3T<T>& a) { return {s * a.x, s * a.y, s * a.z}; }
template <class T>
MCA_HD Vec3T<T> operator*(const Vec3T<T>& a, const Scalar<T>& s) { return {s * a.x, s * a.y, s * a.z}; }
template <class T>
MCA_HD Vec3T<T>& operator+=(Vec3T<T>& a, const Vec3T<T>& b) {
  a.x += b.x; a.y += b.y; a.z += b.z;
  return a;
}
template <class T>
MCA_HD Vec3T<T>& operator-=(Vec3T<T>& a, const Vec3T<T>& b) {
  a.x -= b.x; a.y -= b.y; a.z -= b.z;
  return a;
}
template <class T>
MCA_HD T dot(const Vec3T<T>& a, const Vec3T<T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T>
MCA_HD Vec3T<T> cross(const Vec3T<T>& a, const Vec3T<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
MCA_HD float length(Vec3 a) { return std::sqrt(dot(a, a)); }
MCA_HD double length(DVec3 a) { return std::sqrt(dot(a, a)); }
// Per component: m ? a : b.
template <class M, class T>
MCA_HD Vec3T<T> select(const M& m, const Vec3T<T>& a, const Vec3T<T>& b) {
  return {select(m, a.x, b.x), select(m, a.y, b.y), select(m, a.z, b.z)};
}

MCA_HD DVec3 to_dvec3(Vec3 a) { return {a.x, a.y, a.z}; }
MCA_HD Vec3 to_vec3(DVec3 a) { return {static_cast<float>(a.x), static_cast<float>(a.y), static_cast<float>(a.z)}; }
// A double vector (or one of double lanes) rounded to float (float lanes), component by component.
template <class D>
MCA_HD auto rounded(const Vec3T<D>& a) {
  using T = decltype(to_float(D{}));
  return Vec3T<T>{to_float(a.x), to_float(a.y), to_float(a.z)};
}
// b - a in double.
template <class D>
MCA_HD Vec3T<D> ddelta(const Vec3T<D>& a, const Vec3T<D>& b) { return {b.x - a.x, b.y - a.y, b.z - a.z}; }
// b - a, formed in double and rounded to float.
template <class D>
MCA_HD auto delta(const Vec3T<D>& a, const Vec3T<D>& b) { return rounded(ddelta(a, b)); }
// A double position moved by a float displacement (each component converted, then added).
template <class D, class T>
MCA_HD Vec3T<D>& operator+=(Vec3T<D>& a, const Vec3T<T>& b) requires(!std::is_same_v<D, T>) {
  a.x += to_double(b.x); a.y += to_double(b.y); a.z += to_double(b.z);
  return a;
}

// Unit quaternion (w, x, y, z) for the orientation of an automaton.
template <class T>
struct QuatT {
  T w{1.0f}, x{}, y{}, z{};
};
using Quat = QuatT<float>;

// v turned by the unit quaternion q: t = 2 (u x v), v' = v + w t + u x t. In double for the posed
// surfaces and fragment meshes, in float (or lanes) for the step.
template <class T>
MCA_HD Vec3T<T> rotated(const QuatT<T>& q, const Vec3T<T>& v) {
  const Vec3T<T> u{q.x, q.y, q.z};
  const Vec3T<T> t = cross(u, v) * T(2);
  return v + q.w * t + cross(u, t);
}
inline DVec3 rotated(const QuatT<double>& q, const DVec3& v) { return rotated<double>(q, v); }

// q <- normalize(q + dt/2 * (0, omega) * q)   (physics.md sec. 7)
template <class T>
MCA_HD QuatT<T> integrate_orientation(const QuatT<T>& q, const Vec3T<T>& om, float dt) {
  const float h = 0.5f * dt;
  QuatT<T> r{q.w - h * (om.x * q.x + om.y * q.y + om.z * q.z),
             q.x + h * (om.x * q.w + om.y * q.z - om.z * q.y),
             q.y + h * (om.y * q.w + om.z * q.x - om.x * q.z),
             q.z + h * (om.z * q.w + om.x * q.y - om.y * q.x)};
  // |r|^2 = 1 + O(dt^2 omega^2): one Newton step for 1/sqrt, (3 - |r|^2) / 2, renormalises to float
  // precision without a square root or a division.
  const T inv = 0.5f * (3.0f - (r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z));
  return {r.w * inv, r.x * inv, r.y * inv, r.z * inv};
}

// A projectile's orientation. Its spin comes from its contacts at the objects' time step, not its own: a ball
// of 1 mm rolling at 2.7 m/s beside a soft box turned 3.6 rad a step, where the step above keeps a unit
// length up to about 0.5 rad (0.9987 there), loses it past 1.7 rad and gives NaN past 3. The turn is made in
// 2^k equal parts of at most 0.5 rad (up to 64 parts: 32 rad a step), each renormalised; a turn of up to
// 0.5 rad is the one step above, bit for bit. A faster turn (its length shrank: 0.94 at 100 rad a step)
// stops the run (the projectile passes).
constexpr float kLargestProjectileTurn = 32.0f;  // rad a step
MCA_HD float projectile_turn(const Vec3& om, float dt) { return length(om) * dt; }
MCA_HD Quat integrate_projectile_orientation(const Quat& q, const Vec3& om, float dt) {
  const float turn = projectile_turn(om, dt);
  int parts = 1;
  while (parts < 64 && turn > 0.5f * static_cast<float>(parts)) parts *= 2;
  const float h = dt / static_cast<float>(parts);  // (exact: a power of two)
  Quat r = q;
  for (int k = 0; k < parts; ++k) r = integrate_orientation(r, om, h);
  return r;
}

// Symmetric 3x3 tensor: xx, yy, zz, xy, yz, zx (VTK's order for symmetric tensors).
template <class T>
struct Sym3T {
  T xx{}, yy{}, zz{}, xy{}, yz{}, zx{};
};
using Sym3 = Sym3T<float>;

template <class T>
MCA_HD Sym3T<T>& operator+=(Sym3T<T>& a, const Sym3T<T>& b) {
  a.xx += b.xx; a.yy += b.yy; a.zz += b.zz; a.xy += b.xy; a.yz += b.yz; a.zx += b.zx;
  return a;
}
// s * sym(a (x) b)
template <class T>
MCA_HD Sym3T<T> sym_outer(const Vec3T<T>& a, const Vec3T<T>& b, const Scalar<T>& s) {
  return {s * a.x * b.x, s * a.y * b.y, s * a.z * b.z, 0.5f * s * (a.x * b.y + a.y * b.x),
          0.5f * s * (a.y * b.z + a.z * b.y), 0.5f * s * (a.z * b.x + a.x * b.z)};
}
MCA_HD float mean_stress(const Sym3& s) { return (s.xx + s.yy + s.zz) * (1.0f / 3.0f); }
// von Mises equivalent stress of the automaton's averaged stress tensor.
MCA_HD float von_mises(const Sym3& s) {
  const float a = s.xx - s.yy, b = s.yy - s.zz, c = s.zz - s.xx;
  return std::sqrt(0.5f * (a * a + b * b + c * c) + 3.0f * (s.xy * s.xy + s.yz * s.yz + s.zx * s.zx));
}

}  // namespace mca
