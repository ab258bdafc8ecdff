// mesh::simplify_flat (a closed mesh's flat parts merged into large triangles, CGAL's edge collapse): a
// box sampled as a fragment's mesh is, two triangles to a voxel on every side, turned and moved away from
// the origin, becomes a few large triangles on the same six planes, its volume and area kept; curved parts
// keep every vertex; a mesh it cannot take is left as it was; a poll that throws stops it. And
// mesh::feature_point (where a voxel's crossings' planes meet: a fragment mesh's sharp edges and corners).
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <set>
#include <vector>

#include "mesh/mesh.hpp"
#include "mesh/simplify.hpp"
#include "mesh/voxelize.hpp"
#include "mesh_fixtures.hpp"

namespace mca {
namespace {

using mesh::Point;

// The surface of the cube [0, n]^3 in steps of `a`, two triangles to a unit square, outward, welded; the
// vertices inside each side moved within it by up to `jitter` steps (irregular, still flat).
mesh::TriMesh sampled_box(int n, double a, double jitter, unsigned seed) {
  mesh::TriMesh m;
  std::map<std::array<int, 3>, std::uint32_t> index;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-jitter, jitter);
  const auto vertex = [&](std::array<int, 3> k) {
    const auto [it, added] = index.try_emplace(k, static_cast<std::uint32_t>(m.vertices.size()));
    if (added) {
      Point p{a * k[0], a * k[1], a * k[2]};
      // Inside a side: no coordinate but the side's own at 0 or n.
      int on_bounds = 0;
      for (int c = 0; c < 3; ++c) on_bounds += k[c] == 0 || k[c] == n;
      if (on_bounds == 1)
        for (int c = 0; c < 3; ++c)
          if (k[c] != 0 && k[c] != n) p[c] += a * u(rng);
      m.vertices.push_back(p);
    }
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const int ua = (axis + 1) % 3, va = (axis + 2) % 3;
      for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
          std::array<std::uint32_t, 4> q;
          const int corner[4][2] = {{i, j}, {i + 1, j}, {i + 1, j + 1}, {i, j + 1}};
          for (int c = 0; c < 4; ++c) {
            std::array<int, 3> k{};
            k[axis] = side * n;
            k[ua] = corner[c][0];
            k[va] = corner[c][1];
            q[c] = vertex(k);
          }
          if (side == 0) std::swap(q[1], q[3]);
          m.faces.push_back({q[0], q[1], q[2]});
          m.faces.push_back({q[0], q[2], q[3]});
        }
    }
  return m;
}

// Turned by a rotation about a slanted axis and moved by `shift`.
void place(mesh::TriMesh& m, const Point& shift) {
  const double c = std::cos(0.7), s = std::sin(0.7);
  const double k[3] = {1 / std::sqrt(3.0), 1 / std::sqrt(3.0), 1 / std::sqrt(3.0)};
  for (Point& p : m.vertices) {
    // Rodrigues' formula.
    const double kp = k[0] * p[0] + k[1] * p[1] + k[2] * p[2];
    const Point x{k[1] * p[2] - k[2] * p[1], k[2] * p[0] - k[0] * p[2], k[0] * p[1] - k[1] * p[0]};
    Point r;
    for (int a = 0; a < 3; ++a) r[a] = p[a] * c + x[a] * s + k[a] * kp * (1 - c) + shift[a];
    p = r;
  }
}

double area(const mesh::TriMesh& m) {
  double sum = 0;
  for (const auto& f : m.faces) sum += 0.5 * mesh::twice_area(m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]]);
  return sum;
}

// Each triangle's height across its longest edge.
double lowest_height(const mesh::TriMesh& m) {
  double low = INFINITY;
  for (const auto& f : m.faces)
    low = std::min(low, mesh::height_across_longest_edge(m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]]));
  return low;
}

