// The CUDA backend: DeviceBackend over CudaDevice, and the device it runs on.
#include <cuda_runtime.h>

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <string>

#include "backend/cuda/cuda_device.cuh"
#include "backend/cuda/device_backend.hpp"

namespace mca {

std::string cuda_device(std::string* why) {
  int count = 0;
  const cudaError_t e = cudaGetDeviceCount(&count);
  if (e != cudaSuccess || count == 0) {
    if (why)
      *why = e == cudaErrorInsufficientDriver
                 ? std::string("no NVIDIA driver found, or one older than this build's CUDA runtime needs (CUDA: ") +
                       cudaGetErrorString(e) + ")"
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
}  // namespace

std::unique_ptr<Backend> make_cuda_backend(const Model& model) {
  std::string why;
  const std::string device = cuda_device(&why);
  if (device.empty()) throw Error("the CUDA backend needs an NVIDIA GPU: " + why);
  return std::make_unique<CudaBackend>(model, device);
}

}  // namespace mca
