#include "mesh/near_triangles.hpp"

#include <algorithm>
#include <array>
#include <limits>
#include <stdexcept>

#include <openvdb/math/Proximity.h>

namespace mca::mesh {
namespace {

openvdb::math::Vec3d vec(const Point& p) { return {p[0], p[1], p[2]}; }

double length_of(const Point& a, const Point& b) {
  const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
  return std::sqrt(x * x + y * y + z * z);
}

constexpr int kKeyBits = 21;  // per axis: a cell's key packs its three indices into 63 bits

}  // namespace

NearTriangles::NearTriangles(const TriMesh& m, std::vector<std::int32_t> label, double reach, const Bounds* region)
    : reach_(reach), cell_(0.5 * reach), label_(std::move(label)) {
  if (label_.size() != m.faces.size()) throw std::invalid_argument("NearTriangles: a label for each face");
  if (!(reach > 0) || !std::isfinite(reach)) throw std::invalid_argument("NearTriangles: the reach must be positive");
  tri_.reserve(m.faces.size());
  Point lo{INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY};
  for (const Triangle& f : m.faces) {
    Tri t{m.vertices[f[0]], m.vertices[f[1]], m.vertices[f[2]], {}, 0, {}, {}, false};
    for (int c = 0; c < 3; ++c) {
      t.centre[c] = (t.a[c] + t.b[c] + t.c[c]) / 3;
      t.lo[c] = std::min({t.a[c], t.b[c], t.c[c]});
      t.hi[c] = std::max({t.a[c], t.b[c], t.c[c]});
      lo[c] = std::min(lo[c], t.lo[c]);
      hi[c] = std::max(hi[c], t.hi[c]);
    }
    t.radius = std::max({length_of(t.a, t.centre), length_of(t.b, t.centre), length_of(t.c, t.centre)});
    t.flat = zero_area(m, f);
    tri_.push_back(t);
  }
  if (tri_.empty()) return;
  // The triangles listed: those within the reach of the region's box (all without one), and the grid over
  // both boxes' overlap.
  std::vector<std::uint8_t> listed_tri(tri_.size(), 1);
  double region_face = INFINITY;  // the largest face of the region's box: no more of a triangle's area lies in it
  if (region) {
    for (std::size_t f = 0; f < tri_.size(); ++f)
      for (int c = 0; c < 3; ++c)
        if (tri_[f].lo[c] > region->hi[c] + reach || tri_[f].hi[c] < region->lo[c] - reach) listed_tri[f] = 0;
    const Point e = region->extent();
    region_face = std::max({e[0] * e[1], e[1] * e[2], e[2] * e[0]}) + 1e-300;
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::max(lo[c], region->lo[c] - reach);
      hi[c] = std::min(hi[c], region->hi[c] + reach);
    }
    if (!(lo[0] <= hi[0] && lo[1] <= hi[1] && lo[2] <= hi[2])) return;  // (nothing near the region)
  }
  // The grid: cells of half the reach over that box and the reach around it (a cell lists the triangles
  // within 1.43 reaches of its centre; cells of the reach, 1.87: a third more to look at, three times fewer
  // entries), fewer than 2^21 a side, and large enough that the triangles' area spans at most kMostCells of
  // them (a triangle lies in about three layers of cells over its area: a few large triangles and a small
  // reach would list millions).
  constexpr double kMostCells = 4e6;
  double area = 0;
  for (std::size_t f = 0; f < tri_.size(); ++f)
    if (listed_tri[f]) {
      const Triangle& t = m.faces[f];
      area += std::min(0.5 * twice_area(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]), region_face);
    }
  cell_ = std::max(cell_, std::sqrt(area / kMostCells));
  for (int c = 0; c < 3; ++c) cell_ = std::max(cell_, (hi[c] - lo[c] + 2 * reach) / ((1 << kKeyBits) - 4));
  for (int c = 0; c < 3; ++c) {
    origin_[c] = lo[c] - reach - cell_;
    dims_[c] = static_cast<std::int64_t>(std::ceil((hi[c] + reach + cell_ - origin_[c]) / cell_)) + 1;
  }
  // Each triangle into the cells within reach of it: the cells of its box and the reach around it,
  // halved along their longest side while the triangle lies within reach of the half's box.
  struct Listed {
    std::uint64_t key;
    float from_centre;
    std::uint32_t triangle;
  };
  std::vector<Listed> listed;
  const auto key = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<std::uint64_t>(i) | static_cast<std::uint64_t>(j) << kKeyBits | static_cast<std::uint64_t>(k) << (2 * kKeyBits);
  };
  for (std::uint32_t f = 0; f < tri_.size(); ++f) {
    if (!listed_tri[f]) continue;
    const Tri& t = tri_[f];
    std::array<std::int64_t, 3> first, last;
    for (int c = 0; c < 3; ++c) {
      const double a = t.lo[c] - reach, b = t.hi[c] + reach;
      first[c] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((a - origin_[c]) / cell_)), 0, dims_[c] - 1);
      last[c] = std::clamp<std::int64_t>(static_cast<std::int64_t>(std::floor((b - origin_[c]) / cell_)), 0, dims_[c] - 1);
    }
    const auto insert = [&](auto&& self, std::array<std::int64_t, 3> l, std::array<std::int64_t, 3> h) -> void {
      Point centre;
      double half2 = 0;
      for (int c = 0; c < 3; ++c) {
        centre[c] = origin_[c] + 0.5 * static_cast<double>(l[c] + h[c] + 1) * cell_;
        const double half = 0.5 * static_cast<double>(h[c] - l[c] + 1) * cell_;
        half2 += half * half;
      }
      const Point to = closest(t, centre);
      const double from_centre = std::sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
      if (from_centre > reach + std::sqrt(half2)) return;
      int longest = 0;
      for (int c = 1; c < 3; ++c)
        if (h[c] - l[c] > h[longest] - l[longest]) longest = c;
      if (h[longest] == l[longest]) {
        // (Rounded down to float: a point of the cell lies no nearer than this less the half-diagonal.)
        float fc = static_cast<float>(from_centre);
        if (static_cast<double>(fc) > from_centre) fc = std::nextafter(fc, 0.0f);
        listed.push_back({key(l[0], l[1], l[2]), fc, f});
        return;
      }
      const std::int64_t mid = (l[longest] + h[longest]) / 2;
      std::array<std::int64_t, 3> h1 = h, l2 = l;
      h1[longest] = mid;
      l2[longest] = mid + 1;
      self(self, l, h1);
      self(self, l2, h);
    };
    insert(insert, first, last);
  }
  // Each cell's list nearest first (ties by triangle: the same list on every run).
  std::sort(listed.begin(), listed.end(), [](const Listed& x, const Listed& y) {
    return x.key != y.key ? x.key < y.key : x.from_centre != y.from_centre ? x.from_centre < y.from_centre : x.triangle < y.triangle;
  });
  if (listed.size() >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("NearTriangles: over 4 billion listed triangles");
  entries_.reserve(listed.size());
  for (std::size_t k = 0; k < listed.size();) {
    const std::uint64_t cell = listed[k].key;
    const auto begin = static_cast<std::uint32_t>(entries_.size());
    std::int32_t only = label_[listed[k].triangle];
    for (; k < listed.size() && listed[k].key == cell; ++k) {
      entries_.push_back({listed[k].from_centre, listed[k].triangle});
      if (label_[listed[k].triangle] != only) only = kMixed;
    }
    cells_.emplace(cell, Cell{begin, static_cast<std::uint32_t>(entries_.size()), only});
  }
  half_diagonal_ = 0.5 * std::sqrt(3.0) * cell_;
}

