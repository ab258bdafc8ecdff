// The CUDA backend's host emulation: DeviceBackend over HostDevice (see host_device.hpp).
#include <cstdlib>
#include <fmt/format.h>
#include <string_view>

#include "backend/cuda/device_backend.hpp"
#include "backend/cuda/host_device.hpp"
#include "mca/error.hpp"

namespace mca {

std::unique_ptr<Backend> make_cuda_emulation_backend(const Model& model) {
  return std::make_unique<gpu::DeviceBackend<gpu::HostDevice>>(model);
}

CudaLattice cuda_lattice() {
  const char* given = std::getenv("MCA_CUDA_LATTICE");
  if (!given || !*given) return {};
  const std::string_view how(given);
  if (how == "split") return {false, 3};
  if (how == "fused") return {};
  for (const int blocks : {2, 3, 4})
    if (how == fmt::format("fused:{}", blocks)) return {true, blocks};
  throw Error(fmt::format("MCA_CUDA_LATTICE = '{}' (how the CUDA backend runs the lattice): give fused (the default), "
                          "fused:2, fused:3 or fused:4 (the fused kernel's blocks per multiprocessor; fused is fused:3) "
                          "or split, or unset it",
                          given));
}

}  // namespace mca
