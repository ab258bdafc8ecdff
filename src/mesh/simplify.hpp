#pragma once
// The flat parts of a closed triangle mesh merged into large triangles (CGAL's edge collapse, kept apart:
// it compiles slowly). A mesh sampled in voxels (a fragment's: analysis/fragment_meshes.cpp) has two
// triangles a voxel on every face, flat or not: a box's flat sides take most of its file.
#include <cstddef>
#include <functional>

#include "mesh/mesh.hpp"

namespace mca::mesh {

// The share of m's vertices (0 to 1) that lie in one plane with all their triangles, or on a straight
// edge between two such planes (each triangle's corners within `tol` of its plane): those simplify_flat
// may remove. Cheap (one pass): it tells whether simplifying is worth its time.
double flat_vertex_share(const TriMesh& m, double tol);

struct FlatSimplified {
  std::size_t faces_before = 0, faces_after = 0;
  bool done = false;  // false: m is not a closed manifold CGAL can take, and is left as it was
};

// Removes the vertices that lie in one plane with their triangles, or on a straight edge between two, by
// moving each onto a neighbour in that plane (or along that edge), so that a collapse moves no point of the
// surface by more than `tol` from the planes of the triangles it changes (one after another may add up:
// a nearly flat top bent by 2.5e-7 of its width moved 1.8 tol); shortest edges first, until none is left. A collapse that would turn a triangle over
// or leave one lower than `min_height` across its longest edge is not made. The mesh stays closed, its
// topology and its curved parts as they were. Deterministic (one thread, in the mesh's order). `poll` is
// called often and may throw to stop (m is then left half simplified: a mesh to let go).
FlatSimplified simplify_flat(TriMesh& m, double tol, double min_height, const std::function<void()>& poll = {});

}  // namespace mca::mesh
