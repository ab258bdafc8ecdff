#pragma once
// The labelled triangles of a mesh near a point: the distance to the nearest triangle of one label and to
// the nearest of any other (a shell's fragment meshes: a point of the shell belongs to the piece whose
// triangle is nearest). Triangles are listed in cells of a sparse grid, each cell holding every triangle
// within the reach of some point of it, so a query reads one cell.
#include <cmath>
#include <climits>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "mesh/mesh.hpp"

namespace mca::mesh {

class NearTriangles {
 public:
  // The faces of m, face f labelled label[f], for queries within `reach` (> 0) of them and, where a
  // region is given, from points in it (a point outside finds nothing; triangles farther than the reach
  // from it are not listed). Throws std::invalid_argument where the labels do not match the faces or the
  // reach is not positive.
  NearTriangles(const TriMesh& m, std::vector<std::int32_t> label, double reach, const Bounds* region = nullptr);

  struct Nearest {
    double own = INFINITY;    // to the nearest triangle labelled `own`, where within `own_within`
    double other = INFINITY;  // to the nearest labelled otherwise, where within `past_own` of own
    Point own_at{0, 0, 0}, other_at{0, 0, 0};  // their closest points to p, less p
  };
  struct Entry {
    float from_centre;  // the triangle's distance from the cell's centre (the cell's list is in its order)
    std::uint32_t triangle;
  };
  // The last cell a query read (consecutive queries along a row of voxels mostly read the same one): one
  // per thread.
  struct Cursor {
    std::uint64_t key = ~std::uint64_t{0};
    const Entry* begin = nullptr;
    const Entry* end = nullptr;
    std::int32_t only = kMixed;  // the label of every triangle listed, where they share one
  };
  static constexpr std::int32_t kMixed = INT32_MIN;
  // The distances from p to its nearest triangles (within the reach): the nearest labelled `own` where it
  // lies within `own_within`, and then the nearest labelled otherwise where it lies within `past_own` of
  // that; infinity for each where not (a triangle whose bounding box or ball lies farther is skipped).
  // Where no triangle but its own lies within the reach of p's cell, the first own one found within `deep`
  // answers (not the nearest: enough to tell that p lies deeper than that).
  Nearest nearest(const Point& p, std::int32_t own, double own_within, double past_own, double deep, Cursor& cursor) const;
  Nearest nearest(const Point& p, std::int32_t own) const {
    Cursor c;
    return nearest(p, own, INFINITY, INFINITY, -1, c);
  }

  double reach() const { return reach_; }
  double cell() const { return cell_; }
  // Triangles listed, over all cells (a triangle in several cells counts in each).
  std::size_t entries() const { return entries_.size(); }
  std::size_t bytes() const;

 private:
  struct Tri {
    Point a, b, c;
    Point centre;   // its corners' mean
    double radius;  // its farthest corner from centre: no point of it lies farther
    Point lo, hi;   // its box
    bool flat;      // no area: measured against its edges
  };
  // The point of t nearest p, less p.
  Point closest(const Tri& t, const Point& p) const;
  bool cell_of(const Point& p, std::uint64_t& key) const;

  double reach_, cell_, half_diagonal_ = 0;
  Point origin_{0, 0, 0};
  std::int64_t dims_[3] = {0, 0, 0};
  std::vector<Tri> tri_;
  std::vector<std::int32_t> label_;
  std::vector<Entry> entries_;  // the cells' lists, one after another
  struct Cell {
    std::uint32_t begin, end;  // in entries_
    std::int32_t only;         // the label of all, or kMixed
  };
  std::unordered_map<std::uint64_t, Cell> cells_;
};

}  // namespace mca::mesh
