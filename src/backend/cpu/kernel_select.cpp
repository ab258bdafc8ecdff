// Which build of the lattice kernels runs: the widest instruction set this processor has, or the one
// the MCA_SIMD environment variable names (to compare, or to step around a processor's fault).
#include <cstdlib>
#include <fmt/format.h>
#include <string>

#include "backend/cpu/lattice_kernels.hpp"
#include "core/text.hpp"
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

std::vector<BlockRun> block_runs(const Model& m, int lanes) {
  const std::size_t n = m.size(), W = static_cast<std::size_t>(lanes), blocks = W > 1 ? n / W : 0;
  std::vector<BlockRun> runs(6 * blocks);
  for (int dir = 0; dir < 6; ++dir) {
    const std::uint32_t* nb = (dir < 3 ? m.neighbour.data() : m.neighbour_below.data()) + (dir % 3) * n;
    for (std::size_t blk = 0; blk < blocks; ++blk) {
      const std::size_t a0 = blk * W;
      BlockRun r{0, 0};
      bool first = true, run = true;
      std::int64_t c = 0;
      for (std::size_t k = 0; k < W; ++k) {
        const std::uint32_t j = nb[a0 + k];
        if (j == Model::kNoLink) continue;
        r.has |= 1u << k;
        const std::int64_t o = static_cast<std::int64_t>(j) - static_cast<std::int64_t>(a0 + k);
        if (first) c = o, first = false;
        else run = run && o == c;
      }
      const std::int64_t j0 = static_cast<std::int64_t>(a0) + c;
      run = run && j0 >= 0 && j0 + static_cast<std::int64_t>(W) <= static_cast<std::int64_t>(n);
      r.offset = run ? static_cast<std::int32_t>(c) : BlockRun::kGather;
      runs[static_cast<std::size_t>(dir) * blocks + blk] = r;
    }
  }
  return runs;
}

const Kernels& select_kernels() {
  const Kernels* sets[4];
  const int count = available_kernels(sets);
  const char* given = std::getenv("MCA_SIMD");
  if (!given || !*given) return *sets[count - 1];
  const std::string want = text::lower(given);  // any case: AVX2 is avx2
  std::string have;
  for (int k = 0; k < count; ++k) {
    if (want == sets[k]->name) return *sets[k];
    have += (k ? ", " : "") + std::string(sets[k]->name);
  }
  const bool known = want == kernels_avx2().name || want == kernels_avx512().name;
  throw Error(fmt::format("MCA_SIMD = {}: {}; this processor runs {} (unset MCA_SIMD for the widest)", given,
                          known ? "this processor lacks that instruction set" : "not an instruction set mca knows",
                          have));
}

}  // namespace mca::cpu
