// The CUDA backend: DeviceBackend over CudaDevice, and the device it runs on.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "backend/cuda/cuda_device.cuh"
#include "backend/cuda/device_backend.hpp"
#include "backend/cuda/host_device.hpp"

namespace mca {

std::string cuda_device(std::string* why) {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess || count == 0) {
    int driver = 0;  // (0: none installed; -1: not read)
    if (e == cudaErrorInsufficientDriver && cudaDriverGetVersion(&driver) != cudaSuccess) driver = -1;
    if (why)
      *why = e == cudaErrorInsufficientDriver ? cuda_driver_problem(driver, CUDART_VERSION)
             : e == cudaErrorNoDevice || e == cudaSuccess ? std::string("no NVIDIA GPU is present")
                                                          : std::string("the NVIDIA driver reports no usable GPU (CUDA: ") +
                                                                cudaGetErrorString(e) + ")";
    return "";
  }
  cudaDeviceProp p{};
  if (cudaGetDeviceProperties(&p, 0) != cudaSuccess) {
    if (why) *why = "the GPU's properties could not be read";
    return "";
  }
  // The oldest GPU this build's device code runs on (CMAKE_CUDA_ARCHITECTURES: sm_80 by default).
  constexpr int kArchs[] = {__CUDA_ARCH_LIST__};
  const int oldest = *std::min_element(std::begin(kArchs), std::end(kArchs));
  if (100 * p.major + 10 * p.minor < oldest) {
    if (why)
      *why = std::string("the GPU (") + p.name + ") has compute capability " + std::to_string(p.major) + "." +
             std::to_string(p.minor) + "; this build's device code needs " + std::to_string(oldest / 100) + "." +
             std::to_string(oldest / 10 % 10) + " or newer";
    return "";
  }
  // And a kernel image for it (a build for other GPUs, without PTX, has none).
  cudaFuncAttributes kernel{};
  if (const cudaError_t k = cudaFuncGetAttributes(&kernel, gpu::small_scan_kernel); k != cudaSuccess) {
    cudaGetLastError();
    if (why)
      *why = std::string("this build's device code does not run on the GPU (") + p.name + ", compute capability " +
             std::to_string(p.major) + "." + std::to_string(p.minor) + "; CUDA: " + cudaGetErrorString(k) +
             "): build mca with CMAKE_CUDA_ARCHITECTURES naming it";
    return "";
  }
  char text[400];
  std::snprintf(text, sizeof text, "%s, %.0f GiB, compute capability %d.%d", p.name,
                static_cast<double>(p.totalGlobalMem) / (1024.0 * 1024.0 * 1024.0), p.major, p.minor);
  return text;
}

namespace {
class CudaBackend final : public gpu::DeviceBackend<gpu::CudaDevice> {
 public:
  CudaBackend(const Model& m, std::string device) : DeviceBackend(m), device_(std::move(device)) {}
  std::string name() const override { return "cuda (" + device_ + ")"; }

 private:
  std::string device_;
};

// The GPU's description (cuda_device), or an mca::Error saying why there is none.
std::string required_device() {
  std::string why;
  std::string device = cuda_device(&why);
  if (device.empty()) throw Error("the CUDA backend needs an NVIDIA GPU: " + why);
  return device;
}
}  // namespace

std::unique_ptr<Backend> make_cuda_backend(const Model& model) {
  return std::make_unique<CudaBackend>(model, required_device());
}

