// The tests' backend where a scene leaves it on auto: the CPU, whose checks they are, also on a machine with
// an NVIDIA GPU (where auto would take the GPU). MCA_BACKEND set by hand (MCA_BACKEND=cuda) runs them on
// another backend instead; the CudaDevice tests ask for the GPU themselves.
#include <cstdlib>

namespace {
const bool kCpuUnlessSet = [] {
  setenv("MCA_BACKEND", "cpu", 0);
  return true;
}();
}  // namespace
