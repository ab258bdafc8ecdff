#pragma once
// Lanes<float>: what the lattice kernels (lattice_kernels.inl) need of their number type for one automaton
// or link at a time: the CPU's scalar kernels, the ends of the SIMD kernels' ranges, and a CUDA thread
// (src/backend/cuda/). No <experimental/simd> here: nvcc cannot parse it. The SIMD lane types are in
// lanes.hpp, which includes this header.
#include <cstddef>
#include <cstdint>

#if defined(__CUDACC__)
#define MCA_LANE __host__ __device__ __forceinline__
#else
#define MCA_LANE inline __attribute__((always_inline))
#endif

namespace mca {

MCA_LANE std::uint32_t select(bool m, std::uint32_t a, std::uint32_t b) { return m ? a : b; }

// The lane types that go with V.
template <class V>
struct Lanes;

template <>
struct Lanes<float> {
  using D = double;         // positions
  using U = std::uint32_t;  // indices
  using M = bool;
  static constexpr std::size_t size = 1;
  static MCA_LANE float load(const float* p) { return *p; }
  static MCA_LANE double load(const double* p) { return *p; }
  static MCA_LANE std::uint32_t load(const std::uint32_t* p) { return *p; }
  // Bytes as floats (0 or 1 for flags, counts).
  static MCA_LANE float load_bytes(const std::uint8_t* p) { return static_cast<float>(*p); }
  static MCA_LANE void store(float v, float* p) { *p = v; }
  static MCA_LANE void store(double v, double* p) { *p = v; }
  // Whole numbers 0..255 as bytes.
  static MCA_LANE void store_bytes(float v, std::uint8_t* p) { *p = static_cast<std::uint8_t>(v); }
  static MCA_LANE float gather(const float* p, std::uint32_t i) { return p[i]; }
  static MCA_LANE double gather(const double* p, std::uint32_t i) { return p[i]; }
  static MCA_LANE float gather_bytes(const std::uint8_t* p, std::uint32_t i) { return static_cast<float>(p[i]); }
  // The lanes' own indices a, a + 1, ...
  static MCA_LANE std::uint32_t iota(std::size_t a) { return static_cast<std::uint32_t>(a); }
  template <class F>
  static MCA_LANE float from(F&& f) { return f(0); }
  template <class X>
  static MCA_LANE X lane(const X& v, std::size_t) { return v; }
  static MCA_LANE bool any(bool m) { return m; }
  static MCA_LANE bool all(bool m) { return m; }
  static MCA_LANE bool lane(bool m, std::size_t) { return m; }
  static MCA_LANE float hmax(float v) { return v; }
  static MCA_LANE float to_lanes(std::uint32_t u) { return static_cast<float>(u); }
  template <class T>
  static MCA_LANE T load_aligned(const T* p) { return *p; }
};

}  // namespace mca
