#pragma once
// The exponential of the physics (the strengthening law, link_law.hpp), written out so that every backend
// computes the same bits: glibc's exp on the CPU and CUDA's on a GPU thread (an approximate ex2 and fused
// multiply-adds) differ in the last bits, and the law's results feed the state. Only +, -, *, / rounded to
// nearest are used (the host is built with -ffp-contract=off, the device with --fmad=false), so a CPU, a
// SIMD-free GPU thread and any compiler give the same result.
//
// The method is fdlibm's e_exp.c (Sun Microsystems, 1993; FreeBSD's and musl's exp): x = k ln2 + r with
// |r| <= ln2 / 2, ln2 split in two so that k ln2_hi is exact, then a rational approximation of exp(r)
// whose error is below one unit in the last place. tests/test_exp.cpp holds it to one unit in the last
// place of the correctly rounded value over the ranges the law uses, and to the edges (overflow,
// underflow, NaN).
#include <cstdint>
#include <cstring>

#include "core/math.hpp"

namespace mca {

namespace detail {
// 2^k as a double for -1022 <= k <= 1023 (exact).
MCA_HD double pow2(int k) {
  const std::uint64_t bits = static_cast<std::uint64_t>(k + 1023) << 52;
  double d;
  std::memcpy(&d, &bits, sizeof d);
  return d;
}
}  // namespace detail

// exp(x) within one unit in the last place; +inf above the largest finite result, 0 below the smallest
// subnormal one, NaN for NaN.
MCA_HD double exp_rn(double x) {
  constexpr double kOverflow = 7.09782712893383973096e+02;    // above: exp(x) overflows
  constexpr double kUnderflow = -7.45133219101941108420e+02;  // below: exp(x) < half the least subnormal
  constexpr double kInvLn2 = 1.44269504088896338700e+00;
  constexpr double kLn2Hi = 6.93147180369123816490e-01;  // its low 32 bits are zero: k ln2_hi is exact
  constexpr double kLn2Lo = 1.90821492927058770002e-10;
  constexpr double P1 = 1.66666666666666019037e-01, P2 = -2.77777777770155933842e-03,
                   P3 = 6.61375632143793436117e-05, P4 = -1.65339022054652515390e-06,
                   P5 = 4.13813679705723846039e-08;
  if (!(x == x)) return x;
  if (x > kOverflow) return static_cast<double>(INFINITY);
  if (x < kUnderflow) return 0.0;
  // k = x / ln2 rounded to the nearest integer (halves away from zero); |k| <= 1075.
  const double t = x * kInvLn2;
  const int k = static_cast<int>(t < 0.0 ? t - 0.5 : t + 0.5);
  const double kd = static_cast<double>(k);
  const double hi = x - kd * kLn2Hi, lo = kd * kLn2Lo;
  const double r = hi - lo;
  const double r2 = r * r;
  const double c = r - r2 * (P1 + r2 * (P2 + r2 * (P3 + r2 * (P4 + r2 * P5))));
  const double y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
  // y 2^k, in two exact factors where 2^k itself is not a normal double.
  if (k >= -1021 && k <= 1023) return y * detail::pow2(k);
  if (k > 1023) return y * detail::pow2(1023) * detail::pow2(k - 1023);
  return y * detail::pow2(k + 1000) * detail::pow2(-1000);
}

// exp(x) of a float, rounded from exp_rn.
MCA_HD float exp_rn(float x) { return static_cast<float>(exp_rn(static_cast<double>(x))); }

}  // namespace mca
