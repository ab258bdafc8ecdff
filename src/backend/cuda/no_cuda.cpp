// A build without nvcc: no CUDA device code (the CUDA backend's host emulation is still built).
#include "backend/backend.hpp"
#include "mca/error.hpp"

namespace mca {

std::string cuda_device(std::string* why) {
  // (MCA_NO_DEVICE_CODE_WHY: CMakeLists.txt's reason, such as "no nvcc found" or an nvcc older than CUDA 12)
  if (why) *why = std::string("this build of mca has no CUDA device code (when it was built: ") + MCA_NO_DEVICE_CODE_WHY + ")";
  return "";
}

namespace {
[[noreturn]] void unavailable() {
  std::string why;
  cuda_device(&why);
  throw Error("the CUDA backend is not available: " + why);
}
}  // namespace

std::unique_ptr<Backend> make_cuda_backend(const Model&) { unavailable(); }

std::string cuda_primitives_check() { unavailable(); }

std::string cuda_memory_check() { unavailable(); }

}  // namespace mca
