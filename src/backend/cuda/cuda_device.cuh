#pragma once
// The CUDA device for DeviceBackend (device_backend.hpp): device arrays, kernel launches as grids of one
// thread per element, and the device-wide primitives from Thrust (CUDA toolkit) with the results of their
// host twins in host_device.hpp (integer scans and stable sorts, the max and min of values: none depends on
// the order of evaluation). Compiled by nvcc with --fmad=false (no fused multiply-add, IEEE division and
// square root), so a thread computes the CPU's bits.
#include <cuda_runtime.h>
#include <thrust/execution_policy.h>
#include <thrust/functional.h>
#include <thrust/reduce.h>
#include <thrust/scan.h>
#include <thrust/sort.h>
#include <thrust/transform_reduce.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "mca/error.hpp"

namespace mca::gpu {

inline void cuda_check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw Error(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

template <class K>
__global__ void run_kernel(K k, std::size_t n) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) k(i);
}

template <class T>
__global__ void fill_kernel(T* p, std::size_t n, T value) {
  const std::size_t i = static_cast<std::size_t>(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < n) p[i] = value;
}

// x where x > 0, else 0 (NaN included): the host twin's max ignores NaN the same way.
struct NonNegative {
  __host__ __device__ float operator()(float x) const { return x > 0.0f ? x : 0.0f; }
};
struct Larger {
  __host__ __device__ float operator()(float a, float b) const { return a > b ? a : b; }
};
struct Smaller {
  __host__ __device__ std::uint32_t operator()(std::uint32_t a, std::uint32_t b) const { return a < b ? a : b; }
};

struct CudaDevice {
  static constexpr const char* kName = "cuda";
  static constexpr unsigned kBlock = 256;

  template <class T>
  class Buffer {
   public:
    Buffer() = default;
    Buffer(const Buffer&) = delete;
    Buffer& operator=(const Buffer&) = delete;
    Buffer(Buffer&& o) noexcept
        : p_(std::exchange(o.p_, nullptr)), n_(std::exchange(o.n_, 0)), cap_(std::exchange(o.cap_, 0)) {}
    Buffer& operator=(Buffer&& o) noexcept {
      std::swap(p_, o.p_);
      std::swap(n_, o.n_);
      std::swap(cap_, o.cap_);
      return *this;
    }
    ~Buffer() {
      if (p_) cudaFree(p_);
    }
    T* data() { return p_; }
    const T* data() const { return p_; }
    std::size_t size() const { return n_; }
    // Discards the contents; memory is allocated only when the buffer grows past what it has held (the lists
    // that change size every step reuse theirs).
    void resize(std::size_t n) {
      if (n > cap_) {
        if (p_) cuda_check(cudaFree(p_), "cudaFree");
        p_ = nullptr;
        n_ = cap_ = 0;
        cuda_check(cudaMalloc(reinterpret_cast<void**>(&p_), n * sizeof(T)), "cudaMalloc");
        cap_ = n;
      }
      n_ = n;
    }

   private:
    T* p_ = nullptr;
    std::size_t n_ = 0, cap_ = 0;
  };

  template <class T>
  static void upload(Buffer<T>& b, const T* src, std::size_t n) {
    b.resize(n);
    if (n) cuda_check(cudaMemcpy(b.data(), src, n * sizeof(T), cudaMemcpyHostToDevice), "upload");
  }
  template <class T, class A>
  static void upload(Buffer<T>& b, const std::vector<T, A>& src) {
    upload(b, src.data(), src.size());
  }
  template <class T>
  static void download(T* dst, const Buffer<T>& b, std::size_t n, std::size_t offset = 0) {
    if (n) cuda_check(cudaMemcpy(dst, b.data() + offset, n * sizeof(T), cudaMemcpyDeviceToHost), "download");
  }
  template <class T>
  static void fill(Buffer<T>& b, const T& value) {
    const std::size_t n = b.size();
    if (n == 0) return;
    fill_kernel<<<static_cast<unsigned>((n + kBlock - 1) / kBlock), kBlock>>>(b.data(), n, value);
    cuda_check(cudaGetLastError(), "fill");
  }
  template <class T>
  static void copy(Buffer<T>& to, const Buffer<T>& from, std::size_t n) {
    if (n) cuda_check(cudaMemcpy(to.data(), from.data(), n * sizeof(T), cudaMemcpyDeviceToDevice), "copy");
  }

  template <class K>
  static void launch(std::size_t n, const K& kernel) {
    if (n == 0) return;
    run_kernel<<<static_cast<unsigned>((n + kBlock - 1) / kBlock), kBlock>>>(kernel, n);
    cuda_check(cudaGetLastError(), "kernel launch");
  }

  static std::uint32_t exclusive_scan(const std::uint32_t* in, std::uint32_t* out, std::size_t n) {
    if (n == 0) return 0;
    std::uint32_t last_in = 0;
    cuda_check(cudaMemcpy(&last_in, in + n - 1, sizeof last_in, cudaMemcpyDeviceToHost), "scan");
    thrust::exclusive_scan(thrust::device, in, in + n, out);
    std::uint32_t last_out = 0;
    cuda_check(cudaMemcpy(&last_out, out + n - 1, sizeof last_out, cudaMemcpyDeviceToHost), "scan");
    return last_out + last_in;
  }
  static void stable_sort_by_key(std::uint64_t* keys, std::uint32_t* values, std::size_t n) {
    if (n) thrust::stable_sort_by_key(thrust::device, keys, keys + n, values);
  }
  static float max_of(const float* x, std::size_t n) {
    return n ? thrust::transform_reduce(thrust::device, x, x + n, NonNegative{}, 0.0f, Larger{}) : 0.0f;
  }
  static std::uint32_t min_of(const std::uint32_t* x, std::size_t n) {
    return n ? thrust::reduce(thrust::device, x, x + n, std::uint32_t{0xffffffffu}, Smaller{}) : 0xffffffffu;
  }
};

}  // namespace mca::gpu
