// The lattice kernels for AVX2, 8 lanes (compiled with -mavx2).
// Everything here is in namespace mca::cpu::avx2 (see lattice_kernels.hpp).
#include "backend/cpu/lanes.hpp"  // first: see lanes.hpp
#include "backend/cpu/lattice_kernels.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

#include <algorithm>
#include <cmath>

namespace mca::cpu::avx2 {
using V = stdx::native_simd<float>;
#include "backend/cpu/lattice_kernels.inl"
constexpr Kernels kKernels = make_kernels("avx2");
}  // namespace mca::cpu::avx2

namespace mca::cpu {
const Kernels& kernels_avx2() { return avx2::kKernels; }
}  // namespace mca::cpu
