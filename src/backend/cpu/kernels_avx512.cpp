// The lattice kernels for AVX-512, 16 lanes (compiled with -mavx512f -mavx512vl -mavx512bw -mavx512dq).

// GCC 12's avx512fintrin.h builds its "undefined" vectors as `__m512 __Y = __Y;`, which -Wmaybe-uninitialized
// reports wherever std::experimental::simd inlines one (GCC bug 105593, fixed in GCC 13).
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

#define MCA_KERNEL_SET avx512
#define MCA_KERNEL_LANE stdx::native_simd<float>
#include "backend/cpu/kernel_set.inl"
