// Uniform grid: every pair closer than a cutoff <= cell_size must be found, compared with an O(N^2)
// search. The point sets aim at the grid's weak spots: floor() of negative coordinates, hashed cells
// that collide, points on or next to cell faces, and coincident points.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/math.hpp"
#include "grid/uniform_grid.hpp"

namespace {

using mca::DVec3;
using Pairs = std::set<std::pair<std::size_t, std::size_t>>;

double dist2(DVec3 a, DVec3 b) {
  const double dx = a.x - b.x, dy = a.y - b.y, dz = a.z - b.z;
  return dx * dx + dy * dy + dz * dz;
}

Pairs brute_force(const std::vector<DVec3>& x, double cutoff) {
  Pairs out;
  for (std::size_t i = 0; i < x.size(); ++i)
    for (std::size_t j = i + 1; j < x.size(); ++j)
      if (dist2(x[i], x[j]) < cutoff * cutoff) out.emplace(i, j);
  return out;
}

struct GridResult {
  Pairs pairs;
  std::size_t repeats = 0;       // an index reported twice for one query
  std::size_t out_of_range = 0;  // an index >= n
  std::size_t far = 0;           // candidates outside the 27 cells: only hash collisions bring these
};

GridResult through_grid(const std::vector<DVec3>& x, double cell, double cutoff) {
  mca::UniformGrid grid;
  grid.build(x.data(), x.size(), cell);
  GridResult r;
  // Beyond 2 sqrt(3) cells a point cannot be in any of the 27 cells around the query.
  const double far2 = 12.0 * cell * cell * (1 + 1e-9);
  std::vector<std::size_t> last_query(x.size(), SIZE_MAX);
  for (std::size_t i = 0; i < x.size(); ++i) {
    grid.for_each_candidate(x[i], [&](std::uint32_t j) {
      if (j >= x.size()) {
        ++r.out_of_range;
        return;
      }
      if (last_query[j] == i) ++r.repeats;
      last_query[j] = i;
      const double d2 = dist2(x[i], x[j]);
      if (d2 > far2) ++r.far;
      if (j > i && d2 < cutoff * cutoff) r.pairs.emplace(i, j);
    });
  }
  return r;
}

// The pairs the brute force finds that the grid misses, and the reverse, for the failure message.
std::string difference(const Pairs& expected, const Pairs& got) {
  std::string s;
  auto add = [&](const char* what, const std::pair<std::size_t, std::size_t>& p) {
    s += what + (" (" + std::to_string(p.first) + ", " + std::to_string(p.second) + ") ");
  };
  int shown = 0;
  for (const auto& p : expected)
    if (!got.count(p) && shown++ < 10) add("missed", p);
  for (const auto& p : got)
    if (!expected.count(p) && shown++ < 20) add("extra", p);
  return s;
}

void expect_same_pairs(const std::vector<DVec3>& x, double cell, double cutoff, GridResult* result = nullptr) {
  const Pairs expected = brute_force(x, cutoff);
  GridResult r = through_grid(x, cell, cutoff);
  EXPECT_EQ(r.repeats, 0u) << "for_each_candidate reported an index twice for one query";
  EXPECT_EQ(r.out_of_range, 0u);
  EXPECT_EQ(r.pairs.size(), expected.size());
  EXPECT_TRUE(r.pairs == expected) << difference(expected, r.pairs);
  if (result) *result = std::move(r);
}

std::vector<DVec3> uniform_points(std::mt19937_64& rng, std::size_t n, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  std::vector<DVec3> x(n);
  for (DVec3& p : x) p = {u(rng), u(rng), u(rng)};
  return x;
}

TEST(UniformGrid, RandomPointsAroundTheOrigin) {
  std::mt19937_64 rng(7);
  // About 4 points per cell, half of them at negative coordinates on each axis.
  const std::vector<DVec3> x = uniform_points(rng, 4000, -5.0, 5.0);
  std::size_t found = 0;
  for (double cutoff : {1.0, 0.7, 0.25}) {
    SCOPED_TRACE(cutoff);
    GridResult r;
    expect_same_pairs(x, 1.0, cutoff, &r);
    found += r.pairs.size();
  }
  EXPECT_GT(found, 10000u);  // the comparison is not vacuous
}

TEST(UniformGrid, SpreadFarBeyondTheCellSizeCollidesInTheHash) {
  std::mt19937_64 rng(11);
  // 2000 scattered points over 4e4 cells per axis plus 60 tight clusters: far more occupied cells than
  // hash buckets can tell apart (the table is about 2n), so distinct cells share buckets.
  std::vector<DVec3> x = uniform_points(rng, 2000, -1e4, 1e4);
  std::uniform_real_distribution<double> centre(-1e4, 1e4), offset(-1.0, 1.0);
  for (int c = 0; c < 60; ++c) {
    const DVec3 o = {centre(rng), centre(rng), centre(rng)};
    for (int k = 0; k < 40; ++k) x.push_back({o.x + offset(rng), o.y + offset(rng), o.z + offset(rng)});
  }
  GridResult r;
  expect_same_pairs(x, 0.5, 0.5, &r);
  EXPECT_GT(r.pairs.size(), 1000u);
  // Candidates from outside the 27 cells prove that colliding buckets were exercised (and filtered).
  EXPECT_GT(r.far, 0u);
  RecordProperty("pairs", static_cast<int>(r.pairs.size()));
  RecordProperty("far_candidates", static_cast<int>(r.far));

  // The same with the cutoff well below the cell size.
  expect_same_pairs(x, 0.5, 0.2);
}

TEST(UniformGrid, CubicLatticeJustInsideTheCutoff) {
  // Spacing a little under the cutoff: every face neighbour is within range, no diagonal one is, and
  // the lattice points drift across cell faces, so neighbours sit in adjacent cells.
  const double cutoff = 1.0, spacing = cutoff - 1e-6;
  const int n = 14;
  for (const double origin : {0.0, -7.3, -1e3 + 0.5}) {
    SCOPED_TRACE(origin);
    std::vector<DVec3> x;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) x.push_back({origin + i * spacing, origin + j * spacing, origin + k * spacing});
    GridResult r;
    expect_same_pairs(x, cutoff, cutoff, &r);
    EXPECT_EQ(r.pairs.size(), static_cast<std::size_t>(3 * n * n * (n - 1)));  // face neighbours only
  }
}

