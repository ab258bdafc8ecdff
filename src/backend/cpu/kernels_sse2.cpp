// The lattice kernels for SSE2, 4 lanes: every x86-64 processor.
// Everything here is in namespace mca::cpu::sse2 (see lattice_kernels.hpp).
#include "backend/cpu/lanes.hpp"  // first: see lanes.hpp
#include "backend/cpu/lattice_kernels.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

#include <algorithm>
#include <cmath>

namespace mca::cpu::sse2 {
using V = stdx::native_simd<float>;
#include "backend/cpu/lattice_kernels.inl"
constexpr Kernels kKernels = make_kernels("sse2");
}  // namespace mca::cpu::sse2

namespace mca::cpu {
const Kernels& kernels_sse2() { return sse2::kKernels; }
}  // namespace mca::cpu
