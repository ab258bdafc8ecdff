#include "analysis/fragments.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <algorithm>
#include <numeric>
#include <random>
#include <vector>

using mca::analysis::describe_fragments;
using mca::analysis::Fragments;
using mca::analysis::label_fragments;

namespace {

struct Links {
  std::vector<std::uint32_t> i, j;
  std::vector<std::uint8_t> intact;
  void add(std::uint32_t a, std::uint32_t b, bool ok = true) {
    i.push_back(a);
    j.push_back(b);
    intact.push_back(ok ? 1 : 0);
  }
  // Equal masses: ordered by automata count.
  Fragments label(std::size_t n) const {
    return label_fragments(n, i.data(), j.data(), intact.data(), i.size(), nullptr);
  }
  Fragments label(const std::vector<float>& mass) const {
    return label_fragments(mass.size(), i.data(), j.data(), intact.data(), i.size(), mass.data());
  }
};

}  // namespace

TEST(Fragments, FullyLinkedBlockIsOneFragment) {
  // 2x2x2 block, index = x + 2y + 4z, links along the 12 edges.
  Links links;
  for (std::uint32_t a = 0; a < 8; ++a)
    for (std::uint32_t bit : {1u, 2u, 4u})
      if (!(a & bit)) links.add(a, a | bit);
  ASSERT_EQ(links.i.size(), 12u);
  const Fragments f = links.label(8);
  EXPECT_EQ(f.count, 1);
  for (std::int32_t id : f.id) EXPECT_EQ(id, 0);
}

TEST(Fragments, ChainWithOneBrokenLinkSplitsInTwoLargestFirst) {
  // 0-1-2-3-4-5-6, link 1-2 broken: {0,1} and {2..6}; the larger one gets id 0.
  Links links;
  for (std::uint32_t a = 0; a < 6; ++a) links.add(a, a + 1, a != 1);
  const Fragments f = links.label(7);
  ASSERT_EQ(f.count, 2);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{1, 1, 0, 0, 0, 0, 0}));
}

TEST(Fragments, EqualSizesOrderedBySmallestIndex) {
  // {3,4} and {0,5} and {1,2}: sizes tie, so the order is by smallest member: {0,5}, {1,2}, {3,4}.
  Links links;
  links.add(4, 3);
  links.add(5, 0);
  links.add(2, 1);
  const Fragments f = links.label(6);
  ASSERT_EQ(f.count, 3);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{0, 1, 1, 2, 2, 0}));
}

TEST(Fragments, ResultDoesNotDependOnLinkOrder) {
  Links forward, backward;
  for (std::uint32_t a = 0; a < 9; ++a) forward.add(a, a + 1, a % 3 != 2);
  for (std::uint32_t a = 9; a-- > 0;) backward.add(a + 1, a, a % 3 != 2);
  const Fragments f = forward.label(10), b = backward.label(10);
  EXPECT_EQ(f.count, b.count);
  EXPECT_EQ(f.id, b.id);
}

TEST(Fragments, OrderedByMassNotByCount) {
  // {0,1,2} of mass 1 each (3 kg) and {3,4} of mass 5 each (10 kg): the pair is the heaviest.
  Links links;
  links.add(0, 1);
  links.add(1, 2);
  links.add(3, 4);
  const Fragments f = links.label(std::vector<float>{1, 1, 1, 5, 5});
  ASSERT_EQ(f.count, 2);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{1, 1, 1, 0, 0}));
  // Without masses, by count.
  EXPECT_EQ(links.label(5).id, (std::vector<std::int32_t>{0, 0, 0, 1, 1}));
}

TEST(Fragments, EqualMassesOrderedBySmallestIndex) {
  // {4,5} (2 + 2) and {0} (4) and {1,2,3} (1 + 2 + 1) weigh the same: order by smallest member.
  Links links;
  links.add(5, 4);
  links.add(1, 2);
  links.add(3, 2);
  const Fragments f = links.label(std::vector<float>{4, 1, 2, 1, 2, 2});
  ASSERT_EQ(f.count, 3);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{0, 1, 1, 1, 2, 2}));
}