Point NearTriangles::closest(const Tri& t, const Point& p) const {
  // Measured from p (OpenVDB's closest point works in the coordinates it is given, and 1e5 m from their
  // origin it was off by up to a centimetre for triangles of one).
  const openvdb::math::Vec3d a = vec(t.a) - vec(p), b = vec(t.b) - vec(p), c = vec(t.c) - vec(p), o(0, 0, 0);
  openvdb::math::Vec3d x(0, 0, 0);
  if (!t.flat) {
    openvdb::math::Vec3d uvw;
    x = openvdb::math::closestPointOnTriangleToPoint(a, b, c, o, uvw);
  } else {
    // (A triangle of no area: its edges; the closest point on a face would divide by its zero area.)
    const openvdb::math::Vec3d* corner[3] = {&a, &b, &c};
    double best = INFINITY;
    for (int e = 0; e < 3; ++e) {
      double along;
      const auto y = openvdb::math::closestPointOnSegmentToPoint(*corner[e], *corner[(e + 1) % 3], o, along);
      if (y.lengthSqr() < best) {
        best = y.lengthSqr();
        x = y;
      }
    }
  }
  return {x[0], x[1], x[2]};
}

bool NearTriangles::cell_of(const Point& p, std::uint64_t& key) const {
  std::uint64_t k = 0;
  for (int c = 0; c < 3; ++c) {
    const double u = std::floor((p[c] - origin_[c]) / cell_);
    if (!(u >= 0 && u < static_cast<double>(dims_[c]))) return false;
    k |= static_cast<std::uint64_t>(u) << (c * kKeyBits);
  }
  key = k;
  return true;
}

