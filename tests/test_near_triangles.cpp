// mesh::NearTriangles (the labelled triangles near a point, which part a shell among its fragments): against
// every triangle measured one by one, from random points around triangles of every size (slivers, a few
// much larger than the rest, some of no area), near the origin and 1e5 m from it (where OpenVDB's closest
// point on a triangle, given the coordinates as they are, was off by up to a centimetre).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>
#include <vector>

#include "mesh/near_triangles.hpp"

namespace mca {
namespace {

using mesh::Point;

Point sub(const Point& a, const Point& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot3(const Point& a, const Point& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

double to_segment(const Point& p, const Point& a, const Point& b) {
  const Point ab = sub(b, a), ap = sub(p, a);
  const double l2 = dot3(ab, ab);
  const double t = l2 > 0 ? std::clamp(dot3(ap, ab) / l2, 0.0, 1.0) : 0.0;
  const Point q{a[0] + t * ab[0] - p[0], a[1] + t * ab[1] - p[1], a[2] + t * ab[2] - p[2]};
  return std::sqrt(dot3(q, q));
}

// The distance from p to the triangle abc, written apart from the index's (OpenVDB's): inside the
// triangle's projection, the distance to its plane; else the nearest of its edges.
double to_triangle(const Point& p, const Point& a, const Point& b, const Point& c) {
  const Point ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const Point n{ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2], ab[0] * ac[1] - ab[1] * ac[0]};
  const double n2 = dot3(n, n);
  double best = std::min({to_segment(p, a, b), to_segment(p, b, c), to_segment(p, c, a)});
  if (n2 > 1e-30 * dot3(ab, ab) * dot3(ac, ac)) {
    // Barycentric coordinates of p's projection.
    const double d00 = dot3(ab, ab), d01 = dot3(ab, ac), d11 = dot3(ac, ac), d20 = dot3(ap, ab), d21 = dot3(ap, ac);
    const double den = d00 * d11 - d01 * d01, v = (d11 * d20 - d01 * d21) / den, w = (d00 * d21 - d01 * d20) / den;
    if (v >= 0 && w >= 0 && v + w <= 1) best = std::min(best, std::fabs(dot3(ap, n)) / std::sqrt(n2));
  }
  return best;
}

struct Soup {
  mesh::TriMesh mesh;
  std::vector<std::int32_t> label;
};

// Triangles of edges about 1 cm around `at` in a box of 20 cm, labelled 0 to 4: small ones, slivers of 10
// cm by 0.1 mm, three of 30 cm, and two of no area (a repeated corner, corners on a line).
Soup soup(const Point& at, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.1, 0.1), e(-0.01, 0.01);
  Soup s;
  const auto add = [&](const Point& a, const Point& b, const Point& c, std::int32_t label) {
    const auto base = static_cast<std::uint32_t>(s.mesh.vertices.size());
    for (const Point& p : {a, b, c}) s.mesh.vertices.push_back({at[0] + p[0], at[1] + p[1], at[2] + p[2]});
    s.mesh.faces.push_back({base, base + 1, base + 2});
    s.label.push_back(label);
  };
  for (int k = 0; k < 300; ++k) {
    const Point o{u(rng), u(rng), u(rng)};
    add(o, {o[0] + e(rng), o[1] + e(rng), o[2] + e(rng)}, {o[0] + e(rng), o[1] + e(rng), o[2] + e(rng)}, k % 5);
  }
  for (int k = 0; k < 40; ++k) {  // slivers
    const Point o{u(rng), u(rng), u(rng)}, dir{u(rng), u(rng), u(rng)};
    add(o, {o[0] + dir[0], o[1] + dir[1], o[2] + dir[2]}, {o[0] + 1e-4, o[1], o[2] + 1e-4}, k % 5);
  }
  for (int k = 0; k < 3; ++k) add({-0.15, -0.15, u(rng)}, {0.15, -0.1, u(rng)}, {0.0, 0.15, u(rng)}, k);  // large
  add({0.01, 0.02, 0.03}, {0.01, 0.02, 0.03}, {0.05, 0.0, 0.0}, 1);  // a repeated corner
  add({0.0, 0.0, 0.0}, {0.02, 0.02, 0.02}, {0.05, 0.05, 0.05}, 2);  // on a line
  return s;
}

TEST(NearTriangles, FindsTheNearestOwnAndOtherTrianglesWithinTheirLimits) {
  for (const Point at : {Point{0, 0, 0}, Point{1e5, -2e5, 3e4}}) {
    const Soup s = soup(at, 7);
    for (const double reach : {0.004, 0.02, 0.1}) {
      const mesh::NearTriangles near(s.mesh, s.label, reach);
      std::printf("%zu triangles 1e5 m out: %d, reach %.3f m: cells of %.4f m, %zu listed (%.1f MB)\n", s.label.size(),
                  at[0] != 0, reach, near.cell(), near.entries(), near.bytes() / 1e6);
      std::mt19937 rng(11);
      std::uniform_real_distribution<double> u(-0.2, 0.2), w(0, 1), off(-1.5 * reach, 1.5 * reach);
      int with_own = 0, with_other = 0;
      mesh::NearTriangles::Cursor cursor;
      for (int k = 0; k < 4000; ++k) {
        // Every other point within one and a half reaches of a point of one of its own small triangles
        // (triangle j < 340 has the label j % 5), the rest anywhere.
        const std::int32_t own = k % 5;
        Point p{at[0] + u(rng), at[1] + u(rng), at[2] + u(rng)};
        if (k % 2) {
          const auto& t = s.mesh.faces[static_cast<std::size_t>((k / 2 * 5 + own) % 340)];
          double x = w(rng), y = w(rng);
          if (x + y > 1) x = 1 - x, y = 1 - y;
          for (int c = 0; c < 3; ++c)
            p[c] = s.mesh.vertices[t[0]][c] + x * (s.mesh.vertices[t[1]][c] - s.mesh.vertices[t[0]][c]) +
                   y * (s.mesh.vertices[t[2]][c] - s.mesh.vertices[t[0]][c]) + off(rng);
        }
        const double own_within = (k % 3 + 1) * reach / 3, past_own = reach / 4;
        double own_d = INFINITY, other_all = INFINITY;
        for (std::size_t f = 0; f < s.label.size(); ++f) {
          const auto& t = s.mesh.faces[f];
          const double r = to_triangle(p, s.mesh.vertices[t[0]], s.mesh.vertices[t[1]], s.mesh.vertices[t[2]]);
          (s.label[f] == own ? own_d : other_all) = std::min(s.label[f] == own ? own_d : other_all, r);
        }
        // (A distance within the rounding of its limit may fall either side of it: such points are left out.)
        const auto edge = [&](double v, double limit) { return std::fabs(v - limit) < 1e-6 * reach; };
        const double own_limit = std::min(own_within, reach);
        if (edge(own_d, own_limit)) continue;
        if (own_d > own_limit) own_d = INFINITY;
        const double other_limit = std::min(own_d + past_own, reach);
        if (own_d != INFINITY && edge(other_all, other_limit)) continue;
        const double other_d = own_d != INFINITY && other_all <= other_limit ? other_all : INFINITY;
        const auto got = near.nearest(p, own, own_within, past_own, -1, cursor);
        const double tol = 1e-9 * (1 + std::fabs(at[0]) * 1e-6);
        if (own_d == INFINITY) {
          EXPECT_EQ(got.own, INFINITY) << "point " << k;
        } else {
          ++with_own;
          EXPECT_NEAR(got.own, own_d, tol) << "point " << k;
        }
        if (other_d == INFINITY) {
          EXPECT_EQ(got.other, INFINITY) << "point " << k << " (own " << own_d << ")";
        } else {
          ++with_other;
          EXPECT_NEAR(got.other, other_d, tol) << "point " << k;
        }
      }
      std::printf("  %d of 4,000 points with an own triangle in reach, %d of them with another\n", with_own, with_other);
      EXPECT_GT(with_own, 400);
      EXPECT_GT(with_other, 20);
    }
  }
}

// A grid over a region (a class of a shell's pieces, fragment_meshes.cpp) answers as the whole one from
// points in the region, and finds nothing from points outside it.
TEST(NearTriangles, AGridOverARegionAnswersAsTheWholeInIt) {
  const Soup s = soup({0, 0, 0}, 3);
  const double reach = 0.02;
  mesh::Bounds region;
  region.lo = {-0.05, -0.02, -0.1};
  region.hi = {0.03, 0.04, 0.1};
  const mesh::NearTriangles whole(s.mesh, s.label, reach), part(s.mesh, s.label, reach, &region);
  std::printf("listed: %zu over the whole, %zu over the region\n", whole.entries(), part.entries());
  EXPECT_LT(part.entries(), whole.entries() / 2);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.12, 0.12);
  int inside = 0;
  mesh::NearTriangles::Cursor a, b;
  for (int k = 0; k < 3000; ++k) {
    const Point p{u(rng), u(rng), u(rng)};
    const auto w = whole.nearest(p, k % 5, reach, reach / 4, -1, a), r = part.nearest(p, k % 5, reach, reach / 4, -1, b);
    bool in = true;
    for (int c = 0; c < 3; ++c) in = in && p[c] >= region.lo[c] && p[c] <= region.hi[c];
    if (in) {
      ++inside;
      EXPECT_EQ(r.own, w.own) << "point " << k;
      EXPECT_EQ(r.other, w.other) << "point " << k;
    }
  }
  EXPECT_GT(inside, 50);
}

// `deep`: where only the own label's triangles lie near the point's cell, the first own triangle found
// within it answers (the point is deeper than that); in a cell with others near, the nearest is found.
TEST(NearTriangles, AnOwnTriangleWithinDeepAnswersWhereNoOtherIsNear) {
  mesh::TriMesh m;
  m.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0.01}, {1, 0, 0.01}, {0, 1, 0.01}, {5, 5, 0}, {6, 5, 0}, {5, 6, 0}};
  m.faces = {{0, 1, 2}, {3, 4, 5}, {6, 7, 8}};
  const mesh::NearTriangles near(m, {0, 0, 1}, 0.1);
  const Point p{0.2, 0.2, 0.004};
  const auto exact = near.nearest(p, 0);
  EXPECT_NEAR(exact.own, 0.004, 1e-12);
  EXPECT_EQ(exact.other, INFINITY);
  mesh::NearTriangles::Cursor c;
  const auto deep = near.nearest(p, 0, 1.0, 1.0, 0.05, c);
  EXPECT_LE(deep.own, 0.006 + 1e-12);
  EXPECT_GE(deep.own, 0.004 - 1e-12);
  // Label 1's point near its own triangle, far from label 0's.
  EXPECT_NEAR(near.nearest({5.2, 5.2, 0.03}, 1).own, 0.03, 1e-12);
  EXPECT_EQ(near.nearest({5.2, 5.2, 0.03}, 0).own, INFINITY);
  EXPECT_THROW(mesh::NearTriangles(m, {0, 1}, 0.1), std::invalid_argument);
  EXPECT_THROW(mesh::NearTriangles(m, {0, 0, 1}, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace mca
