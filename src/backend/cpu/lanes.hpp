#pragma once
// Lanes: what the lattice kernels (lattice_kernels.inl) need of their number type V, for V = a SIMD vector
// of floats (std::experimental::simd, as wide as the instruction set the file is compiled for: 4 lanes for
// SSE2, 8 for AVX2, 16 for AVX-512); V = float (one automaton or link at a time, and a CUDA thread) is in
// lanes_scalar.hpp, which needs no <experimental/simd> (nvcc cannot parse it).
//
// The vector forms of select, to_float and to_double are found by the formulas of core/math.hpp and
// physics/ only when declared before them (their arguments live in std::experimental, so argument-
// dependent lookup does not see namespace mca): include this header first.
#ifdef MCA_CORE_MATH_HPP
#error "include backend/cpu/lanes.hpp before core/math.hpp"
#endif
#include <cstddef>
#include <cstdint>
#include <experimental/simd>
#include <type_traits>

#include "backend/cpu/lanes_scalar.hpp"

namespace mca {

namespace stdx = std::experimental;

template <class T, class A>
MCA_LANE stdx::simd<T, A> select(const stdx::simd_mask<T, A>& m, const stdx::simd<T, A>& a, stdx::simd<T, A> b) {
  stdx::where(m, b) = a;
  return b;
}

// A mask of float lanes applied to doubles (or the other way): the same lanes, one by one through memory
// (simd's generator constructor may be compiled out of line, see Lanes::from).
template <class T, class U, class A, class B>
MCA_LANE stdx::simd<T, A> select(const stdx::simd_mask<U, B>& m, const stdx::simd<T, A>& a, const stdx::simd<T, A>& b)
  requires(!std::is_same_v<T, U>)
{
  alignas(64) T t[stdx::simd<T, A>::size()];
  for (std::size_t k = 0; k < stdx::simd<T, A>::size(); ++k) t[k] = m[k] ? a[k] : b[k];
  return stdx::simd<T, A>(t, stdx::vector_aligned);
}

template <class A>
MCA_LANE auto to_float(const stdx::simd<double, A>& d) {
  return stdx::static_simd_cast<stdx::rebind_simd_t<float, stdx::simd<double, A>>>(d);
}

template <class A>
MCA_LANE auto to_double(const stdx::simd<float, A>& f) {
  return stdx::static_simd_cast<stdx::rebind_simd_t<double, stdx::simd<float, A>>>(f);
}

template <class A>
struct Lanes<stdx::simd<float, A>> {
  using V = stdx::simd<float, A>;
  using D = stdx::rebind_simd_t<double, V>;
  using U = stdx::rebind_simd_t<std::uint32_t, V>;
  using M = typename V::mask_type;
  static constexpr std::size_t size = V::size();
  static MCA_LANE V load(const float* p) { return V(p, stdx::element_aligned); }
  static MCA_LANE D load(const double* p) { return D(p, stdx::element_aligned); }
  static MCA_LANE U load(const std::uint32_t* p) { return U(p, stdx::element_aligned); }
  static MCA_LANE V load_bytes(const std::uint8_t* p) {
    return stdx::static_simd_cast<V>(stdx::rebind_simd_t<std::uint8_t, V>(p, stdx::element_aligned));
  }
  static MCA_LANE void store(const V& v, float* p) { v.copy_to(p, stdx::element_aligned); }
  static MCA_LANE void store(const D& v, double* p) { v.copy_to(p, stdx::element_aligned); }
  static MCA_LANE void store_bytes(const V& v, std::uint8_t* p) {
    stdx::static_simd_cast<stdx::rebind_simd_t<std::uint8_t, V>>(stdx::static_simd_cast<U>(v)).copy_to(
        p, stdx::element_aligned);
  }
  // Lane by lane through memory, not simd's generator constructor: that one may be compiled out of line,
  // as a function of the same name in every file that uses the type.
  template <class F>
  static MCA_LANE V from(F&& f) {
    alignas(64) float t[size];
    for (std::size_t k = 0; k < size; ++k) t[k] = f(k);
    return V(t, stdx::vector_aligned);
  }
  static MCA_LANE V gather(const float* p, const U& i) {
    return from([&](std::size_t k) { return p[i[k]]; });
  }
  static MCA_LANE D gather(const double* p, const U& i) {
    alignas(64) double t[size];
    for (std::size_t k = 0; k < size; ++k) t[k] = p[i[k]];
    return D(t, stdx::element_aligned);
  }
  static MCA_LANE V gather_bytes(const std::uint8_t* p, const U& i) {
    return from([&](std::size_t k) { return static_cast<float>(p[i[k]]); });
  }
  static MCA_LANE U iota(std::size_t a) {
    alignas(64) static constexpr std::uint32_t lane[16] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15};
    static_assert(size <= 16);
    return U(static_cast<std::uint32_t>(a)) + U(lane, stdx::vector_aligned);
  }
  template <class X>
  static MCA_LANE auto lane(const X& v, std::size_t k) { return v[k]; }
  template <class Mask>
  static MCA_LANE bool any(const Mask& m) { return stdx::any_of(m); }
  template <class Mask>
  static MCA_LANE bool all(const Mask& m) { return stdx::all_of(m); }
  static MCA_LANE float hmax(const V& v) { return stdx::hmax(v); }
  // Whole numbers as the float lanes (the far ends' flags).
  static MCA_LANE V to_lanes(const U& u) { return stdx::static_simd_cast<V>(u); }
  // Lanes from an array of `size` aligned values (floats or doubles).
  template <class T>
  static MCA_LANE auto load_aligned(const T* p) {
    return stdx::rebind_simd_t<T, V>(p, stdx::vector_aligned);
  }
};

}  // namespace mca
