#!/bin/sh
# Builds bench/simd_compare/simd_compare (not part of the project's CMake build).
# Needs: apt-get install libxsimd-dev libhwy-dev   (Debian 12: xsimd 8.1.0, Highway 1.0.3)
# The project's flags (CMakeLists.txt): -O3 -ffp-contract=off -fno-math-errno; AVX2 = -mavx2, AVX-512 =
# -mavx512f -mavx512vl -mavx512bw -mavx512dq. Highway picks its static target from the predefined
# macros and wants BMI2/FMA/F16C/PCLMUL/AES for its AVX2 and AVX3 targets; its HWY_DISABLE_* switches
# drop that requirement, so Highway gets the same -m flags as the others (no FMA instructions anywhere).
set -eu
cd "$(dirname "$0")"
SRC=../../src
OUT=${OUT_DIR:-build}
CXX=${CXX:-g++}
mkdir -p "$OUT"
COMMON="-std=c++20 -O3 -ffp-contract=off -fno-math-errno -Wall -Wextra -I$SRC"
AVX2="-mavx2"
AVX512="-mavx512f -mavx512vl -mavx512bw -mavx512dq"
HWY="-DHWY_DISABLE_BMI2_FMA -DHWY_DISABLE_F16C -DHWY_DISABLE_PCLMUL_AES"
# GCC 12 bug 105593 (-Wmaybe-uninitialized in avx512fintrin.h), as src/backend/cpu/kernels_avx512.cpp notes.
NOWARN512="-Wno-maybe-uninitialized"
set -x
$CXX $COMMON -DSC_VARIANT=0 -DSC_NAME=scalar                              -c simd_compare.cpp -o $OUT/scalar.o
$CXX $COMMON -DSC_VARIANT=1 -DSC_NAME=stdx_avx2    $AVX2                  -c simd_compare.cpp -o $OUT/stdx_avx2.o
$CXX $COMMON -DSC_VARIANT=1 -DSC_NAME=stdx_avx512  $AVX512 $NOWARN512     -c simd_compare.cpp -o $OUT/stdx_avx512.o
$CXX $COMMON -DSC_VARIANT=2 -DSC_NAME=xsimd_avx2   $AVX2                  -c simd_compare.cpp -o $OUT/xsimd_avx2.o
$CXX $COMMON -DSC_VARIANT=2 -DSC_NAME=xsimd_avx512 $AVX512 $NOWARN512     -c simd_compare.cpp -o $OUT/xsimd_avx512.o
$CXX $COMMON -DSC_VARIANT=3 -DSC_NAME=hwy_avx2     $AVX2 $HWY             -c simd_compare.cpp -o $OUT/hwy_avx2.o
$CXX $COMMON -DSC_VARIANT=3 -DSC_NAME=hwy_avx512   $AVX512 $HWY $NOWARN512 -c simd_compare.cpp -o $OUT/hwy_avx512.o
$CXX $COMMON -DSC_MAIN                                                    -c simd_compare.cpp -o $OUT/main.o
$CXX $OUT/main.o $OUT/scalar.o $OUT/stdx_avx2.o $OUT/stdx_avx512.o $OUT/xsimd_avx2.o $OUT/xsimd_avx512.o \
  $OUT/hwy_avx2.o $OUT/hwy_avx512.o -o $OUT/simd_compare
