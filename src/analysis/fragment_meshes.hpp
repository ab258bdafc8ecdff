#pragma once
// Closed, watertight meshes of the fragments of a state (what [output] fragments writes at the end of a
// run). A fragment's solid is the part of its object nearest its own automata: split from its
// neighbours halfway between automata on either side of a broken link (the faces of their cells), and
// bounded outside by the object's mesh (mesh objects: the original surface, resampled at a third of the
// spacing; in surface mode the piece's own triangles thickened to the shell's thickness, parted from the
// other pieces' halfway between their triangles) or by its automata's cells
// (boxes, spheres, cylinders). The solid is polygonized (OpenVDB), its vertices moved onto the field's zero
// (a primitive's edges and corners where its faces' planes meet), its crack faces smoothed and its flat
// parts merged, then carried to the fragment's pose (its automata's mean rotation and centre).
#include <cstdint>
#include <functional>
#include <vector>

#include "analysis/fragments.hpp"
#include "core/model.hpp"
#include "core/state.hpp"
#include "mesh/mesh.hpp"

namespace mca::analysis {

inline constexpr std::int64_t kMeshedAlone = 512;

// Voxels per spacing for a piece of `automata` automata: small pieces get finer voxels (8 at 27 automata and
// fewer, `cells_per_spacing` from 512), since polygonizing bevels a solid's edges by about a voxel (at 3 per
// spacing it shaved a third off a piece of one cell).
int voxels_per_spacing(std::int64_t automata, int cells_per_spacing = 3);

// The voxel of a shell's piece: `automata` automata, its triangles' area `area` (m^2) and the least
// height of one of them `narrowest` (m), of a shell of half-thickness `half` at the spacing `spacing`,
// whose object's triangles have `object_area` in all. The lattice's voxel, finer down to the shell's
// half-thickness and, for a piece of 27 automata or fewer, to half its narrowest triangle's height (a
// sliver's piece between the samples kept a hundredth of its volume); coarser where the piece's surface
// would take more than 256 voxels an automaton and its share by area of 200,000 (eight large triangles of
// a 0.8 m plate made 12 million faces at an eighth of the spacing), and finer for a thin shell only within
// 64 an automaton or that share (a fine patch beside a large frame in one object was meshed at the
// frame's voxel when the bound was the object's); and at
// least an eighth of the half-thickness (a shell a hundred spacings thick asked every voxel of its box for
// every triangle). (A piece whose box would hold over 2e8 voxels is coarser still.)
double shell_voxel(double spacing, double half, std::int64_t automata, double area, double narrowest,
                   double object_area, int cells_per_spacing = 3);

// Whether float32 holds coordinates up to `far` metres from the origin to a hundredth of `voxel`: a piece
// whose vertices it does not is written in double (FragmentMesh::float32).
bool float32_holds(double far, double voxel);

struct FragmentMesh {
  std::int32_t fragment = 0;  // Fragments id
  std::int64_t automata = 0;
  mesh::TriMesh mesh;         // world coordinates, the state's pose, outward-facing triangles
  double volume = 0;          // enclosed by the mesh [m^3]
  // Whether float32 holds its coordinates to a hundredth of its voxel (its vertices within float32's
  // rounding of each other are then merged: they would be one point in a float32 file); else it is to be
  // written in double (far from the origin, float32 made the pieces empty or folded).
  bool float32 = true;
};

// The fragments of more than `min_automata` automata, in id order (heaviest first). The voxel is the
// spacing over `cells_per_spacing`, finer for pieces under 512 automata (down to an eighth of the spacing
// for 27 and fewer; a shell's piece of a few large triangles coarser, and a shell at least a voxel thick);
// the vertices are then moved onto the exact field, which keeps edges and corners sharp: a box's pieces of
// more than 8 automata hold their cells within 0.5 %, a piece of one cell 98.5 % (docs/model-notes.md). No
// triangle has zero area.
std::vector<FragmentMesh> fragment_meshes(const Model& model, const State& state, const Fragments& fragments,
                                          std::int64_t min_automata, int cells_per_spacing = 3);

// The fragments those meshes are of: the ids of the fragments of more than `min_automata` automata, in id
// order.
std::vector<std::int32_t> meshed_fragments(const Fragments& fragments, std::int64_t min_automata);

// The same meshes, each handed to `sink` as soon as it is made and then let go (a run of many pieces holds
// a few at a time, not all of them). `sink` is called from several threads at once, in no set order.
// Pieces of more than kMeshedAlone automata are meshed one at a time, the others side by side. `poll`, where
// given, is called often while a piece is meshed (from several threads): an exception it throws (a stop
// signal's) ends the meshing there and comes out of this call.
void for_each_fragment_mesh(const Model& model, const State& state, const Fragments& fragments,
                            std::int64_t min_automata, const std::function<void(FragmentMesh&&)>& sink,
                            int cells_per_spacing = 3, const std::function<void()>& poll = {});

}  // namespace mca::analysis
