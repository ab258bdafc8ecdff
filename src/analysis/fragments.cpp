#include "analysis/fragments.hpp"

#include "core/model.hpp"

#include <fmt/format.h>

#include <algorithm>
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

}  // namespace mca::analysis
