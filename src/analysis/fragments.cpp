#include "analysis/fragments.hpp"

#include "core/model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

namespace mca::analysis {

namespace {

class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n), size_(n, 1) {
    std::iota(parent_.begin(), parent_.end(), std::uint32_t{0});
  }

  std::uint32_t find(std::uint32_t a) {
    std::uint32_t root = a;
    while (parent_[root] != root) root = parent_[root];
    while (parent_[a] != root) {  // full path compression
      const std::uint32_t next = parent_[a];
      parent_[a] = root;
      a = next;
    }
    return root;
  }

  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
  }


 private:
  std::vector<std::uint32_t> parent_, size_;
};

}  // namespace

namespace {
// Unites the ends of link k, after checking them.
void unite_link(UnionFind& uf, std::size_t n_automata, std::size_t k, std::uint32_t i, std::uint32_t j) {
  if (i >= n_automata || j >= n_automata)
    throw std::out_of_range(
        fmt::format("label_fragments: link {} ({}, {}) refers past {} automata", k, i, j, n_automata));
  uf.unite(i, j);
}

Fragments number_fragments(std::size_t n_automata, UnionFind& uf, const float* mass);

UnionFind fresh_union(std::size_t n_automata) {
  if (n_automata > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max()))
    throw std::out_of_range(fmt::format("label_fragments: {} automata exceed int32 ids", n_automata));
  return UnionFind(n_automata);
}
}  // namespace

Fragments label_fragments(std::size_t n_automata, const std::uint32_t* link_i, const std::uint32_t* link_j,
                          const std::uint8_t* link_intact, std::size_t n_links, const float* mass) {
  UnionFind uf = fresh_union(n_automata);
  for (std::size_t k = 0; k < n_links; ++k)
    if (link_intact[k]) unite_link(uf, n_automata, k, link_i[k], link_j[k]);
  return number_fragments(n_automata, uf, mass);
}

Fragments label_model_fragments(const Model& m, const std::uint8_t* intact) {
  const std::size_t n = m.size();
  UnionFind uf = fresh_union(n);
  m.for_each_link([&](std::size_t l, std::uint32_t i, std::uint32_t j, int) {
    if (intact[l]) unite_link(uf, n, l, i, j);
  });
  return number_fragments(n, uf, m.mass.data());
}

namespace {
Fragments number_fragments(std::size_t n_automata, UnionFind& uf, const float* mass) {

  // Scanning automata in index order meets each root first at its smallest member, which is the
  // tie-break key, so a stable sort by mass alone gives the documented order. The masses are summed in
  // the same scan, in automaton order: the same sums (to the last bit) whatever the link order.
  std::vector<std::uint32_t> root_of(n_automata);
  std::vector<std::int32_t> slot(n_automata, -1);  // root -> position in `roots`
  std::vector<std::uint32_t> roots;
  std::vector<double> weight;  // per position in `roots`
  for (std::uint32_t a = 0; a < n_automata; ++a) {
    const std::uint32_t r = uf.find(a);
    root_of[a] = r;
    if (slot[r] < 0) {
      slot[r] = static_cast<std::int32_t>(roots.size());
      roots.push_back(r);
      weight.push_back(0.0);
    }
    weight[static_cast<std::size_t>(slot[r])] += mass ? static_cast<double>(mass[a]) : 1.0;
  }
  std::vector<std::uint32_t> order(roots.size());
  std::iota(order.begin(), order.end(), std::uint32_t{0});
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return weight[a] > weight[b]; });
  for (std::size_t k = 0; k < order.size(); ++k) slot[roots[order[k]]] = static_cast<std::int32_t>(k);

  Fragments result;
  result.count = static_cast<std::int32_t>(roots.size());
  result.id.resize(n_automata);
  for (std::size_t a = 0; a < n_automata; ++a) result.id[a] = slot[root_of[a]];
  return result;
}
}  // namespace

