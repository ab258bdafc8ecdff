// The lattice kernels for AVX2, 8 lanes (compiled with -mavx2).
#define MCA_KERNEL_SET avx2
#define MCA_KERNEL_LANE stdx::native_simd<float>
#include "backend/cpu/kernel_set.inl"
