// The lattice kernels for one automaton or link at a time: the reference the others must match.
#define MCA_KERNEL_SET scalar
#define MCA_KERNEL_LANE float
#include "backend/cpu/kernel_set.inl"