namespace {
using Dev = gpu::CudaDevice;
using Twin = gpu::HostDevice;  // the primitives' serial twins (host_device.hpp), the emulation's

template <class Key>
std::string sort_differs(std::size_t n, int key_bits, Key mod, std::mt19937_64& rng) {
  std::vector<Key> keys(n);
  std::vector<std::uint32_t> values(n);
  for (std::size_t i = 0; i < n; ++i) {
    keys[i] = static_cast<Key>(rng() % mod);
    values[i] = static_cast<std::uint32_t>(i);
  }
  std::vector<Key> expected_keys = keys;
  std::vector<std::uint32_t> expected_values = values;
  Twin::stable_sort_by_key(expected_keys.data(), expected_values.data(), n, key_bits);
  Dev::Buffer<Key> k;
  Dev::Buffer<std::uint32_t> v;
  Dev::upload(k, keys);
  Dev::upload(v, values);
  Dev::stable_sort_by_key(k.data(), v.data(), n, key_bits);
  Dev::download(keys.data(), k, n);
  Dev::download(values.data(), v, n);
  for (std::size_t i = 0; i < n; ++i)
    if (keys[i] != expected_keys[i] || values[i] != expected_values[i])
      return "stable_sort_by_key of " + std::to_string(n) + " " + std::to_string(8 * sizeof(Key)) + "-bit keys below " +
             std::to_string(mod) + ": element " + std::to_string(i) + " is (" + std::to_string(keys[i]) + ", " +
             std::to_string(values[i]) + "), not (" + std::to_string(expected_keys[i]) + ", " +
             std::to_string(expected_values[i]) + ")";
  return "";
}

std::string scan_differs(std::size_t n, std::mt19937_64& rng) {
  std::vector<std::uint32_t> in(n), out(n + 1, 0xdeadbeefu), expected(n + 1);
  for (auto& x : in) x = static_cast<std::uint32_t>(rng() % 3);
  Twin::exclusive_scan(in.data(), expected.data(), n);
  Dev::Buffer<std::uint32_t> a, b;
  Dev::upload(a, in);
  Dev::upload(b, out);  // (not zeros: every element must be written)
  Dev::exclusive_scan(a.data(), b.data(), n);
  Dev::download(out.data(), b, n + 1);
  for (std::size_t i = 0; i <= n; ++i)
    if (out[i] != expected[i])
      return "exclusive_scan of " + std::to_string(n) + ": element " + std::to_string(i) + " is " + std::to_string(out[i]) +
             ", not " + std::to_string(expected[i]);
  return "";
}

// Phase 0 writes a, phase 1 reads what other threads wrote there, phase 2 one thread sums it.
struct PhasesKernel {
  static constexpr int kPhases = 3;
  std::uint32_t *a, *b;
  unsigned long long* sum;
  std::uint32_t n;
  __host__ __device__ std::size_t size(int phase) const { return phase == 2 ? 1 : n; }
  __host__ __device__ void operator()(int phase, std::size_t k) const {
    if (phase == 0) {
      a[k] = static_cast<std::uint32_t>(k) + 1;
    } else if (phase == 1) {
      b[k] = a[n - 1 - k];
    } else {
      unsigned long long s = 0;
      for (std::uint32_t i = 0; i < n; ++i) s += b[i];
      *sum = s;
    }
  }
};
}  // namespace

std::string cuda_primitives_check() {
  required_device();
  std::mt19937_64 rng(7);
  for (const std::size_t n : {0, 1, 2, 31, 33, 255, 257, 1000, 1023, 1024, 1025, 4095, 4096, 4097, 100000}) {
    for (std::string d : {sort_differs<std::uint32_t>(n, 12, 1u << 12, rng), sort_differs<std::uint32_t>(n, 3, 5u, rng),
                          sort_differs<std::uint64_t>(n, 52, std::uint64_t{1} << 52, rng),
                          sort_differs<std::uint64_t>(n, 40, std::uint64_t{7}, rng), scan_differs(n, rng)})
      if (!d.empty()) return d;
  }
  for (const std::uint32_t n : {1u, 255u, 256u, 257u, 5000u}) {
    Dev::Buffer<std::uint32_t> a, b;
    Dev::Buffer<unsigned long long> sum;
    a.resize(n);
    b.resize(n);
    sum.resize(1);
    for (int rep = 0; rep < 20; ++rep) {
      Dev::launch_block(PhasesKernel{a.data(), b.data(), sum.data(), n});
      unsigned long long got = 0;
      Dev::download(&got, sum, 1);
      if (got != std::uint64_t{n} * (n + 1) / 2)
        return "launch_block of " + std::to_string(n) + " threads' work per phase: the sum is " + std::to_string(got) +
               ", not " + std::to_string(std::uint64_t{n} * (n + 1) / 2);
    }
  }
  return "";
}

std::string cuda_memory_check() {
  required_device();
  std::size_t free = 0, total = 0;
  gpu::cuda_check(cudaMemGetInfo(&free, &total), "cudaMemGetInfo");
  const std::size_t held = gpu::DeviceMemory::held();
  Dev::Buffer<double> big;
  try {
    big.resize(total / sizeof(double) * 2);  // twice the GPU
    return "an array of twice the GPU's " + std::to_string(total) + " bytes was made";
  } catch (const Error& e) {
    if (std::string(e.what()).find("the GPU's memory is full") == std::string::npos)
      return std::string("the error is not the full GPU's: ") + e.what();
  }
  if (gpu::DeviceMemory::held() != held)
    return "the refused array is counted: " + std::to_string(gpu::DeviceMemory::held() - held) + " bytes more held";
  std::vector<std::uint32_t> values(1 << 18), back(values.size());
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<std::uint32_t>(i * 2654435761u);
  Dev::Buffer<std::uint32_t> b;
  Dev::upload(b, values);
  Dev::download(back.data(), b, back.size());
  if (back != values) return "an array made after the refusal does not read back what was written";
  if (gpu::DeviceMemory::held() != held + values.size() * sizeof(std::uint32_t))
    return "an array of 1 MB is not counted as 1 MB held";
  return "";
}

}  // namespace mca
