// The lattice kernels for SSE2, 4 lanes: every x86-64 processor.
#define MCA_KERNEL_SET sse2
#define MCA_KERNEL_LANE stdx::native_simd<float>
#include "backend/cpu/kernel_set.inl"