TEST(UniformGrid, DuplicatePointsAreAllPaired) {
  std::mt19937_64 rng(3);
  // 600 points on 100 distinct positions: coincident points (distance 0) are pairs too.
  const std::vector<DVec3> distinct = uniform_points(rng, 100, -2.0, 2.0);
  std::vector<DVec3> x;
  std::uniform_int_distribution<std::size_t> pick(0, distinct.size() - 1);
  for (int k = 0; k < 600; ++k) x.push_back(distinct[pick(rng)]);
  // Every point in one cell, many times over.
  for (int k = 0; k < 50; ++k) x.push_back({-0.25, -0.25, -0.25});
  GridResult r;
  expect_same_pairs(x, 1.0, 1.0, &r);
  EXPECT_GE(r.pairs.size(), 50u * 49u / 2u);
  expect_same_pairs(x, 1.0, 1e-12);  // only the coincident ones
}

TEST(UniformGrid, QueriesAwayFromThePoints) {
  std::mt19937_64 rng(5);
  const std::vector<DVec3> x = uniform_points(rng, 3000, -4.0, 4.0);
  mca::UniformGrid grid;
  grid.build(x.data(), x.size(), 0.8);
  std::vector<int> seen(x.size(), -1);
  const std::vector<DVec3> queries = uniform_points(rng, 500, -5.0, 5.0);
  for (int q = 0; q < static_cast<int>(queries.size()); ++q) {
    const DVec3 p = queries[q];
    std::size_t within = 0, repeats = 0;
    grid.for_each_candidate(p, [&](std::uint32_t j) {
      if (seen[j] == q) ++repeats;
      seen[j] = q;
      if (dist2(p, x[j]) < 0.8 * 0.8) ++within;
    });
    std::size_t expected = 0;
    for (const DVec3& y : x) expected += dist2(p, y) < 0.8 * 0.8;
    ASSERT_EQ(within, expected) << "query " << q;
    ASSERT_EQ(repeats, 0u) << "query " << q;
  }
}

TEST(UniformGrid, EmptyAndRebuilt) {
  mca::UniformGrid grid;
  grid.build(nullptr, 0, 1.0);
  int calls = 0;
  grid.for_each_candidate({0, 0, 0}, [&](std::uint32_t) { ++calls; });
  EXPECT_EQ(calls, 0);

  // A rebuild with other points and another cell size forgets the first build.
  std::mt19937_64 rng(9);
  const std::vector<DVec3> a = uniform_points(rng, 500, -3.0, 3.0);
  grid.build(a.data(), a.size(), 1.0);
  const std::vector<DVec3> b = uniform_points(rng, 200, 10.0, 12.0);
  grid.build(b.data(), b.size(), 0.5);
  EXPECT_EQ(grid.cell_size(), 0.5);
  std::size_t found = 0;
  for (std::size_t i = 0; i < b.size(); ++i) {
    grid.for_each_candidate(b[i], [&](std::uint32_t j) {
      ASSERT_LT(j, b.size());
      found += j > i && dist2(b[i], b[j]) < 0.25;
    });
  }
  EXPECT_EQ(found, brute_force(b, 0.5).size());
}

}  // namespace

