#pragma once
// The lattice cells whose centres lie inside a closed triangle mesh (OpenVDB: the mesh's signed distance
// on the lattice, inside where it is negative). Behind this plain interface: a file that includes OpenVDB
// takes about 20 s to compile.
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "mesh/mesh.hpp"

namespace mca::mesh {

// A box of n[0] x n[1] x n[2] cells of size d; the centre of cell (i, j, k) is origin + (i, j, k) d in the
// mesh's coordinates.
struct CellBox {
  std::int64_t n[3] = {0, 0, 0};
  double origin[3] = {0, 0, 0};
  double d = 0;
  std::int64_t cells() const { return n[0] * n[1] * n[2]; }
};

// One byte per cell, x fastest: 1 where the cell centre is inside the mesh (signed distance < 0). The
// sign is found by flood fill from outside, so it does not depend on the triangles' orientation, a few
// flipped or doubled triangles change nothing, and holes narrower than about a cell are closed; a larger
// hole lets the outside in (the caller refuses such meshes: Topology::largest_hole).
// `faces`: only these triangles of m (one shell), else all.
std::vector<std::uint8_t> interior_cells(const TriMesh& m, const CellBox& box,
                                         const std::vector<std::uint32_t>* faces = nullptr);

// The signed distance of a mesh (negative inside), sampled at the cell centres of a box: exact within
// `band` cells of the surface, +-band cells (by the side) beyond.
class SignedDistance {
 public:
  SignedDistance(const TriMesh& m, const CellBox& box, float band = 3.0f);
  ~SignedDistance();
  SignedDistance(const SignedDistance&) = delete;
  SignedDistance& operator=(const SignedDistance&) = delete;
  // At the centre of cell (i, j, k) of the box (any integers: outside the box, the value beyond the band),
  // in the mesh's units.
  float at(std::int64_t i, std::int64_t j, std::int64_t k) const;

 private:
  struct Grid;
  std::unique_ptr<Grid> grid_;
};

// The closed surface where a field over the cell centres of `box` crosses zero, negative inside, as
// outward-facing triangles in the box's coordinates. The field must be positive on the box's outer cells
// for the surface to close. `plane(k, values)` writes the field's plane k (x fastest, n[0] * n[1] values);
// it is called from several threads at once, for a few planes at a time, so the whole field is never held.
TriMesh polygonize(const CellBox& box, const std::function<void(std::int64_t k, float* values)>& plane);

// Where the planes through at[i] with unit normals normal[i] (i < n) meet nearest to their points' mean, in
// the least-squares sense, within the box from lo to hi (dual contouring's quadratic error function, Ju et
// al. 2002, solved by OpenVDB's symmetric eigendecomposition), into x: along a direction in which the
// normals' squared components sum to under `flat` times the strongest direction's, x stays at the mean (one
// plane: the mean moved onto it; two: onto their line; three that meet at a corner: the corner). Where a
// line's point lies beyond the box: the line's point in the box nearest it. False where no such point lies
// in the box (a corner or a plane's point beyond it, a line that misses it).
bool feature_point(const Point* at, const Point* normal, int n, double flat, const Point& lo, const Point& hi, Point& x);

}  // namespace mca::mesh
