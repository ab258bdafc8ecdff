#include "analysis/fragments.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <numeric>
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
  Fragments label(std::size_t n) const { return label_fragments(n, i.data(), j.data(), intact.data(), i.size()); }
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

TEST(Fragments, IsolatedAutomataAreTheirOwnFragments) {
  Links links;
  links.add(0, 1, false);
  links.add(1, 2, false);
  const Fragments f = links.label(4);
  ASSERT_EQ(f.count, 4);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{0, 1, 2, 3}));
}

TEST(Fragments, NoLinks) {
  const Fragments f = label_fragments(3, nullptr, nullptr, nullptr, 0);
  EXPECT_EQ(f.count, 3);
  EXPECT_EQ(f.id, (std::vector<std::int32_t>{0, 1, 2}));
  const Fragments empty = label_fragments(0, nullptr, nullptr, nullptr, 0);
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
  const Fragments f = links.label(20);
  std::vector<float> mass(20), xyz(60), vel(60);
  for (std::size_t a = 0; a < 20; ++a) {
    mass[a] = 0.5f + 0.25f * static_cast<float>(a % 5);
    for (int c = 0; c < 3; ++c) xyz[3 * a + c] = static_cast<float>(a) * 0.1f + static_cast<float>(c);
  }
  const auto info = describe_fragments(f, mass.data(), xyz.data(), vel.data());
  ASSERT_EQ(info.size(), static_cast<std::size_t>(f.count));
  double total = 0.0, described = 0.0;
  std::int64_t automata = 0;
  for (float m : mass) total += m;
  for (std::size_t k = 0; k < info.size(); ++k) {
    EXPECT_EQ(info[k].id, static_cast<std::int32_t>(k));
    if (k > 0) {
      EXPECT_GE(info[k - 1].automata, info[k].automata);
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
  const std::vector<float> xyz{0, 0, 0, 4, 0, 0, 1, 2, 3};
  const std::vector<float> vel{2, 0, 0, -2, 0, 0, 0, 0, 5};
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
