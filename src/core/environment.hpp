#pragma once
// What the environment gives: variables every backend reads, and the machine's memory.

namespace mca {

// MCA_PROFILE: unset, empty or 0: off; 1: each backend prints the time of its passes when it ends (the
// CUDA backend also its reads and device memory). Any other value is an mca::Error naming it.
bool profile_requested();

// The machine's physical memory in bytes, 0 where the system does not say.
double machine_memory_bytes();

}  // namespace mca