std::vector<FragmentInfo> describe_fragments(const Fragments& fragments, const float* mass, const double* xyz,
                                             const double* vel, const float* volume) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  std::vector<FragmentInfo> info(static_cast<std::size_t>(fragments.count));
  // Plain sums back the zero-mass fallback; kept in the same pass to read the arrays once.
  std::vector<std::array<double, 6>> plain(info.size(), std::array<double, 6>{});
  for (std::size_t f = 0; f < info.size(); ++f) {
    info[f].id = static_cast<std::int32_t>(f);
    info[f].box_min = {kInf, kInf, kInf};
    info[f].box_max = {-kInf, -kInf, -kInf};
  }
  for (std::size_t a = 0; a < fragments.id.size(); ++a) {
    FragmentInfo& f = info[static_cast<std::size_t>(fragments.id[a])];
    auto& p = plain[static_cast<std::size_t>(fragments.id[a])];
    const double m = mass[a];
    f.automata += 1;
    f.mass += m;
    if (volume) f.volume += volume[a];
    for (int c = 0; c < 3; ++c) {
      const double x = xyz[3 * a + c];
      const double v = vel[3 * a + c];
      f.centre[c] += m * x;
      f.velocity[c] += m * v;
      p[c] += x;
      p[3 + c] += v;
      f.box_min[c] = std::min(f.box_min[c], x);
      f.box_max[c] = std::max(f.box_max[c], x);
    }
  }
  for (std::size_t k = 0; k < info.size(); ++k) {
    FragmentInfo& f = info[k];
    for (int c = 0; c < 3; ++c) {
      if (f.mass > 0.0) {
        f.centre[c] /= f.mass;
        f.velocity[c] /= f.mass;
      } else {
        f.centre[c] = plain[k][c] / static_cast<double>(f.automata);
        f.velocity[c] = plain[k][3 + c] / static_cast<double>(f.automata);
      }
    }
  }
  return info;
}

std::vector<SizeBin> fragment_size_bins(const std::vector<FragmentInfo>& fragments) {
  std::vector<SizeBin> bins;
  for (const FragmentInfo& f : fragments) {
    std::size_t k = 0;
    while ((std::int64_t{2} << k) <= f.automata) ++k;
    while (bins.size() <= k) {
      SizeBin b;
      b.automata_min = std::int64_t{1} << bins.size();
      b.automata_max = (std::int64_t{2} << bins.size()) - 1;
      bins.push_back(b);
    }
    bins[k].fragments += 1;
    bins[k].mass += f.mass;
  }
  return bins;
}

namespace {
// The bin of a fragment of `size` automata (mass over the mean automaton's): its size rounded to a whole
// number, halves up as fracture_metrics.py's bounds [2^k - 0.5, 2^(k+1) - 0.5) round, and at least 1, so
// that a fragment lighter than half an average automaton (a light material beside a heavy one) is
// counted in the first bin rather than in none.
int mass_bin(double size) {
  const double whole = std::max(1.0, std::floor(size + 0.5));
  // A size past 2^62 automata cannot come from a model (int32 automata ids); the clamp only keeps the
  // conversion defined.
  const auto w = static_cast<std::uint64_t>(std::min(whole, 0x1p62));
  return std::bit_width(w) - 1;
}
}  // namespace

PowerLawFit fit_power_law(const std::vector<MassBin>& bins, double fit_max) {
  PowerLawFit fit;
  fit.fit_max_automata = fit_max;
  std::vector<double> x, y;
  for (const MassBin& b : bins) {
    if (static_cast<double>(b.automata_max) > fit_max) continue;
    ++fit.bins_in_range;
    if (b.count == 0) continue;
    x.push_back(std::log10(b.abscissa));
    y.push_back(std::log10(b.number_density));
  }
  fit.bins_fitted = static_cast<int>(x.size());
  fit.empty_bins_in_range = fit.bins_in_range - fit.bins_fitted;
  if (x.size() < 2) {
    fit.reason = fmt::format("{} non-empty bin{} of at most {:g} automata: a power law needs at least 2",
                             x.size(), x.size() == 1 ? "" : "s", fit_max);
    return fit;
  }
  // Unweighted least squares, y = slope x + intercept (numpy.polyfit(x, y, 1) in fracture_metrics.py).
  const auto n = static_cast<double>(x.size());
  double xm = 0, ym = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    xm += x[i];
    ym += y[i];
  }
  xm /= n;
  ym /= n;
  double sxx = 0, sxy = 0, ss_tot = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    sxx += (x[i] - xm) * (x[i] - xm);
    sxy += (x[i] - xm) * (y[i] - ym);
    ss_tot += (y[i] - ym) * (y[i] - ym);
  }
  // The abscissae of different bins differ, so sxx > 0.
  const double slope = sxy / sxx;
  const double intercept = ym - slope * xm;
  double ss_res = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double r = y[i] - (slope * x[i] + intercept);
    ss_res += r * r;
  }
  fit.tau = -slope;
  fit.log10_prefactor = intercept;
  if (x.size() > 2)
    fit.tau_stderr = std::sqrt(ss_res / (n - 2) / sxx);
  else
    fit.tau_stderr_reason = "2 bins fitted: a line passes through both points, leaving no scatter to estimate "
                            "the error from";
  if (x.size() == 2)
    fit.r2_reason = "2 bins fitted: a line passes through both points, so R^2 = 1 says nothing";
  else if (ss_tot > 0)
    fit.r2 = 1.0 - ss_res / ss_tot;
  else
    fit.r2_reason = "every fitted bin has the same density: R^2 is undefined";
  fit.m_first = std::pow(10.0, x.front());
  fit.m_last = std::pow(10.0, x.back());
  fit.decades = x.back() - x.front();
  return fit;
}

