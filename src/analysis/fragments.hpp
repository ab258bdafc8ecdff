#pragma once
// Fragments: the connected components of the automata under intact links.
#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
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

// The fragment mass distribution of issue 21 (summary.json's fragment_mass_distribution), defined as
// tools/fracture_metrics.py defines it, so that the two agree on the same run. Masses are counted in
// automata: a fragment of mass m has size s = m / (M / N), N the automata of the whole run (every object)
// and M their mass; for a single material s is its automata count. Bin k holds the fragments whose size
// rounded to a whole number (halves up, and at least 1: a fragment lighter than half an average automaton
// counts as one) lies in [2^k, 2^(k+1)); the bins run up to the largest fragment's.
struct MassBin {
  int k = 0;
  std::int64_t automata_min = 0, automata_max = 0;  // 2^k and 2^(k+1) - 1
  std::int64_t count = 0;                           // fragments in the bin
  // count / 2^k: fragments per automaton of mass range, the number density n(m) (times the automaton's
  // mass M / N, it is per kg)
  double number_density = 0;
  // sqrt(2^k (2^(k+1) - 1)): the geometric mean of the bin's smallest and largest whole size [automata],
  // where n(m) is plotted and fitted
  double abscissa = 0;
  double mass_share = 0;  // the bin's fragments' mass over M
};

// A class of fragments by automata count: how many, and their share of the mass.
struct FragmentClass {
  std::int64_t count = 0;
  double mass_share = 0;
};

// n(m) ~ m^-tau fitted by unweighted least squares to log10(number_density) against log10(abscissa) over
// the non-empty bins that lie wholly within [1, fit_max] automata (automata_max <= fit_max).
struct PowerLawFit {
  double fit_max_automata = 0;
  int bins_in_range = 0;        // bins (up to the largest fragment's) with automata_max <= fit_max
  int bins_fitted = 0;          // the non-empty ones among them
  int empty_bins_in_range = 0;  // bins_in_range - bins_fitted
  // Each unset value has its reason: tau and the rest with fewer than 2 bins to fit, or with every
  // fragment a single automaton (`reason`; bins_fitted is then 0); the
  // standard error with exactly 2, which a line passes through exactly (`tau_stderr_reason`); R^2 when
  // the fitted densities are all equal, which leaves nothing to explain (`r2_reason`).
  std::optional<double> tau, tau_stderr, r2, log10_prefactor;
  std::string reason, tau_stderr_reason, r2_reason;
  // The first and last fitted abscissae [automata] and the decades between them (0 without a fit;
  // summary.json writes null).
  std::optional<double> m_first, m_last;
  double decades = 0;
};

struct MassDistribution {
  std::int64_t automata = 0;   // N
  std::int64_t fragments = 0;
  double mass = 0;             // M [kg], summed over the fragments heaviest first (fragments.csv's order)
  double automaton_mass = 0;   // M / N [kg]
  std::vector<MassBin> bins;
  FragmentClass singles;       // fragments of 1 automaton
  FragmentClass small;         // 2 to 9 automata
  FragmentClass mid;           // at least 10 automata and at most N / 10 ("between 10 automata and a tenth")
  FragmentClass above_tenth;   // more than N / 10 automata
  double tenth = 0;            // N / 10 [automata]
  std::int64_t largest_automata = 0;
  double largest_mass_share = 0;
  PowerLawFit fit;
  // Set (and everything above empty) when no distribution can be formed: no automata, or no mass.
  std::string reason;
};

// The distribution of `fragments` (describe_fragments: one entry per fragment, heaviest first), fitted up to
// N / 10 automata.
MassDistribution fragment_mass_distribution(const std::vector<FragmentInfo>& fragments);
// The fit alone over `bins` (as fragment_mass_distribution makes them), up to fit_max automata.
PowerLawFit fit_power_law(const std::vector<MassBin>& bins, double fit_max);

}  // namespace mca::analysis
