// Strength classes: the shares match P(c), draws are reproducible and keyed only as documented, and
// grains make neighbours share a class.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <mca/scene.hpp>

#include "core/math.hpp"
#include "lattice/heterogeneity.hpp"

namespace {

using mca::lattice::assign_classes;
using mca::lattice::class_from_uniform;
using Shares = std::array<double, 4>;

// A simple-cubic block of nx x ny x nz points of spacing d centred at the origin (so half of every
// coordinate range is negative), x fastest: index = i + nx (j + ny k).
struct Block {
  int nx, ny, nz;
  double d;
  std::vector<mca::Vec3> points;

  Block(int nx_, int ny_, int nz_, double d_) : nx(nx_), ny(ny_), nz(nz_), d(d_) {
    points.reserve(static_cast<std::size_t>(nx) * ny * nz);
    for (int k = 0; k < nz; ++k)
      for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
          points.push_back({static_cast<float>((i - 0.5 * (nx - 1)) * d), static_cast<float>((j - 0.5 * (ny - 1)) * d),
                            static_cast<float>((k - 0.5 * (nz - 1)) * d)});
  }
  std::size_t index(int i, int j, int k) const { return static_cast<std::size_t>(i + nx * (j + ny * k)); }
  double volume() const { return nx * ny * nz * d * d * d; }
};

Shares fractions(const std::vector<std::uint8_t>& classes) {
  Shares f{};
  for (std::uint8_t c : classes) {
    EXPECT_TRUE(c >= 1 && c <= 4) << "class " << int(c);
    if (c >= 1 && c <= 4) f[c - 1] += 1.0;
  }
  for (double& v : f) v /= static_cast<double>(classes.size());
  return f;
}

// Share of face-neighbour pairs (along x, y and z) whose two automata are in the same class.
double equal_neighbour_fraction(const Block& b, const std::vector<std::uint8_t>& cls) {
  std::size_t same = 0, pairs = 0;
  for (int k = 0; k < b.nz; ++k)
    for (int j = 0; j < b.ny; ++j)
      for (int i = 0; i < b.nx; ++i) {
        const std::uint8_t c = cls[b.index(i, j, k)];
        auto pair_with = [&](std::size_t other) {
          same += c == cls[other];
          ++pairs;
        };
        if (i + 1 < b.nx) pair_with(b.index(i + 1, j, k));
        if (j + 1 < b.ny) pair_with(b.index(i, j + 1, k));
        if (k + 1 < b.nz) pair_with(b.index(i, j, k + 1));
      }
  return static_cast<double>(same) / static_cast<double>(pairs);
}

// Probability that two independent draws land in the same class.
double sum_of_squares(const Shares& p) { return p[0] * p[0] + p[1] * p[1] + p[2] * p[2] + p[3] * p[3]; }

mca::HeterogeneityDef het_of(const Shares& shares, double grain_size = 0.0) {
  mca::HeterogeneityDef h;
  h.shares = shares;
  h.preset = "custom";
  h.grain_size = grain_size;
  return h;
}

mca::HeterogeneityDef preset(const std::string& name, double grain_size = 0.0) {
  mca::HeterogeneityDef h;
  EXPECT_TRUE(mca::heterogeneity_preset(name, h.shares)) << name;
  h.preset = name;
  h.grain_size = grain_size;
  return h;
}

TEST(Heterogeneity, ClassFromUniformCutsAtTheCumulativeShares) {
  const Shares low = {0, 0, 0.1, 0.9};
  EXPECT_EQ(class_from_uniform(0.0, low), 3);  // classes with zero share are skipped
  EXPECT_EQ(class_from_uniform(0.0999, low), 3);
  EXPECT_EQ(class_from_uniform(0.1, low), 4);
  EXPECT_EQ(class_from_uniform(0.999999, low), 4);

  const Shares high = {0.2, 0.25, 0.25, 0.3};
  EXPECT_EQ(class_from_uniform(0.19, high), 1);
  EXPECT_EQ(class_from_uniform(0.21, high), 2);
  EXPECT_EQ(class_from_uniform(0.46, high), 3);
  EXPECT_EQ(class_from_uniform(0.71, high), 4);

  // Shares that sum to a little under 1 (validate_scene allows 1e-6): u above the sum takes the last
  // class with a share, never a class with none.
  const Shares short_sum = {0.3, 0.3, 0.3999995, 0};
  EXPECT_EQ(class_from_uniform(0.9999999, short_sum), 3);
}

TEST(Heterogeneity, PresetSharesOverOneHundredThousandAutomata) {
  const Block b(50, 50, 40, 0.01);
  ASSERT_EQ(b.points.size(), 100000u);
  // One percentage point is about 7 standard deviations of a share estimated from 1e5 independent
  // draws (sqrt(0.25 * 0.75 / 1e5) = 0.14 %).
  for (const char* name : {"none", "low", "medium", "high"}) {
    SCOPED_TRACE(name);
    const mca::HeterogeneityDef h = preset(name);
    const Shares f = fractions(assign_classes(b.points, h, 1, 0));
    for (int c = 0; c < 4; ++c) {
      EXPECT_NEAR(f[c], h.shares[c], 0.01) << "class " << c + 1;
      if (h.shares[c] == 0.0) {
        EXPECT_EQ(f[c], 0.0) << "class " << c + 1 << " has no share but was drawn";
      }
    }
  }
}

TEST(Heterogeneity, CustomShares) {
  const Block b(50, 50, 40, 0.01);
  const Shares shares = {0.05, 0.4, 0.0, 0.55};
  const Shares f = fractions(assign_classes(b.points, het_of(shares), 42, 3));
  for (int c = 0; c < 4; ++c) EXPECT_NEAR(f[c], shares[c], 0.01) << "class " << c + 1;
  EXPECT_EQ(f[2], 0.0);
}

TEST(Heterogeneity, SeedAndObjectKeyTheDraws) {
  const Block b(30, 30, 30, 0.01);
  for (const double grain : {0.0, 0.04}) {
    SCOPED_TRACE(grain);
    const mca::HeterogeneityDef h = preset("high", grain);
    const auto a = assign_classes(b.points, h, 1234, 0);
    EXPECT_EQ(a, assign_classes(b.points, h, 1234, 0));

    // Two independent class fields agree on a point with probability sum P(c)^2 = 0.255 (for grains
    // the agreement is per grain, so the same on average); well over half must differ.
    auto differing = [&](const std::vector<std::uint8_t>& other) {
      std::size_t n = 0;
      for (std::size_t k = 0; k < a.size(); ++k) n += a[k] != other[k];
      return static_cast<double>(n) / static_cast<double>(a.size());
    };
    EXPECT_NEAR(differing(assign_classes(b.points, h, 1235, 0)), 1.0 - sum_of_squares(h.shares), 0.05);
    EXPECT_NEAR(differing(assign_classes(b.points, h, 1234, 1)), 1.0 - sum_of_squares(h.shares), 0.05);
  }
}

// Independent draws are keyed by (seed, object, point index) only: the coordinates do not matter, and a
// prefix of the points keeps its classes. Reordering the points reorders nothing: index k always gets
// the k-th draw.
TEST(Heterogeneity, IndependentDrawsDependOnlyOnTheIndex) {
  const Block b(40, 40, 40, 0.01);
  const mca::HeterogeneityDef h = preset("high");
  const auto all = assign_classes(b.points, h, 7, 2);

  const std::vector<mca::Vec3> prefix(b.points.begin(), b.points.begin() + 1000);
  const auto first = assign_classes(prefix, h, 7, 2);
  EXPECT_TRUE(std::equal(first.begin(), first.end(), all.begin()));

  std::vector<mca::Vec3> moved = b.points;
  for (mca::Vec3& p : moved) p = p * 3.0f + mca::Vec3{100.0f, -50.0f, 7.0f};
  EXPECT_EQ(assign_classes(moved, h, 7, 2), all);
}

// Grain classes are keyed by (seed, object, grain cube) and the point's position: any subset of the
// points, in any order, keeps each point's class.
TEST(Heterogeneity, GrainClassesDependOnlyOnThePosition) {
  const Block b(40, 40, 40, 0.01);
  const mca::HeterogeneityDef h = preset("medium", 0.035);
  const auto all = assign_classes(b.points, h, 7, 2);

  std::vector<mca::Vec3> subset;
  std::vector<std::size_t> picked;
  for (std::size_t k = b.points.size(); k-- > 0;) {
    if (k % 7 == 3 || k % 11 == 0) {  // every 7th and 11th point, backwards
      subset.push_back(b.points[k]);
      picked.push_back(k);
    }
  }
  const auto some = assign_classes(subset, h, 7, 2);
  ASSERT_EQ(some.size(), picked.size());
  for (std::size_t s = 0; s < some.size(); ++s) ASSERT_EQ(some[s], all[picked[s]]) << "point " << picked[s];
}

// With grains the shares are those of the grains, so the spread is that of G grain draws, not of N
// automaton draws. 80^3 automata of 1 cm with 4 cm grains give G = 0.512 m^3 / (4 cm)^3 = 8000 grains
// (one seed per cube of side grain_size). A share estimated from G grains of unequal size has a standard
// deviation of about sqrt(p (1 - p) / G) sqrt(1 + cv^2), cv being the coefficient of variation of the
// grain volume (below 0.5 for seeds jittered in their cubes, and the cut grains at the block's faces
// add a little): at most 0.0048 * 1.12 = 0.54 percentage points for p = 0.25 (over 60 seeds the measured
// deviations were 0.41 to 0.55 points, the largest error 1.95). Five such deviations, 2.7 points, is the
// tolerance.
TEST(Heterogeneity, GrainsKeepTheSharesAndCorrelateNeighbours) {
  const Block b(80, 80, 80, 0.01);
  const double grain = 0.04;
  const double grains = b.volume() / (grain * grain * grain);
  ASSERT_NEAR(grains, 8000.0, 1.0);

  for (const char* name : {"medium", "high"}) {
    SCOPED_TRACE(name);
    const mca::HeterogeneityDef indep = preset(name);
    const mca::HeterogeneityDef grained = preset(name, grain);
    const auto ci = assign_classes(b.points, indep, 99, 0);
    const auto cg = assign_classes(b.points, grained, 99, 0);

    const Shares f = fractions(cg);
    double worst = 0.0;
    for (int c = 0; c < 4; ++c) {
      worst = std::max(worst, std::fabs(f[c] - grained.shares[c]));
      const double p = grained.shares[c];
      const double tol = 5.0 * std::sqrt(p * (1.0 - p) / grains) * std::sqrt(1.0 + 0.5 * 0.5);
      EXPECT_LE(tol, 0.03);
      EXPECT_NEAR(f[c], p, tol) << "class " << c + 1;
      if (p == 0.0) {
        EXPECT_EQ(f[c], 0.0) << "class " << c + 1 << " has no share but was drawn";
      }
    }

    // Independent draws: a face-neighbour pair agrees with probability sum P(c)^2 (over 1.5e6 pairs the
    // estimate is good to a few 1e-4). Grains: the pair lies in one grain with a probability q of about
    // 1 - S_V d / 2 (S_V ~ 3 / grain, the Voronoi face area per volume), about 0.6 here, and agrees with
    // probability q + (1 - q) sum P(c)^2. Requiring q > 0.4 keeps a wide margin.
    const double theory = sum_of_squares(indep.shares);
    const double fi = equal_neighbour_fraction(b, ci);
    const double fg = equal_neighbour_fraction(b, cg);
    EXPECT_NEAR(fi, theory, 0.005);
    const double q = (fg - theory) / (1.0 - theory);  // estimated share of pairs inside one grain
    EXPECT_GT(q, 0.4) << "equal-class neighbours: grains " << fg << ", independent " << fi << ", theory " << theory;
    RecordProperty(std::string(name) + "_grain_share_error", std::to_string(worst));
    RecordProperty(std::string(name) + "_independent_equal", std::to_string(fi));
    RecordProperty(std::string(name) + "_grain_equal", std::to_string(fg));
  }
}

}  // namespace
