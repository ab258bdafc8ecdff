// The CUDA backend's host emulation: DeviceBackend over HostDevice (see host_device.hpp).
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <fmt/format.h>
#include <string_view>

#include "backend/cuda/device_backend.hpp"
#include "backend/cuda/device_memory.hpp"
#include "backend/cuda/host_device.hpp"
#include "core/text.hpp"
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

std::string cuda_driver_problem(int driver, int runtime) {
  const auto version = [](int v) { return fmt::format("{}.{}", v / 1000, v % 1000 / 10); };
  const int major = runtime / 1000;
  // The first driver series of each CUDA major version (NVIDIA's release notes, "CUDA Toolkit and Minimum
  // Required Driver Version"): a runtime of that major version runs on it and every later one.
  const char* series = major == 11 ? "450" : major == 12 ? "525" : major == 13 ? "580" : nullptr;
  const std::string needs =
      series ? fmt::format("a driver for CUDA {} or later (NVIDIA's {} series or newer)", major, series)
             : fmt::format("a driver for CUDA {} or later", major);
  if (driver == 0)
    return fmt::format("no NVIDIA driver is installed (its library, libcuda.so.1, was not found); this build's CUDA "
                       "runtime {} needs {}",
                       version(runtime), needs);
  if (driver < 0)
    return fmt::format("the NVIDIA driver did not start this build's CUDA runtime {} and could not be asked for its "
                       "version; the runtime needs {}",
                       version(runtime), needs);
  if (driver / 1000 >= major)  // (the runtime's verdict, though the driver is of its major version)
    return fmt::format("the NVIDIA driver, for CUDA {}, reports that it is too old for this build's CUDA runtime {}: "
                       "update it to the newest {}",
                       version(driver), version(runtime), needs.substr(2));
  // The device code needs CUDA 12 or newer (CMakeLists.txt), and a toolkit of the driver's major version runs
  // on it.
  const std::string rebuild =
      driver / 1000 >= 12 ? fmt::format(", or build mca with a CUDA {} toolkit (CMAKE_CUDA_COMPILER naming its nvcc)",
                                        driver / 1000)
                          : std::string(" (mca's device code needs CUDA 12 or newer)");
  return fmt::format("the NVIDIA driver supports CUDA {} and this build's CUDA runtime {} needs {}: update the "
                     "driver{}",
                     version(driver), version(runtime), needs, rebuild);
}

namespace gpu {

std::optional<std::size_t> emulated_gpu_memory() {
  const char* given = std::getenv("MCA_EMULATED_GPU_MEMORY_MB");
  if (!given || !*given) return std::nullopt;
  const std::string_view text(given);
  double mb = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), mb);
  constexpr double kMost = 1e9;  // MB: a GPU of 1 PB
  if (ec != std::errc() || end != text.data() + text.size() || !(mb >= 0.001 && mb <= kMost))
    throw Error(fmt::format("MCA_EMULATED_GPU_MEMORY_MB = '{}' (the memory of the GPU the cuda-emulation backend plays): "
                            "give a number of MB (1e6 bytes) from 0.001 to 1e9, or unset it",
                            given));
  return static_cast<std::size_t>(std::llround(mb * 1e6));
}

DeviceMemoryFull out_of_device_memory(std::size_t asked, std::size_t free, std::size_t total, bool emulated) {
  const auto mb = [](std::size_t bytes) { return text::human_bytes(static_cast<double>(bytes)); };
  const std::string room = !total   ? std::string("the GPU's free memory could not be read")
                           : emulated ? fmt::format("the emulated GPU (MCA_EMULATED_GPU_MEMORY_MB) has {} free of {}",
                                                    mb(free), mb(total))
                                      : fmt::format("the GPU has {} free of {} (other programs may hold some)", mb(free),
                                                    mb(total));
  return DeviceMemoryFull(fmt::format(
      "the GPU's memory is full: mca asked for {} more, holding {} there (all of this process's simulations: in "
      "Python, each Simulation still alive, or an array view of one, holds its own), and {}. This scene needs more GPU "
      "memory: "
      "use backend \"cpu\" (--backend cpu, or solver.backend; a run stopped by this continues from its last "
      "checkpoint with mca resume DIR --backend cpu), a larger solver.spacing, or {}",
      mb(asked), mb(DeviceMemory::held()), room,
      emulated ? "a larger MCA_EMULATED_GPU_MEMORY_MB (or none)" : "a GPU with more memory"));
}

}  // namespace gpu

}  // namespace mca