TEST(SimplifyFlat, ASampledBoxBecomesAFewLargeTrianglesOnItsSides) {
  const int n = 20;
  const double a = 0.01;  // a box of 20 cm in voxels of 1 cm
  for (const Point shift : {Point{0, 0, 0}, Point{-3e3, 1e3, 2e3}}) {
    for (const double jitter : {0.0, 0.3}) {
      SCOPED_TRACE(testing::Message() << "shift " << shift[0] << ", jitter " << jitter);
      mesh::TriMesh m = sampled_box(n, a, jitter, 7);
      const mesh::TriMesh unplaced = m;
      place(m, shift);
      const mesh::TriMesh before = m;
      const double tol = 1e-6 * a;
      // Every vertex but the 8 corners lies in a side or on a straight edge.
      EXPECT_NEAR(mesh::flat_vertex_share(m, tol), 1.0 - 8.0 / static_cast<double>(m.vertices.size()), 1e-12);
      const auto r = mesh::simplify_flat(m, tol, 0.05 * a);
      ASSERT_TRUE(r.done);
      std::printf("box of %zu triangles (shift %g, jitter %g): %zu after\n", r.faces_before, shift[0], jitter,
                  r.faces_after);
      EXPECT_EQ(r.faces_before, before.faces.size());
      EXPECT_EQ(r.faces_after, m.faces.size());
      EXPECT_LT(m.faces.size(), 100u) << "the flat sides were not merged";
      EXPECT_TRUE(mesh::topology(m).closed());
      EXPECT_EQ(mesh::topology(m).degenerate_faces, 0u);
      EXPECT_NEAR(mesh::signed_volume(m), mesh::signed_volume(before), 1e-9 * mesh::signed_volume(before));
      EXPECT_NEAR(area(m), area(before), 1e-9 * area(before));
      EXPECT_GE(lowest_height(m), 0.05 * a * (1 - 1e-9));
      // Each vertex left is one of the box's, where it was (a collapse moves one end onto the other).
      std::set<Point> was(before.vertices.begin(), before.vertices.end());
      for (const Point& p : m.vertices) EXPECT_TRUE(was.count(p)) << p[0] << " " << p[1] << " " << p[2];
      // Each triangle lies in one side: its corners' starting coordinates share a 0 or an n.
      std::map<Point, Point> start;
      for (std::size_t v = 0; v < before.vertices.size(); ++v) start[before.vertices[v]] = unplaced.vertices[v];
      for (const auto& f : m.faces) {
        bool one_side = false;
        for (int c = 0; c < 3 && !one_side; ++c)
          for (const double at : {0.0, n * a}) {
            bool all = true;
            for (const auto v : f) all = all && std::fabs(start[m.vertices[v]][c] - at) < 1e-12;
            one_side = one_side || all;
          }
        EXPECT_TRUE(one_side);
      }
    }
  }
}

TEST(SimplifyFlat, CurvedPartsKeepEveryVertex) {
  // A sphere: nothing flat, nothing changes.
  mesh::TriMesh ball = test::sphere_mesh(0.3, 3);
  const mesh::TriMesh round = ball;
  EXPECT_EQ(mesh::flat_vertex_share(ball, 1e-8), 0.0);
  const auto r = mesh::simplify_flat(ball, 1e-8, 1e-4);
  ASSERT_TRUE(r.done);
  EXPECT_EQ(ball.vertices, round.vertices);
  EXPECT_EQ(ball.faces, round.faces);
  // A box with a dome on its top: the dome's vertices all stay; the flat rest merges.
  const int n = 20;
  const double a = 0.01;
  mesh::TriMesh m = sampled_box(n, a, 0, 1);
  std::vector<Point> dome;
  for (Point& p : m.vertices) {
    const double rx = p[0] - 0.1, ry = p[1] - 0.1, r2 = rx * rx + ry * ry;
    if (p[2] == n * a && r2 < 0.06 * 0.06) {
      p[2] += 0.5 * (0.06 * 0.06 - r2) / 0.06;
      dome.push_back(p);
    }
  }
  ASSERT_GT(dome.size(), 30u);
  const std::size_t faces = m.faces.size();
  const double volume = mesh::signed_volume(m);
  const auto d = mesh::simplify_flat(m, 1e-8, 0.05 * a);
  ASSERT_TRUE(d.done);
  EXPECT_LT(m.faces.size(), faces / 4);
  EXPECT_TRUE(mesh::topology(m).closed());
  EXPECT_NEAR(mesh::signed_volume(m), volume, 1e-9 * volume);
  const std::set<Point> left(m.vertices.begin(), m.vertices.end());
  for (const Point& p : dome) EXPECT_TRUE(left.count(p)) << "a vertex of the dome went: " << p[0] << " " << p[1];
}