// for_each_candidate_above(p, i) reports exactly the candidates j > i that for_each_candidate(p) reports,
// each once: with every point binned, and with an ascending subset of ids (as the contact list bins its
// exposed automata), over scattered points whose cells share hash buckets and tight clusters.
TEST(UniformGrid, CandidatesAboveAreTheCandidatesAboveTheQuery) {
  std::mt19937_64 rng(19);
  std::vector<DVec3> x = uniform_points(rng, 3000, -3.0, 3.0);
  const std::vector<DVec3> spread = uniform_points(rng, 1000, -1e4, 1e4);
  x.insert(x.end(), spread.begin(), spread.end());
  std::vector<std::uint32_t> some;
  for (std::uint32_t a = 0; a < x.size(); ++a)
    if (rng() % 3) some.push_back(a);
  std::size_t compared = 0;
  for (const bool subset : {false, true}) {
    SCOPED_TRACE(subset ? "a subset of ids" : "every point");
    mca::UniformGrid grid;
    grid.build(x.data(), subset ? some.size() : x.size(), 0.5, subset ? some.data() : nullptr);
    for (std::uint32_t i = 0; i < x.size(); ++i) {
      std::vector<std::uint32_t> all, above;
      grid.for_each_candidate(x[i], [&](std::uint32_t j) {
        if (j > i) all.push_back(j);
      });
      grid.for_each_candidate_above(x[i], i, [&](std::uint32_t j) { above.push_back(j); });
      std::sort(all.begin(), all.end());
      std::sort(above.begin(), above.end());
      ASSERT_EQ(above, all) << "query " << i;
      compared += all.size();
    }
  }
  EXPECT_GT(compared, 20000u);  // not vacuous
}

// for_each_near_above(p, i, cells, reach) (the contact search for the sites of faces) reports every point
// j > i nearer to p than reach cells, skipping only the cells of the (2 cells + 1)^3 that lie farther: at
// reaches just inside and beyond a whole number of cells, around the origin (floor of negative
// coordinates) and a million cells out, and not every cell (the corners of 5 x 5 x 5 at sqrt(3) cells).
TEST(UniformGrid, NearAboveFindsEveryPointWithinTheReach) {
  std::mt19937_64 rng(23);
  const double cell = 0.5;
  for (const double centre : {0.0, -3.3e5, 5e5}) {
    std::vector<DVec3> x = uniform_points(rng, 4000, centre - 4.0, centre + 4.0);
    mca::UniformGrid grid;
    grid.build(x.data(), x.size(), cell);
    for (const double reach_cells : {1.7330, 1.999, 2.0, 1.0}) {
      SCOPED_TRACE(testing::Message() << "centre " << centre << ", reach " << reach_cells);
      const int cells = static_cast<int>(std::ceil(reach_cells));
      const double reach = reach_cells * cell;
      std::size_t found = 0, visited = 0, all = 0;
      for (std::uint32_t i = 0; i < x.size(); ++i) {
        std::set<std::uint32_t> near;
        grid.for_each_near_above(x[i], i, cells, reach_cells, [&](std::uint32_t j) {
          ASSERT_GT(j, i);
          near.insert(j);
          ++visited;
        });
        // (Every point of the full block, for the share the skipped cells save.)
        grid.for_each_near_above(x[i], i, cells, 1e9, [&](std::uint32_t) { ++all; });
        for (std::uint32_t j = i + 1; j < x.size(); ++j) {
          if (!(dist2(x[i], x[j]) < reach * reach)) continue;
          ASSERT_TRUE(near.count(j)) << "query " << i << " misses " << j << " at " << std::sqrt(dist2(x[i], x[j]));
          ++found;
        }
      }
      EXPECT_GT(found, 5000u);  // not vacuous
      // The skipped cells: for a reach of sqrt(3) cells, about 61 of the 125 cells are visited.
      if (cells == 2 && reach_cells < 1.8) {
        EXPECT_LT(static_cast<double>(visited), 0.7 * static_cast<double>(all));
      }
    }
  }
}
