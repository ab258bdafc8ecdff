// The CUDA backend's host emulation: DeviceBackend over HostDevice (see host_device.hpp).
#include "backend/cuda/device_backend.hpp"
#include "backend/cuda/host_device.hpp"

namespace mca {

std::unique_ptr<Backend> make_cuda_emulation_backend(const Model& model) {
  return std::make_unique<gpu::DeviceBackend<gpu::HostDevice>>(model);
}

}  // namespace mca
