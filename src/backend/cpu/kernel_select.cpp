// Which build of the lattice kernels runs: the widest instruction set this processor has, or the one
// the MCA_SIMD environment variable names (to compare, or to step around a processor's fault).
#include <cstdlib>
#include <cstring>
#include <fmt/format.h>
#include <string>

#include "backend/cpu/lattice_kernels.hpp"
#include "mca/error.hpp"

namespace mca::cpu {

int available_kernels(const Kernels* out[4]) {
  int k = 0;
  out[k++] = &kernels_scalar();
  out[k++] = &kernels_sse2();  // every x86-64 processor has SSE2
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2")) out[k++] = &kernels_avx2();
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512bw") &&
      __builtin_cpu_supports("avx512dq"))
    out[k++] = &kernels_avx512();
  return k;
}

const Kernels& select_kernels() {
  const Kernels* sets[4];
  const int count = available_kernels(sets);
  const char* want = std::getenv("MCA_SIMD");
  if (!want || !*want) return *sets[count - 1];
  std::string have;
  for (int k = 0; k < count; ++k) {
    if (std::strcmp(want, sets[k]->name) == 0) return *sets[k];
    have += (k ? ", " : "") + std::string(sets[k]->name);
  }
  const bool known = std::strcmp(want, "avx2") == 0 || std::strcmp(want, "avx512") == 0;
  throw Error(fmt::format("MCA_SIMD = {}: {}; this processor runs {} (unset MCA_SIMD for the widest)", want,
                          known ? "this processor lacks that instruction set" : "not an instruction set mca knows",
                          have));
}

}  // namespace mca::cpu
