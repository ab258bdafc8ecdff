// The device's copy bandwidth, the ceiling the CUDA backend's kernels are measured against
// (docs/benchmarks.md): a device-to-device copy of 2 GiB, bytes read plus bytes written over the median
// of 20 copies timed with CUDA events. Built and run by scripts/gpu_check.sh; prints one line.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

static void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) {
    std::fprintf(stderr, "copy_bandwidth: %s: %s\n", what, cudaGetErrorString(e));
    std::exit(1);
  }
}

// Not zeros: the copy moves data the way the backend's arrays hold it.
__global__ void fill(unsigned* p, std::size_t n) {
  for (std::size_t i = blockIdx.x * static_cast<std::size_t>(blockDim.x) + threadIdx.x; i < n;
       i += static_cast<std::size_t>(gridDim.x) * blockDim.x)
    p[i] = static_cast<unsigned>(i * 2654435761u);
}

int main() {
  const std::size_t bytes = std::size_t{2} << 30, n = bytes / sizeof(unsigned);
  unsigned *a = nullptr, *b = nullptr;
  check(cudaMalloc(&a, bytes), "cudaMalloc");
  check(cudaMalloc(&b, bytes), "cudaMalloc");
  fill<<<1024, 256>>>(a, n);
  check(cudaGetLastError(), "fill");
  cudaEvent_t start, stop;
  check(cudaEventCreate(&start), "cudaEventCreate");
  check(cudaEventCreate(&stop), "cudaEventCreate");
  std::vector<float> ms;
  for (int k = 0; k < 23; ++k) {
    check(cudaEventRecord(start), "cudaEventRecord");
    check(cudaMemcpyAsync(b, a, bytes, cudaMemcpyDeviceToDevice), "copy");
    check(cudaEventRecord(stop), "cudaEventRecord");
    check(cudaEventSynchronize(stop), "cudaEventSynchronize");
    float t = 0;
    check(cudaEventElapsedTime(&t, start, stop), "cudaEventElapsedTime");
    if (k >= 3) ms.push_back(t);  // the first three warm up
  }
  std::sort(ms.begin(), ms.end());
  const double median = 0.5 * (ms[ms.size() / 2 - 1] + ms[ms.size() / 2]);
  cudaDeviceProp p{};
  check(cudaGetDeviceProperties(&p, 0), "cudaGetDeviceProperties");
  std::printf("device-to-device copy on %s: %.0f GB/s (read + write, 2 GiB, median of %zu; %.3f to %.3f ms)\n", p.name,
              2.0 * static_cast<double>(bytes) / (median * 1e-3) / 1e9, ms.size(), ms.front(), ms.back());
  return 0;
}