TEST(SimplifyFlat, AMeshItCannotTakeIsLeftAsItWas) {
  // An open sheet, and two boxes sharing an edge (four triangles on one edge).
  mesh::TriMesh sheet = test::sheet_mesh(6, 6, 0.05);
  mesh::TriMesh two = test::cube_mesh(0.1);
  const mesh::TriMesh other = test::cube_mesh(0.1, {0.2, 0.2, 0});
  for (const auto& f : other.faces) {
    const auto base = static_cast<std::uint32_t>(two.vertices.size());
    two.faces.push_back({base + f[0], base + f[1], base + f[2]});
  }
  two.vertices.insert(two.vertices.end(), other.vertices.begin(), other.vertices.end());
  // (Welded where they touch: the second box's corner (0.1, 0.1, z) is the first's.)
  for (auto& f : two.faces)
    for (auto& v : f)
      for (std::uint32_t w = 0; w < 8; ++w)
        if (v >= 8 && two.vertices[v] == two.vertices[w]) v = w;
  ASSERT_GT(mesh::topology(two).non_manifold_edges, 0u);
  for (mesh::TriMesh* m : {&sheet, &two}) {
    const mesh::TriMesh was = *m;
    const auto r = mesh::simplify_flat(*m, 1e-8, 1e-4);
    EXPECT_FALSE(r.done);
    EXPECT_EQ(r.faces_after, r.faces_before);
    EXPECT_EQ(m->vertices, was.vertices);
    EXPECT_EQ(m->faces, was.faces);
  }
}

TEST(SimplifyFlat, APollThatThrowsStopsIt) {
  mesh::TriMesh m = sampled_box(30, 0.01, 0.2, 3);
  int calls = 0;
  mesh::TriMesh whole = m;
  mesh::simplify_flat(whole, 1e-8, 5e-4, [&] { ++calls; });
  ASSERT_GT(calls, 4);
  struct Stop {};
  int polls = 0;
  EXPECT_THROW(mesh::simplify_flat(m, 1e-8, 5e-4, [&] {
    if (++polls == calls / 2) throw Stop{};
  }), Stop);
  EXPECT_EQ(polls, calls / 2);
}


