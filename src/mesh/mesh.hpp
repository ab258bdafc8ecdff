#pragma once
// Triangle meshes from files (OBJ, PLY, OFF: mca's readers; STL, glTF/GLB: assimp), checked so that a bad file is a
// clear mca::Error naming it, and what a mesh is made of (boundary and non-manifold edges, volume).
// Interior cells of a closed mesh on a lattice are in voxelize.hpp (OpenVDB, kept apart: it compiles slowly).
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace mca::mesh {

using Point = std::array<double, 3>;
using Triangle = std::array<std::uint32_t, 3>;

struct TriMesh {
  std::vector<Point> vertices;
  std::vector<Triangle> faces;  // indices into vertices; every index is checked < vertices.size()
};

// The file extensions read_mesh accepts (lower case, no dot).
const std::vector<std::string>& mesh_extensions();

// Reads a mesh file: all meshes of the file joined (node transforms applied), triangulated, identical
// vertices welded (STL and OBJ store them per face). OBJ, PLY and OFF are read by mca's own readers, in
// double (mesh/readers.hpp); STL, glTF and GLB, which store float32, by assimp. Throws mca::Error naming
// `path` for a missing file, an unknown extension, a file whose first bytes are not its format's, a header
// whose counts the file cannot hold, a file assimp cannot read, no triangles (a point cloud), non-finite
// coordinates, only degenerate triangles, or a file whose reading would take more than
// `max_memory_bytes` (solver.max_memory_gb; estimated from its size and counts before it is read).
TriMesh read_mesh(const std::string& path, double max_memory_bytes = 16e9);

// The same from bytes in memory; `extension` picks the format, `name` names the data in messages.
TriMesh read_mesh_memory(const void* data, std::size_t size, const std::string& extension, const std::string& name,
                         double max_memory_bytes = 16e9);

// Whether the format of this file (or this extension) stores float32 coordinates (STL, glTF, GLB, and a PLY
// file whose header makes its vertices' x a float): a model far from the file's origin has lost precision
// there already.
bool float32_format(const std::string& path_or_extension);

struct Bounds {
  Point lo{0, 0, 0}, hi{0, 0, 0};
  Point extent() const { return {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}; }
  Point centre() const { return {0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])}; }
  double largest_extent() const;
};
Bounds bounds(const TriMesh& m);

// Twice the area of the triangle a b c (the length of the cross product of two of its edges).
double twice_area(const Point& a, const Point& b, const Point& c);
// The triangle's height across its longest edge (0 where all three corners are one point): how narrow it is.
double height_across_longest_edge(const Point& a, const Point& b, const Point& c);

// Whether the triangle of corners `f` of m has no area: a repeated corner, or corners on a line to within
// the rounding of their coordinates (its area against its longest edge; where the corners lie far from
// the origin, against what rounding them to double could make of a line: a triangle of 5 cm at 5e6 m
// from the origin has an area).
bool zero_area(const TriMesh& m, const Triangle& f);

struct Topology {
  std::size_t edges = 0;
  std::size_t boundary_edges = 0;      // used by one triangle: a hole's rim
  std::size_t non_manifold_edges = 0;  // used by three or more triangles
  std::size_t degenerate_faces = 0;    // zero area or a repeated vertex
  std::size_t holes = 0;               // connected loops of boundary edges
  double largest_hole = 0;             // largest extent of one hole's rim (its bounding box diagonal)
  double largest_hole_width = 0;       // that rim's width, 4 area / length (near 0 for a seam: mesh.cpp)
  bool closed() const { return boundary_edges == 0 && non_manifold_edges == 0; }
};
Topology topology(const TriMesh& m);

// The triangles of `faces` (all of m's where null), in increasing order, each repeat left out: a triangle
// of the same three vertices as an earlier one, in any order (a doubled surface, a file that repeats them).
std::vector<std::uint32_t> unique_triangles(const TriMesh& m, const std::vector<std::uint32_t>* faces = nullptr);

// A connected piece of a mesh's surface (triangles joined through shared vertices).
struct Shell {
  std::vector<std::uint32_t> faces;  // indices into TriMesh::faces, increasing
  Bounds bounds;
  bool manifold = false;  // every edge used by exactly two of its triangles
  // Enclosed volume with its triangles turned to agree with their neighbours (so flipped triangles do not
  // matter); meaningful when manifold.
  double volume = 0;
};
// The shells of a mesh, in order of their first triangle.
std::vector<Shell> shells(const TriMesh& m);

// m with only the triangles `faces` (of m's vertices): the vertices no triangle uses are dropped, the rest
// numbered in the order the triangles use them.
void keep_faces(TriMesh& m, std::vector<Triangle>&& faces);

// Drops the shells of m (triangles joined through shared vertices) whose box is under `small` along every
// axis, unless every shell is; returns how many were dropped (none: m is left as it was).
std::size_t drop_small_shells(TriMesh& m, double small);

// Enclosed volume by the divergence theorem (positive for outward-facing triangles; meaningful for a
// closed mesh, approximate for one with small holes).
double signed_volume(const TriMesh& m);

}  // namespace mca::mesh
