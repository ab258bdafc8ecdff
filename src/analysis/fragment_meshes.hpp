#pragma once
// Closed, watertight meshes of the fragments of a state (what [output] fragments writes at the end of a
// run). A fragment's solid is the part of its object nearest its own automata: split from its
// neighbours halfway between automata on either side of a broken link (the faces of their cells), and
// bounded outside by the object's mesh (mesh objects: the original surface, resampled at a third of the
// spacing; in surface mode the surface thickened to the shell's thickness) or by its automata's cells
// (boxes, spheres, cylinders). The solid is polygonized (OpenVDB),
// then carried to the fragment's pose (its automata's mean rotation and centre).
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

struct FragmentMesh {
  std::int32_t fragment = 0;  // Fragments id
  std::int64_t automata = 0;
  mesh::TriMesh mesh;         // world coordinates, the state's pose, outward-facing triangles
  double volume = 0;          // enclosed by the mesh [m^3]
};

// The fragments of more than `min_automata` automata, in id order (heaviest first). The voxel is the
// spacing over `cells_per_spacing`, finer for pieces under 512 automata (down to an eighth of the spacing
// for 27 and fewer); the vertices are then moved onto the exact field, which keeps edges and corners
// sharp: a box's pieces of more than 8 automata hold their cells within 0.5 %, a piece of one cell 98.5 %
// (docs/model-notes.md). No triangle has zero area.
std::vector<FragmentMesh> fragment_meshes(const Model& model, const State& state, const Fragments& fragments,
                                          std::int64_t min_automata, int cells_per_spacing = 3);

// The fragments those meshes are of: the ids of the fragments of more than `min_automata` automata, in id
// order.
std::vector<std::int32_t> meshed_fragments(const Fragments& fragments, std::int64_t min_automata);

// The same meshes, each handed to `sink` as soon as it is made and then let go (a run of many pieces holds
// a few at a time, not all of them). `sink` is called from several threads at once, in no set order.
// Pieces of more than kMeshedAlone automata are meshed one at a time, the others side by side.
void for_each_fragment_mesh(const Model& model, const State& state, const Fragments& fragments,
                            std::int64_t min_automata, const std::function<void(FragmentMesh&&)>& sink,
                            int cells_per_spacing = 3);

}  // namespace mca::analysis
