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

bool cuda_fused_lattice() {
  const char* given = std::getenv("MCA_CUDA_LATTICE");
  if (!given || !*given || std::string_view(given) == "fused") return true;
  if (std::string_view(given) == "split") return false;
  throw Error(fmt::format("MCA_CUDA_LATTICE = '{}' (how the CUDA backend runs the lattice): give fused (the default) or "
                          "split, or unset it",
                          given));
}

}  // namespace mca
