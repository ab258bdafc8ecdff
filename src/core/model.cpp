#include "core/model.hpp"

#include "core/state.hpp"

namespace mca {

std::size_t estimate_memory_bytes(std::size_t automata, std::size_t links) {
  // Model: position0, velocity0 (24), mass, radius, inertia, volume, class factor (20), group, class (2),
  // object, grip (4), adjacency (4 + 2 * 4 per link). State: x, v, w (36), q (16), s (24), ground (12),
  // rebuild positions (12), backend scratch (forces, torques, many-body terms, flags: about 64).
  // Links: i, j, r0, area, axis (17) + intact, ut, sigma, tau (21) + scratch (force, torque, strain: 28).
  const std::size_t per_automaton = 24 + 20 + 2 + 4 + 4 + 36 + 16 + 24 + 12 + 12 + 64;
  const std::size_t per_link = 17 + 21 + 28 + 8;
  // Contacts: after heavy fragmentation about one unlinked pair per automaton (20 bytes each, twice
  // while the list is rebuilt).
  const std::size_t contacts = automata * 40;
  return automata * per_automaton + links * per_link + contacts;
}

}  // namespace mca