NearTriangles::Nearest NearTriangles::nearest(const Point& p, std::int32_t own, double own_within, double past_own,
                                              double deep, Cursor& cursor) const {
  Nearest n;
  std::uint64_t key;
  if (!cell_of(p, key)) return n;
  if (key != cursor.key) {
    cursor.key = key;
    const auto it = cells_.find(key);
    cursor.begin = it == cells_.end() ? nullptr : entries_.data() + it->second.begin;
    cursor.end = it == cells_.end() ? nullptr : entries_.data() + it->second.end;
    cursor.only = it == cells_.end() ? kMixed : it->second.only;
  }
  if (cursor.only != kMixed && cursor.only != own) return n;  // (only others' triangles near)
  const bool alone = cursor.only == own;
  // The cell's list, nearest its centre first, until the triangles lie farther than anything still sought
  // (the nearest own one within own_within, then others within past_own of it), each skipped where its
  // box or ball lies no nearer than the best of its kind so far or its limit. The others' limit shrinks
  // as the own triangles are found; a nearer own one found later only narrows it, so the others kept
  // are checked against the final limit at the end.
  const double own_limit = std::min(own_within, reach_);
  const auto no_nearer = [&](const Tri& t, double than) {
    double box2 = 0, ball2 = 0;
    for (int c = 0; c < 3; ++c) {
      const double out = std::max({t.lo[c] - p[c], p[c] - t.hi[c], 0.0}), to = p[c] - t.centre[c];
      box2 += out * out;
      ball2 += to * to;
    }
    return box2 >= than * than || ball2 >= (than + t.radius) * (than + t.radius);
  };
  for (const Entry* e = cursor.begin; e != cursor.end; ++e) {
    const double own_now = std::min(n.own, own_limit), other_now = std::min(n.other, std::min(own_now + past_own, reach_));
    const double beyond = static_cast<double>(e->from_centre) - half_diagonal_;  // no point of the cell is nearer
    if (beyond >= own_now && beyond >= other_now) break;
    const Tri& t = tri_[e->triangle];
    const bool mine = label_[e->triangle] == own;
    double& best = mine ? n.own : n.other;
    const double limit = mine ? own_now : other_now;
    if (beyond >= limit || no_nearer(t, limit)) continue;
    const Point to = closest(t, p);
    const double r = std::sqrt(to[0] * to[0] + to[1] * to[1] + to[2] * to[2]);
    if (r < limit) {
      best = r;
      (mine ? n.own_at : n.other_at) = to;
    }
    if (alone && r <= deep) return n;
  }
  if (!(n.own <= own_limit)) return {};
  if (!(n.other <= std::min(n.own + past_own, reach_))) n.other = INFINITY;
  return n;
}

std::size_t NearTriangles::bytes() const {
  return tri_.capacity() * sizeof(Tri) + label_.capacity() * sizeof(std::int32_t) + entries_.capacity() * sizeof(Entry) +
         cells_.size() * (sizeof(std::uint64_t) + sizeof(Cell) + 2 * sizeof(void*));
}

}  // namespace mca::mesh
