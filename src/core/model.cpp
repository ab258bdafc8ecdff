#include "core/model.hpp"

#include "core/state.hpp"

namespace mca {

void link_damage(const Model& m, const std::uint8_t* intact, float* out) {
  const std::size_t n = m.size();
  for (std::size_t a = 0; a < n; ++a) {
    std::uint32_t links = 0, broken = 0;
    for (std::size_t axis = 0; axis < 3; ++axis) {
      const std::size_t up = axis * n + a;
      const std::uint32_t below = m.neighbour_below[up];
      if (m.neighbour[up] != Model::kNoLink) {
        ++links;
        broken += !intact[up];
      }
      if (below != Model::kNoLink) {
        ++links;
        broken += !intact[axis * n + below];
      }
    }
    out[a] = links ? static_cast<float>(broken) / static_cast<float>(links) : 0.0f;
  }
}

std::size_t estimate_memory_bytes(std::size_t automata, std::size_t links) {
  // What a run holds at its peak, counted from the arrays (and checked against the measured peak resident
  // size: Cli.MemoryEstimateMatchesThePeak):
  //   per automaton  model 68 (centre 24, velocity 12, mass, radius, inertia, volume 16, class factor 4,
  //                  group, class 2, object 4, grip 2, adjacency start 4); state 140 (x 24, v 12, w 12, q 16,
  //                  averaged stress 24, mean stress 4, force and torque 24, rebuild positions 24); backend
  //                  98 (inverse mass, inertia, volume 12, many-body terms 12, external force, torque and
  //                  stress 48, flags 2, adjacency codes 24); frame output and fragments 60; contacts 64
  //                  (about one unlinked pair of 32 bytes per automaton once it has broken up, two lists
  //                  while the list is rebuilt);
  //   per link       model 25 (ends 8, rest length, area 8, axis 1, adjacency 8); state 13 (intact, shear
  //                  displacement); backend 80 (direction, strain, gathered force and torque, shear modulus,
  //                  spring, strengths, 1 / r0, dashpots);
  //   fixed          8 MB (program, libraries, thread stacks).
  const std::size_t per_automaton = 68 + 140 + 98 + 60 + 64;
  const std::size_t per_link = 25 + 13 + 80;
  return automata * per_automaton + links * per_link + 8'000'000;
}

}  // namespace mca