TEST(Fragments, MassOrderDoesNotDependOnLinkOrder) {
  // Random chains with random breaks and masses; the links shuffled and flipped give the same labels.
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    const std::size_t n = 40;
    std::vector<float> mass(n);
    for (auto& m : mass) m = static_cast<float>(1 + rng() % 4) * 0.5f;
    Links forward;
    for (std::uint32_t a = 0; a + 1 < n; ++a) forward.add(a, a + 1, rng() % 3 != 0);
    for (int k = 0; k < 10; ++k) forward.add(static_cast<std::uint32_t>(rng() % n), static_cast<std::uint32_t>(rng() % n), rng() % 2);
    Links shuffled;
    std::vector<std::size_t> order(forward.i.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::shuffle(order.begin(), order.end(), rng);
    for (std::size_t k : order) shuffled.add(forward.j[k], forward.i[k], forward.intact[k] != 0);
    const Fragments a = forward.label(mass), b = shuffled.label(mass);
    EXPECT_EQ(a.count, b.count);
    EXPECT_EQ(a.id, b.id);
    // Heaviest first.
    std::vector<double> total(static_cast<std::size_t>(a.count), 0.0);
    for (std::size_t k = 0; k < n; ++k) total[static_cast<std::size_t>(a.id[k])] += mass[k];
    for (std::size_t k = 1; k < total.size(); ++k) EXPECT_GE(total[k - 1], total[k]);
  }
}

TEST(Fragments, IsolatedAutomataAreTheirOwnFragments) {
  Links links;
  links.add(0, 1, false);
  links.add(1, 2, false);
  const Fragments f = links.label(4);
  ASSERT_EQ(f.count, 4);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{0, 1, 2, 3}));
}

TEST(Fragments, NoLinks) {
  const Fragments f = label_fragments(3, nullptr, nullptr, nullptr, 0, nullptr);
  EXPECT_EQ(f.count, 3);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{0, 1, 2}));
  const Fragments empty = label_fragments(0, nullptr, nullptr, nullptr, 0, nullptr);
  EXPECT_EQ(empty.count, 0);
  EXPECT_TRUE(empty.id.empty());
}

TEST(Fragments, LinkPastTheEndThrows) {
  Links links;
  links.add(0, 5);
  EXPECT_THROW(links.label(3), std::out_of_range);
}

TEST(Fragments, MassesAddUpToTotal) {
  Links links;
  for (std::uint32_t a = 0; a + 1 < 20; ++a) links.add(a, a + 1, a % 4 != 0 && a % 7 != 0);
  std::vector<float> mass(20);
  std::vector<double> xyz(60), vel(60);
  for (std::size_t a = 0; a < 20; ++a) {
    mass[a] = 0.5f + 0.25f * static_cast<float>(a % 5);
    for (int c = 0; c < 3; ++c) xyz[3 * a + c] = static_cast<double>(a) * 0.1 + static_cast<double>(c);
  }
  const Fragments f = links.label(mass);
  const auto info = describe_fragments(f, mass.data(), xyz.data(), vel.data());
  ASSERT_EQ(info.size(), static_cast<std::size_t>(f.count));
  double total = 0.0, described = 0.0;
  std::int64_t automata = 0;
  for (float m : mass) total += m;
  for (std::size_t k = 0; k < info.size(); ++k) {
    EXPECT_EQ(info[k].id, static_cast<std::int32_t>(k));
    if (k > 0) {
      EXPECT_GE(info[k - 1].mass, info[k].mass);
    }
    described += info[k].mass;
    automata += info[k].automata;
  }
  EXPECT_DOUBLE_EQ(described, total);
  EXPECT_EQ(automata, 20);
}

TEST(Fragments, CentreVelocityAndBoxOnAHandCase) {
  // Fragment 0: automata 0 (m=1 at x=0, v=+2) and 1 (m=3 at x=4, v=-2), linked.
  // Fragment 1: automaton 2 alone (m=2 at (1,2,3), v=(0,0,5)).
  Links links;
  links.add(0, 1);
  const Fragments f = links.label(3);
  const std::vector<float> mass{1, 3, 2};
  const std::vector<double> xyz{0, 0, 0, 4, 0, 0, 1, 2, 3};
  const std::vector<double> vel{2, 0, 0, -2, 0, 0, 0, 0, 5};
  const auto info = describe_fragments(f, mass.data(), xyz.data(), vel.data());
  ASSERT_EQ(info.size(), 2u);

  EXPECT_EQ(info[0].automata, 2);
  EXPECT_DOUBLE_EQ(info[0].mass, 4.0);
  EXPECT_DOUBLE_EQ(info[0].centre[0], 3.0);   // (1*0 + 3*4) / 4
  EXPECT_DOUBLE_EQ(info[0].velocity[0], -1.0);  // (1*2 + 3*-2) / 4
  EXPECT_DOUBLE_EQ(info[0].box_min[0], 0.0);
  EXPECT_DOUBLE_EQ(info[0].box_max[0], 4.0);
  EXPECT_DOUBLE_EQ(info[0].box_max[1], 0.0);

  EXPECT_EQ(info[1].automata, 1);
  EXPECT_DOUBLE_EQ(info[1].mass, 2.0);
  EXPECT_EQ(info[1].centre, (std::array<double, 3>{1, 2, 3}));
  EXPECT_EQ(info[1].velocity, (std::array<double, 3>{0, 0, 5}));
  EXPECT_EQ(info[1].box_min, info[1].box_max);
}
