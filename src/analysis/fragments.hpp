#pragma once
// Fragments: the connected components of the automata under intact links.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace mca {
struct Model;
}

namespace mca::analysis {

struct Fragments {
  std::vector<std::int32_t> id;  // per automaton; 0 = the heaviest fragment
  std::int32_t count = 0;
};

// Union-find over the links with link_intact[k] != 0. Ids are numbered by mass, heaviest first (with
// `mass` null every automaton weighs the same: by automata count); equal masses are ordered by the
// smallest automaton index they contain. A fragment's mass is summed in automaton order, so the
// labelling depends only on the link state and the masses, not on link order. Throws
// std::out_of_range for a link index >= n_automata.
Fragments label_fragments(std::size_t n_automata, const std::uint32_t* link_i, const std::uint32_t* link_j,
                          const std::uint8_t* link_intact, std::size_t n_links, const float* mass);
// The same for the links of a model (core/model.hpp: lattice slots k = axis * n + i link automaton i to
// neighbour[k], then the explicit links), intact[] per link slot, numbered by the automata's masses.
Fragments label_model_fragments(const Model& m, const std::uint8_t* intact);

struct FragmentInfo {
  std::int32_t id = 0;
  std::int64_t automata = 0;
  double mass = 0.0;
  double volume = 0.0;  // sum of its automata's volumes (0 when describe_fragments got none)
  std::array<double, 3> centre{}, velocity{}, box_min{}, box_max{};  // box of the automaton centres
};

// One entry per fragment in id order. `mass` (and `volume`, may be null) has one value per automaton,
// `xyz` and `vel` three, in double (the state's positions and velocities as they are: a float copy lost
// the digits of a body far from the origin or fast). Centre is mass-weighted and velocity is momentum /
// mass; a fragment of zero total mass falls back to the plain average of its automata.
std::vector<FragmentInfo> describe_fragments(const Fragments& fragments, const float* mass, const double* xyz,
                                             const double* vel, const float* volume = nullptr);

// Fragments by size: bin k holds those of 2^k to 2^(k+1) - 1 automata (1, 2-3, 4-7, ...), with their
// count and mass; the bins run up to the largest fragment's.
struct SizeBin {
  std::int64_t automata_min = 0, automata_max = 0;
  std::int64_t fragments = 0;
  double mass = 0.0;
};
std::vector<SizeBin> fragment_size_bins(const std::vector<FragmentInfo>& fragments);

}  // namespace mca::analysis
