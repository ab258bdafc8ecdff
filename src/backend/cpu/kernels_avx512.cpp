// The lattice kernels for AVX-512, 16 lanes (compiled with -mavx512f -mavx512vl -mavx512bw -mavx512dq).
// Everything here is in namespace mca::cpu::avx512 (see lattice_kernels.hpp).
#include "backend/cpu/lanes.hpp"  // first: see lanes.hpp
#include "backend/cpu/lattice_kernels.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

#include <algorithm>
#include <cmath>

// GCC 12's avx512fintrin.h builds its "undefined" vectors as `__m512 __Y = __Y;`, which -Wmaybe-uninitialized
// reports wherever std::experimental::simd inlines one (GCC bug 105593, fixed in GCC 13).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace mca::cpu::avx512 {
using V = stdx::native_simd<float>;
#include "backend/cpu/lattice_kernels.inl"
constexpr Kernels kKernels = make_kernels("avx512");
}  // namespace mca::cpu::avx512

namespace mca::cpu {
const Kernels& kernels_avx512() { return avx512::kKernels; }
}  // namespace mca::cpu
