// One build of the lattice kernels: included by kernels_<set>.cpp after it defines MCA_KERNEL_SET (the
// set's name: scalar, sse2, avx2, avx512) and MCA_KERNEL_LANE (float for one lane at a time, else
// stdx::native_simd<float>, as wide as the file's target flags make it). Everything it defines is in
// namespace mca::cpu::MCA_KERNEL_SET, but the table function mca::cpu::kernels_<set>() (see
// lattice_kernels.hpp and tests/check_kernel_symbols.sh).
#include "backend/cpu/lanes.hpp"  // first: see lanes.hpp
#include "backend/cpu/lattice_kernels.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

#include <algorithm>
#include <cmath>

#define MCA_KERNEL_STRING2(x) #x
#define MCA_KERNEL_STRING(x) MCA_KERNEL_STRING2(x)
#define MCA_KERNEL_TABLE2(x) kernels_##x
#define MCA_KERNEL_TABLE(x) MCA_KERNEL_TABLE2(x)

namespace mca::cpu::MCA_KERNEL_SET {
using V = MCA_KERNEL_LANE;
#include "backend/cpu/lattice_kernels.inl"
constexpr Kernels kKernels = make_kernels(MCA_KERNEL_STRING(MCA_KERNEL_SET));
}  // namespace mca::cpu::MCA_KERNEL_SET

namespace mca::cpu {
const Kernels& MCA_KERNEL_TABLE(MCA_KERNEL_SET)() { return MCA_KERNEL_SET::kKernels; }
}  // namespace mca::cpu
