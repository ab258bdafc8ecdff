#pragma once
// Small vector, quaternion and symmetric-tensor types used by every backend. Functions are MCA_HD so
// the CUDA backend can call the same code (paper sec. 5.3); arithmetic is float32 on all backends.
#include <cmath>

#if defined(__CUDACC__)
#define MCA_HD __host__ __device__ __forceinline__
#else
#define MCA_HD inline
#endif

namespace mca {

struct Vec3 {
  float x = 0, y = 0, z = 0;
};

MCA_HD Vec3 operator+(Vec3 a, Vec3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
MCA_HD Vec3 operator-(Vec3 a, Vec3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
MCA_HD Vec3 operator-(Vec3 a) { return {-a.x, -a.y, -a.z}; }
MCA_HD Vec3 operator*(float s, Vec3 a) { return {s * a.x, s * a.y, s * a.z}; }
MCA_HD Vec3 operator*(Vec3 a, float s) { return {s * a.x, s * a.y, s * a.z}; }
MCA_HD Vec3& operator+=(Vec3& a, Vec3 b) {
  a.x += b.x; a.y += b.y; a.z += b.z;
  return a;
}
MCA_HD Vec3& operator-=(Vec3& a, Vec3 b) {
  a.x -= b.x; a.y -= b.y; a.z -= b.z;
  return a;
}
MCA_HD float dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
MCA_HD Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
MCA_HD float length(Vec3 a) { return std::sqrt(dot(a, a)); }

// Positions are double: a float32 position 0.5 m from the origin resolves 3e-8 m, which is a strain of
// 3e-6 on a 1 cm link (3 % of a concrete's breaking strain) and swallows the per-step motion of a slow
// pull (measured: a grip at 2 mm/s with dt = 5e-7 s did not move at all). Differences of positions are
// taken in double and then rounded, so everything else stays float32.
struct DVec3 {
  double x = 0, y = 0, z = 0;
};
MCA_HD DVec3 to_dvec3(Vec3 a) { return {a.x, a.y, a.z}; }
MCA_HD Vec3 to_vec3(DVec3 a) { return {static_cast<float>(a.x), static_cast<float>(a.y), static_cast<float>(a.z)}; }
// b - a, rounded to float.
MCA_HD Vec3 delta(DVec3 a, DVec3 b) {
  return {static_cast<float>(b.x - a.x), static_cast<float>(b.y - a.y), static_cast<float>(b.z - a.z)};
}
MCA_HD DVec3& operator+=(DVec3& a, Vec3 b) {
  a.x += b.x; a.y += b.y; a.z += b.z;
  return a;
}
MCA_HD double dot(DVec3 a, DVec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
// b - a in double.
MCA_HD DVec3 ddelta(DVec3 a, DVec3 b) { return {b.x - a.x, b.y - a.y, b.z - a.z}; }

// Unit quaternion (w, x, y, z) for the orientation of an automaton.
struct Quat {
  float w = 1, x = 0, y = 0, z = 0;
};

// q <- normalize(q + dt/2 * (0, omega) * q)   (physics.md sec. 7)
MCA_HD Quat integrate_orientation(Quat q, Vec3 om, float dt) {
  const float h = 0.5f * dt;
  Quat r{q.w - h * (om.x * q.x + om.y * q.y + om.z * q.z),
         q.x + h * (om.x * q.w + om.y * q.z - om.z * q.y),
         q.y + h * (om.y * q.w + om.z * q.x - om.x * q.z),
         q.z + h * (om.z * q.w + om.x * q.y - om.y * q.x)};
  // |r|^2 = 1 + O(dt^2 omega^2): one Newton step for 1/sqrt, (3 - |r|^2) / 2, renormalises to float
  // precision without a square root or a division.
  const float inv = 0.5f * (3.0f - (r.w * r.w + r.x * r.x + r.y * r.y + r.z * r.z));
  return {r.w * inv, r.x * inv, r.y * inv, r.z * inv};
}

// Symmetric 3x3 tensor: xx, yy, zz, xy, yz, zx (VTK's order for symmetric tensors).
struct Sym3 {
  float xx = 0, yy = 0, zz = 0, xy = 0, yz = 0, zx = 0;
};

MCA_HD Sym3& operator+=(Sym3& a, const Sym3& b) {
  a.xx += b.xx; a.yy += b.yy; a.zz += b.zz; a.xy += b.xy; a.yz += b.yz; a.zx += b.zx;
  return a;
}
// s * sym(a (x) b)
MCA_HD Sym3 sym_outer(Vec3 a, Vec3 b, float s) {
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
