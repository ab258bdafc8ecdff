#pragma once
// Objects of shape "mesh" made ready for the lattice builder: the file read once, scaled and centred into
// the object's frame, checked, and filled on a cell box (the lattice cells whose centres are inside).
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mca/scene.hpp"
#include "mesh/mesh.hpp"
#include "mesh/voxelize.hpp"

namespace mca::lattice {

struct MeshObject {
  mesh::TriMesh mesh;          // object frame: metres, the centre of its bounding box at the origin
  mesh::Bounds file_bounds;    // bounding box in the file's units
  mesh::Topology topology;
  double scale = 1;            // file units to metres (scale, or what fit_size gives)
  double volume = 0;           // enclosed volume [m^3]
  std::size_t file_vertices = 0;
  // Per region of the object: its mesh in the object frame (mesh regions), else nullopt.
  std::vector<std::optional<mesh::TriMesh>> regions;

  double extent(int axis) const { return file_bounds.extent()[axis] * scale; }
};

// Reads and checks the mesh of scene.objects[index] (and of its mesh regions). Throws mca::Error naming
// the scene, the object and the file: unreadable, empty or flat meshes.
MeshObject prepare_mesh_object(const SceneDef& scene, std::size_t index);

// The cells of `box` (object frame) inside the object's mesh, and per mesh region the cells inside the
// region's mesh (empty for other regions). Throws mca::Error for an open mesh whose holes are wider than a
// cell, for a fill that lets the outside in, and for a mesh that holds no cell (with the spacing that
// gives about 10,000 automata).
struct MeshFillResult {
  std::vector<std::uint8_t> inside;
  std::vector<std::vector<std::uint8_t>> regions;
  std::int64_t count = 0;
  double seconds = 0;
};
MeshFillResult fill_mesh_object(const SceneDef& scene, std::size_t index, const MeshObject& m,
                                const mesh::CellBox& box, bool with_regions);

}  // namespace mca::lattice
