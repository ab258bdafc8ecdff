// How fast this machine's memory delivers k arrays read side by side, for k = 1 ... 56: the question
// behind the tiled link results of the CPU backend (docs/benchmarks.md, "Where the time goes").
// Each pass reads 256 MB in all, k arrays of 256/k MB, one vector from each array in turn, as a
// kernel reading k quantities per automaton does; it prints the best of 5 passes, in GB/s, for a read-only
// pass and for one that writes every vector back (bytes read + written).
//   g++ -std=c++20 -O2 -march=native bench/streams/streams.cpp -o /tmp/streams && /tmp/streams
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <experimental/simd>
#include <vector>

namespace stdx = std::experimental;
using V = stdx::native_simd<float>;

int main() {
  const std::size_t total = std::size_t{64} << 20;  // floats over all arrays
  for (int k : {1, 4, 8, 14, 21, 28, 42, 56}) {
    const std::size_t n = total / k / V::size() * V::size();
    std::vector<float*> a(k);
    for (auto& p : a) {
      p = static_cast<float*>(std::aligned_alloc(64, n * sizeof(float)));
      for (std::size_t j = 0; j < n; ++j) p[j] = static_cast<float>(j % 1024);
    }
    double read = 1e9, rw = 1e9;
    for (int rep = 0; rep < 5; ++rep) {
      auto t0 = std::chrono::steady_clock::now();
      V s = 0.0f;
      for (std::size_t j = 0; j < n; j += V::size())
        for (int i = 0; i < k; ++i) s += V(a[i] + j, stdx::vector_aligned);
      auto t1 = std::chrono::steady_clock::now();
      if (stdx::reduce(s) == -1.0f) std::puts("");  // keep the sum
      for (std::size_t j = 0; j < n; j += V::size())
        for (int i = 0; i < k; ++i) (V(a[i] + j, stdx::vector_aligned) + 1.0f).copy_to(a[i] + j, stdx::vector_aligned);
      auto t2 = std::chrono::steady_clock::now();
      read = std::min(read, std::chrono::duration<double>(t1 - t0).count());
      rw = std::min(rw, std::chrono::duration<double>(t2 - t1).count());
    }
    const double bytes = static_cast<double>(k) * n * sizeof(float);
    std::printf("%2d arrays  read %5.1f GB/s  read and write back %5.1f GB/s\n", k, bytes / read / 1e9,
                2 * bytes / rw / 1e9);
    for (auto p : a) std::free(p);
  }
}
