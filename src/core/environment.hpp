#pragma once
// Environment variables every backend reads.

namespace mca {

// MCA_PROFILE: unset, empty or 0: off; 1: each backend prints the time of its passes when it ends (the
// CUDA backend also its reads and device memory). Any other value is an mca::Error naming it.
bool profile_requested();

}  // namespace mca
