#pragma once
// What the environment gives: variables every backend reads, and the machine's memory.
#include <string>

namespace mca {

// MCA_PROFILE: unset, empty or 0: off; 1: each backend prints the time of its passes when it ends (the
// CUDA backend also its reads and device memory). Any other value is an mca::Error naming it.
bool profile_requested();

// MCA_CUDA_SYNC: unset, empty or 0: off; 1: the CUDA backend waits for each kernel after its launch, so that a
// kernel that fails is named (it is otherwise reported by the next call that waits). Any other value is an
// mca::Error naming it (a "true" or "yes" was taken for off without a word).
bool cuda_sync_requested();

// The machine's physical memory in bytes, 0 where the system does not say.
double machine_memory_bytes();

// The memory a run may take: solver.max_memory_gb (`setting_bytes`), or 90 % of this machine's memory where
// that is less (a model larger than the machine would swap for hours before failing, or be killed). For
// messages, what a need is then over ("over solver.max_memory_gb = 4", "more than the 22.8 GB a run may take
// of this machine's 25.3 GB (90 %)") and the fix beside a smaller need ("raise solver.max_memory_gb if the
// machine has it", "run it on a larger machine"). Bounds a model (lattice::memory_limit) and a mesh file's
// reading alike.
struct MemoryLimit {
  double bytes = 0;
  std::string over, instead;
};
MemoryLimit memory_limit(double setting_bytes);

}  // namespace mca
