// The lattice kernels for one automaton or link at a time: the reference the others must match.
// Everything here is in namespace mca::cpu::scalar (see lattice_kernels.hpp).
#include "backend/cpu/lanes.hpp"  // first: see lanes.hpp
#include "backend/cpu/lattice_kernels.hpp"
#include "physics/fracture.hpp"
#include "physics/integrate.hpp"
#include "physics/link_law.hpp"

#include <algorithm>
#include <cmath>

namespace mca::cpu::scalar {
using V = float;
#include "backend/cpu/lattice_kernels.inl"
constexpr Kernels kKernels = make_kernels("scalar");
}  // namespace mca::cpu::scalar

namespace mca::cpu {
const Kernels& kernels_scalar() { return scalar::kKernels; }
}  // namespace mca::cpu