MassDistribution fragment_mass_distribution(const std::vector<FragmentInfo>& fragments) {
  MassDistribution d;
  d.fragments = static_cast<std::int64_t>(fragments.size());
  for (const FragmentInfo& f : fragments) {
    d.automata += f.automata;
    d.mass += f.mass;
  }
  if (d.automata == 0 || !(d.mass > 0)) {
    d.reason = d.automata == 0 ? "no automata" : "the automata have no mass";
    return d;
  }
  d.automaton_mass = d.mass / static_cast<double>(d.automata);
  d.tenth = static_cast<double>(d.automata) / 10.0;
  std::vector<int> bin_of(fragments.size());
  int kmax = 0;
  const FragmentInfo* heaviest = &fragments.front();
  for (std::size_t i = 0; i < fragments.size(); ++i) {
    const FragmentInfo& f = fragments[i];
    bin_of[i] = mass_bin(f.mass / d.automaton_mass);
    kmax = std::max(kmax, bin_of[i]);
    if (f.mass > heaviest->mass) heaviest = &f;
    // Classes by automata count, as fracture_metrics.py draws them.
    FragmentClass& c = f.automata == 1                                      ? d.singles
                       : f.automata <= 9                                    ? d.small
                       : static_cast<double>(f.automata) <= d.tenth ? d.mid
                                                                            : d.above_tenth;
    c.count += 1;
    c.mass_share += f.mass;
  }
  for (FragmentClass* c : {&d.singles, &d.small, &d.mid, &d.above_tenth}) c->mass_share /= d.mass;
  d.largest_automata = heaviest->automata;
  d.largest_mass_share = heaviest->mass / d.mass;
  d.bins.resize(static_cast<std::size_t>(kmax) + 1);
  for (int k = 0; k <= kmax; ++k) {
    MassBin& b = d.bins[static_cast<std::size_t>(k)];
    b.k = k;
    b.automata_min = std::int64_t{1} << k;
    b.automata_max = (std::int64_t{2} << k) - 1;
    b.abscissa = std::sqrt(static_cast<double>(b.automata_min) * static_cast<double>(b.automata_max));
  }
  for (std::size_t i = 0; i < fragments.size(); ++i) {
    MassBin& b = d.bins[static_cast<std::size_t>(bin_of[i])];
    b.count += 1;
    b.mass_share += fragments[i].mass;
  }
  for (MassBin& b : d.bins) {
    b.number_density = static_cast<double>(b.count) / static_cast<double>(b.automata_min);
    b.mass_share /= d.mass;
  }
  d.fit = fit_power_law(d.bins, d.tenth);
  if (d.singles.count == d.fragments && d.fit.tau) {
    // Rubble alone: the bins above the first hold single automata heavier than the mean (a random
    // lattice's cells differ in volume), and a line through them would fit the cells' spread.
    PowerLawFit none;
    none.fit_max_automata = d.fit.fit_max_automata;
    none.bins_in_range = d.fit.bins_in_range;
    none.empty_bins_in_range = d.fit.bins_in_range;
    none.reason = "every fragment is a single automaton: the spread of their masses is the lattice cells', not a "
                  "distribution of fragments";
    d.fit = none;
  }
  return d;
}

}  // namespace mca::analysis