// Planes through crossings on a voxel's edges meet where they meet: one plane takes the crossings' mean onto
// it, two their line's point nearest that mean, three their corner; a corner beyond the box gives the line
// of its two strongest planes (the most crossings) where that crosses the box, else nothing; planes within
// a few degrees of each other count as one.
TEST(FeaturePoint, PlanesMeetAtTheirLineOrCornerNearestTheirCrossings) {
  const auto unit = [](Point p) {
    const double len = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    return Point{p[0] / len, p[1] / len, p[2] / len};
  };
  const auto dot = [](const Point& a, const Point& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  // Three turned planes n_i . x = c_i (about a box's corner) and points on each.
  const Point n[3] = {unit({0.9, 0.3, -0.2}), unit({-0.25, 0.95, 0.1}), unit({0.2, -0.05, 0.98})};
  const double c[3] = {0.1, -0.2, 0.15};
  const auto on = [&](int i, Point p) {  // p moved onto plane i along its normal
    const double off = dot(n[i], p) - c[i];
    return Point{p[0] - off * n[i][0], p[1] - off * n[i][1], p[2] - off * n[i][2]};
  };
  const Point lo{-1, -1, -1}, hi{1, 1, 1};
  const Point where[6] = {{0.3, -0.4, 0.2}, {-0.5, 0.1, 0.6}, {0.2, 0.7, -0.3}, {-0.6, -0.2, -0.1}, {0.5, 0.5, 0.5}, {0.0, -0.7, 0.4}};
  const auto crossings = [&](int planes, int count, Point* at, Point* normal) {  // on planes 0 .. planes - 1 in turn
    for (int k = 0; k < count; ++k) {
      at[k] = on(k % planes, where[k]);
      normal[k] = n[k % planes];
    }
  };
  const Point line = unit({n[0][1] * n[1][2] - n[0][2] * n[1][1], n[0][2] * n[1][0] - n[0][0] * n[1][2], n[0][0] * n[1][1] - n[0][1] * n[1][0]});
  for (int planes = 1; planes <= 3; ++planes) {
    Point at[6], normal[6], x;
    crossings(planes, 6, at, normal);
    Point mean{0, 0, 0};
    for (const Point& p : at)
      for (int a = 0; a < 3; ++a) mean[a] += p[a] / 6;
    ASSERT_TRUE(mesh::feature_point(at, normal, 6, 0.05, lo, hi, x)) << planes << " planes";
    for (int i = 0; i < planes; ++i) EXPECT_NEAR(dot(n[i], x), c[i], 1e-12) << planes << " planes";
    const Point moved{x[0] - mean[0], x[1] - mean[1], x[2] - mean[2]};
    if (planes == 1) {  // along the normal only
      EXPECT_NEAR(std::fabs(dot(moved, n[0])), std::sqrt(dot(moved, moved)), 1e-12);
    } else if (planes == 2) {  // nearest the mean: not along the line
      EXPECT_NEAR(dot(moved, line), 0, 1e-12);
    }
  }
  // The line of planes 0 and 1 where its point nearest the crossings lies beyond a box it crosses: its point
  // in the box nearest that; a box it misses, or one that the corner of all three misses, gives none.
  {
    Point at[6], normal[6], free, x;
    crossings(2, 4, at, normal);
    ASSERT_TRUE(mesh::feature_point(at, normal, 4, 0.05, lo, hi, free));
    Point box_lo, box_hi;  // half-sides of 0.1 about the line's point 0.5 along it
    for (int a = 0; a < 3; ++a) box_lo[a] = free[a] + 0.5 * line[a] - 0.1, box_hi[a] = free[a] + 0.5 * line[a] + 0.1;
    ASSERT_TRUE(mesh::feature_point(at, normal, 4, 0.05, box_lo, box_hi, x));
    EXPECT_NEAR(dot(n[0], x), c[0], 1e-12);
    EXPECT_NEAR(dot(n[1], x), c[1], 1e-12);
    const double along = dot(Point{x[0] - free[0], x[1] - free[1], x[2] - free[2]}, line);
    EXPECT_LT(along, 0.5) << "the box's side nearest the free point";
    EXPECT_GT(along, 0.5 - 0.1 * std::sqrt(3.0) - 1e-12);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(x[a], box_lo[a]);
      EXPECT_LE(x[a], box_hi[a]);
    }
    for (int a = 0; a < 3; ++a) box_lo[a] += 3, box_hi[a] += 3;
    EXPECT_FALSE(mesh::feature_point(at, normal, 4, 0.05, box_lo, box_hi, x)) << "a box the line misses";
    Point corner;
    crossings(3, 6, at, normal);
    ASSERT_TRUE(mesh::feature_point(at, normal, 6, 0.05, lo, hi, corner));
    const Point near_lo{corner[0] + 0.01, corner[1] - 0.5, corner[2] - 0.5}, near_hi{corner[0] + 1, corner[1] + 0.5, corner[2] + 0.5};
    EXPECT_FALSE(mesh::feature_point(at, normal, 6, 0.05, near_lo, near_hi, x)) << "a corner just beyond the box";
  }
  // Two planes three degrees apart: one, the mean moved along their mean normal only.
  {
    const Point a = unit({0, 0, 1}), b = unit({std::sin(0.05), 0, std::cos(0.05)});
    const Point at[4] = {{0.2, 0.1, 0}, {-0.3, 0.4, 0}, {0.5, -0.2, 0.02}, {-0.1, -0.3, 0.01}};
    const Point normal[4] = {a, a, b, b};
    Point x;
    ASSERT_TRUE(mesh::feature_point(at, normal, 4, 0.05, lo, hi, x));
    EXPECT_NEAR(x[1], (0.1 + 0.4 - 0.2 - 0.3) / 4, 1e-12) << "moved along y";
  }
}

}  // namespace
}  // namespace mca
