#include "grid/uniform_grid.hpp"

namespace mca {

void UniformGrid::build(const DVec3* x, std::size_t n, double cell_size, const std::uint32_t* ids) {
  cell_ = cell_size;
  inv_cell_ = 1.0 / cell_size;
  std::size_t table = 64;
  while (table < 2 * n) table *= 2;
  mask_ = table - 1;
  begin_.assign(table + 1, 0);
  std::vector<std::uint32_t> bucket_of(n);
  for (std::size_t a = 0; a < n; ++a) {
    const DVec3& p = x[ids ? ids[a] : a];
    bucket_of[a] = bucket(cell_of(p.x), cell_of(p.y), cell_of(p.z));
    ++begin_[bucket_of[a] + 1];
  }
  for (std::size_t b = 0; b < table; ++b) begin_[b + 1] += begin_[b];
  items_.resize(n);
  std::vector<std::uint32_t> fill(begin_.begin(), begin_.end() - 1);
  // Serial fill keeps each bucket in index order: the neighbour lists come out the same every run.
  for (std::size_t a = 0; a < n; ++a) items_[fill[bucket_of[a]]++] = ids ? ids[a] : static_cast<std::uint32_t>(a);
}

}  // namespace mca
