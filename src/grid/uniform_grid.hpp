#pragma once
// Uniform grid for the neighbour search (paper sec. 5.2): points are binned by cell with a counting
// sort; cells are hashed into a table of about twice the point count, so fragments flying far apart
// cost no memory. A query visits the 27 cells around a point and skips hash buckets already visited,
// so every candidate is reported once. Cell indices use floor, so negative coordinates work.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/math.hpp"

namespace mca {

class UniformGrid {
 public:
  // cell_size must be >= the largest interaction distance queried. With ids, only those points are
  // binned (and reported by their id); without, points 0..n-1.
  void build(const DVec3* x, std::size_t n, double cell_size, const std::uint32_t* ids = nullptr);

  // Calls f(j) for every point j in the 27 cells around p (each at most once; includes far ones).
  template <class F>
  void for_each_candidate(DVec3 p, F&& f) const {
    for_each_bucket(p, [&](std::uint32_t b) {
      for (std::uint32_t k = begin_[b]; k < begin_[b + 1]; ++k) f(items_[k]);
    });
  }

  // Calls f(j) for every point j > i in the 27 cells around p (each at most once; includes far ones). A
  // bucket holds its points in the order build() was given them, ascending when its ids are (or when
  // there are none), and is read from its end down to the first point <= i: so ids must ascend.
  template <class F>
  void for_each_candidate_above(DVec3 p, std::uint32_t i, F&& f) const {
    for_each_bucket(p, [&](std::uint32_t b) {
      for (std::uint32_t k = begin_[b + 1]; k > begin_[b];) {
        if (items_[--k] <= i) break;
        f(items_[k]);
      }
    });
  }

  // Calls f(j) for every point j > i in the cells of the (2 cells + 1)^3 around p that lie nearer to p
  // than reach_cells cells (includes far ones; a point may be reported more than once, where two cells
  // share a bucket). Ids must ascend, as above.
  template <class F>
  void for_each_near_above(DVec3 p, std::uint32_t i, int cells, double reach_cells, F&& f) const {
    const std::int64_t c[3] = {cell_of(p.x), cell_of(p.y), cell_of(p.z)};
    for_each_cell_within(grid_fraction(p.x, inv_cell_), grid_fraction(p.y, inv_cell_), grid_fraction(p.z, inv_cell_),
                         cells, reach_cells, [&](int dx, int dy, int dz) {
                           const std::uint32_t b = bucket(c[0] + dx, c[1] + dy, c[2] + dz);
                           for (std::uint32_t k = begin_[b + 1]; k > begin_[b];) {
                             if (items_[--k] <= i) break;
                             f(items_[k]);
                           }
                         });
  }

  double cell_size() const { return cell_; }

 private:
  // Calls f(b) for each hash bucket b of the 27 cells around p, once: two cells may share a bucket. A bit
  // per bucket's low 6 bits rules out most repeats at once; only a bit already set needs the list.
  template <class F>
  void for_each_bucket(DVec3 p, F&& f) const {
    const std::int64_t c[3] = {cell_of(p.x), cell_of(p.y), cell_of(p.z)};
    std::uint32_t seen[27];
    int n_seen = 0;
    std::uint64_t seen_bits = 0;
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const std::uint32_t b = bucket(c[0] + dx, c[1] + dy, c[2] + dz);
          const std::uint64_t bit = std::uint64_t{1} << (b & 63);
          if (seen_bits & bit) {
            bool dup = false;
            for (int s = 0; s < n_seen; ++s) dup = dup || seen[s] == b;
            if (dup) continue;
          }
          seen_bits |= bit;
          seen[n_seen++] = b;
          f(b);
        }
  }
  // (Clamped to +-2^52 cells: grid_cell, core/math.hpp.)
  std::int64_t cell_of(double v) const { return grid_cell(v, inv_cell_); }
  std::uint32_t bucket(std::int64_t i, std::int64_t j, std::int64_t k) const {
    const std::uint64_t h = static_cast<std::uint64_t>(i) * 73856093ull ^ static_cast<std::uint64_t>(j) * 19349663ull ^
                            static_cast<std::uint64_t>(k) * 83492791ull;
    return static_cast<std::uint32_t>(h & mask_);
  }

  double cell_ = 1, inv_cell_ = 1;
  std::uint64_t mask_ = 0;
  std::vector<std::uint32_t> begin_, items_;
};

}  // namespace mca
