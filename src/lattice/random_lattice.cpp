#include "lattice/random_lattice.hpp"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_vertex_base_with_info_3.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "core/rng.hpp"

namespace mca::lattice {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using Vb = CGAL::Triangulation_vertex_base_with_info_3<std::uint32_t, K>;
using Tds = CGAL::Triangulation_data_structure_3<Vb, CGAL::Delaunay_triangulation_cell_base_3<K>>;
using Delaunay = CGAL::Delaunay_triangulation_3<K, Tds>;

constexpr int kDraws = 8;
constexpr std::uint64_t kSiteTag = 0x72616e646f6dull;  // "random"

double dist2(const std::array<double, 3>& a, const std::array<double, 3>& b) {
  const double x = a[0] - b[0], y = a[1] - b[1], z = a[2] - b[2];
  return x * x + y * y + z * z;
}

}  // namespace

RandomSites random_sites(const std::int64_t n[3], const double origin[3], double d, const std::vector<std::uint8_t>& inside,
                         std::uint64_t seed, std::uint64_t object) {
  // The frame grown by a layer of cells on every side (ghosts may lie just outside it), walked in
  // row-major order: the object's sites of plane k, then the ghosts of plane k - 1, whose sources lie in
  // planes k - 2 to k. A ring of three planes keeps the sites for the distance test and the mirrors.
  const std::int64_t N[3] = {n[0] + 2, n[1] + 2, n[2] + 2};
  const auto filled = [&](std::int64_t i, std::int64_t j, std::int64_t k) {  // extended coordinates
    --i, --j, --k;
    if (i < 0 || j < 0 || k < 0 || i >= n[0] || j >= n[1] || k >= n[2]) return false;
    return inside[static_cast<std::size_t>(i + n[0] * (j + n[1] * k))] != 0;
  };
  const std::size_t plane = static_cast<std::size_t>(N[0] * N[1]);
  std::vector<std::array<double, 3>> at(3 * plane);
  std::vector<std::uint8_t> drawn(3 * plane, 0);  // 1: an object's site of this plane is in `at`
  const auto slot = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    return static_cast<std::size_t>(k % 3) * plane + static_cast<std::size_t>(i + N[0] * j);
  };
  // How many of the 26 cells around (i, j, k) the object fills.
  const auto filled_neighbours = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    int count = 0;
    for (std::int64_t dk = -1; dk <= 1; ++dk)
      for (std::int64_t dj = -1; dj <= 1; ++dj)
        for (std::int64_t di = -1; di <= 1; ++di) count += (di || dj || dk) && filled(i + di, j + dj, k + dk);
    return count;
  };
  const double min2 = kMinSiteDistance * d * kMinSiteDistance * d;
  // The squared distance from p to the nearest of the object's sites drawn among the neighbours of cell
  // (i, j, k): all 26 (a ghost's, drawn after the planes around it), or the 13 drawn before it (a site's).
  const auto nearest2 = [&](const std::array<double, 3>& p, std::int64_t i, std::int64_t j, std::int64_t k, bool all) {
    double near2 = INFINITY;
    for (std::int64_t dk = -1; dk <= (all ? 1 : 0); ++dk)
      for (std::int64_t dj = -1; dj <= 1; ++dj)
        for (std::int64_t di = -1; di <= 1; ++di) {
          if (!di && !dj && !dk) continue;
          if (!all && dk == 0 && (dj > 0 || (dj == 0 && di >= 0))) continue;  // not drawn yet
          const std::int64_t x = i + di, y = j + dj, z = k + dk;
          if (!filled(x, y, z)) continue;  // (false outside the frame)
          const std::size_t s = slot(x, y, z);
          if (drawn[s]) near2 = std::min(near2, dist2(p, at[s]));
        }
    return near2;
  };
  // A uniform random point of the cell, drawn again, up to 8 times, while it lies closer than
  // kMinSiteDistance d to a neighbouring site (the farthest of the 8 draws otherwise).
  const auto draw = [&](std::int64_t i, std::int64_t j, std::int64_t k, bool in) {
    const auto cell = static_cast<std::uint64_t>(i + N[0] * (j + N[1] * k));
    std::array<double, 3> best{};
    double best2 = -1;
    for (int t = 0; t < kDraws; ++t) {
      std::array<double, 3> p;
      const std::int64_t c[3] = {i - 1, j - 1, k - 1};
      for (int a = 0; a < 3; ++a) {
        double u = unit_from_hash(hash_keys(seed, object, cell, static_cast<std::uint64_t>(t * 3 + a), kSiteTag));
        // Along an axis where the next cell is of the other kind (a site of the object's surface and
        // the ghost beyond it), the site lies at its cell's centre: its contact sphere (radius d / 2)
        // reaches the object's face as the cubic lattice's does (a body stands on the ground at rest,
        // two objects placed face to face touch).
        const std::int64_t e[3] = {a == 0, a == 1, a == 2};
        if (filled(i - e[0], j - e[1], k - e[2]) != in || filled(i + e[0], j + e[1], k + e[2]) != in) u = 0.5;
        p[static_cast<std::size_t>(a)] = origin[a] + (static_cast<double>(c[a]) + u - 0.5) * d;
      }
      const double near2 = nearest2(p, i, j, k, !in);
      if (near2 > best2) {
        best2 = near2;
        best = p;
      }
      if (near2 >= min2) break;
    }
    return best;
  };
  // A ghost: the mirror image of the one site of the object it touches across a face (else, touching none
  // so, across an edge; else across a corner), reflected in the planes between their cells. The site lies
  // at its cell's centre along those axes, so the ghost takes its own cell's centre there and the site's
  // coordinates along the others. The Voronoi faces between a site and the ghosts then lie in the
  // object's faces, as the cubic lattice's free faces do (with ghosts drawn at random, the faces toward
  // them leaned, and their missing links took about 0.1 d of stiffness off each face of a body:
  // docs/model-notes.md, "The random lattice", Wave speed). A ghost that touches several of the object's
  // cells at the first of those levels (a concave corner of a mesh), or whose mirror image lies closer than
  // kMinSiteDistance d to another site, is drawn at random as a site is.
  const auto ghost = [&](std::int64_t i, std::int64_t j, std::int64_t k) {
    std::int64_t src[3] = {0, 0, 0};
    for (int level = 1; level <= 3; ++level) {
      int found = 0;
      for (std::int64_t dk = -1; dk <= 1; ++dk)
        for (std::int64_t dj = -1; dj <= 1; ++dj)
          for (std::int64_t di = -1; di <= 1; ++di) {
            if ((di != 0) + (dj != 0) + (dk != 0) != level || !filled(i + di, j + dj, k + dk)) continue;
            ++found;
            src[0] = i + di, src[1] = j + dj, src[2] = k + dk;
          }
      if (found == 0) continue;
      if (found > 1) break;
      std::array<double, 3> p = at[slot(src[0], src[1], src[2])];
      const std::int64_t g[3] = {i, j, k};
      for (int a = 0; a < 3; ++a)
        if (src[a] != g[a]) p[static_cast<std::size_t>(a)] = origin[a] + static_cast<double>(g[a] - 1) * d;
      if (nearest2(p, i, j, k, true) >= min2) return p;
      break;
    }
    return draw(i, j, k, false);
  };
  RandomSites out;
  for (std::int64_t k = 0; k <= N[2]; ++k) {
    if (k < N[2]) {
      std::fill(drawn.begin() + static_cast<std::ptrdiff_t>((k % 3) * plane),
                drawn.begin() + static_cast<std::ptrdiff_t>((k % 3 + 1) * plane), 0);
      for (std::int64_t j = 0; j < N[1]; ++j)
        for (std::int64_t i = 0; i < N[0]; ++i) {
          if (!filled(i, j, k)) continue;
          const std::array<double, 3> p = draw(i, j, k, true);
          at[slot(i, j, k)] = p;
          drawn[slot(i, j, k)] = 1;
          out.inside.push_back(p);
          out.deep.push_back(filled_neighbours(i, j, k) == 26);  // a filled cell with no empty neighbour
        }
    }
    if (k == 0) continue;
    for (std::int64_t j = 0; j < N[1]; ++j)
      for (std::int64_t i = 0; i < N[0]; ++i)
        if (!filled(i, j, k - 1) && filled_neighbours(i, j, k - 1) > 0) out.ghosts.push_back(ghost(i, j, k - 1));
  }
  return out;
}

