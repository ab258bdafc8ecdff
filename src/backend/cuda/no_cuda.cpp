// A build without nvcc: no CUDA device code (the CUDA backend's host emulation is still built).
#include "backend/backend.hpp"
#include "mca/error.hpp"

namespace mca {

std::string cuda_device(std::string* why) {
  if (why) *why = "this build of mca has no CUDA device code (nvcc was not found when it was built, or MCA_CUDA=OFF)";
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