VoronoiLinks voronoi_links(const std::vector<std::array<double, 3>>& sites,
                           const std::vector<std::array<double, 3>>& ghosts, double min_area) {
  const std::size_t real = sites.size();
  std::vector<std::pair<K::Point_3, std::uint32_t>> points;
  points.reserve(real + ghosts.size());
  for (const auto& p : sites) points.emplace_back(K::Point_3(p[0], p[1], p[2]), static_cast<std::uint32_t>(points.size()));
  for (const auto& p : ghosts) points.emplace_back(K::Point_3(p[0], p[1], p[2]), static_cast<std::uint32_t>(points.size()));
  // (Inserted in CGAL's spatial order, shuffled by a generator of fixed seed: the same triangulation each
  // time; the Voronoi diagram is unique whatever the order.)
  const Delaunay T(points.begin(), points.end());
  VoronoiLinks v;
  v.volume.assign(real, 0.0);
  v.interior.assign(real, 1);
  v.free_face.assign(real, 0.0);
  std::vector<std::pair<std::array<std::uint32_t, 2>, double>> links;
  std::vector<K::Point_3> face;
  for (auto e = T.finite_edges_begin(); e != T.finite_edges_end(); ++e) {
    std::uint32_t a = e->first->vertex(e->second)->info(), b = e->first->vertex(e->third)->info();
    if (a >= real && b >= real) continue;
    if (a > b) std::swap(a, b);
    // The dual face: the circumcentres of the tetrahedra around the edge, in turn.
    face.clear();
    auto c = T.incident_cells(*e);
    const auto done = c;
    do {
      if (T.is_infinite(c)) {
        throw std::logic_error("random lattice: a site of the object lies on the hull of its ghosts");
      }
      face.push_back(T.dual(c));
    } while (++c != done);
    K::Vector_3 s(0, 0, 0);
    for (std::size_t q = 1; q + 1 < face.size(); ++q) s = s + CGAL::cross_product(face[q] - face[0], face[q + 1] - face[0]);
    const double area = 0.5 * std::sqrt(s.squared_length());
    const std::array<double, 3>& pa = sites[a];
    const std::array<double, 3>& pb = b < real ? sites[b] : ghosts[b - real];
    const double r = std::sqrt(dist2(pa, pb));
    // The cell is the union of the pyramids on its faces, each of height r / 2.
    v.volume[a] += area * r / 6.0;
    if (b < real) v.volume[b] += area * r / 6.0;
    else {
      v.interior[a] = 0;
      v.free_face[a] += area * r;
    }
    if (b < real && area >= min_area) links.push_back({{a, b}, area});
  }
  std::sort(links.begin(), links.end());
  v.link.reserve(links.size());
  v.area.reserve(links.size());
  for (const auto& [l, area] : links) {
    v.link.push_back(l);
    v.area.push_back(area);
  }
  return v;
}

}  // namespace mca::lattice
