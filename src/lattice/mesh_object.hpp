#pragma once
// Objects of shape "mesh" made ready for the lattice builder: the file read once, scaled and centred into
// the object's frame, checked, and filled on a cell box (the lattice cells whose centres are inside).
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mca/scene.hpp"
#include "mesh/mesh.hpp"
#include "mesh/voxelize.hpp"

namespace mca::lattice {

// A closed surface to fill: its shells, and how they nest (a shell inside another bounds a cavity, one
// inside a cavity an island, ...).
struct Solid {
  std::string file;
  mesh::TriMesh mesh;          // object frame: metres
  mesh::Topology topology;
  std::vector<mesh::Shell> shells;
  // Per shell: how many other shells enclose it (odd: it bounds a cavity), or -1 for a shell that repeats
  // an earlier one (a doubled surface), which is skipped.
  std::vector<int> depth;
  double volume = 0;           // the solid's: solid shells' volumes minus the cavities' [m^3]
  bool manifold = true;        // every shell manifold: then `volume` is exact and the fill is checked by it
};

struct MeshObject {
  Solid solid;
  mesh::Bounds file_bounds;    // bounding box in the file's units
  double scale = 1;            // file units to metres (scale, or what fit_size gives)
  std::size_t file_vertices = 0;
  bool float32 = false;        // the file's format stores float32 coordinates (mesh::float32_format)
  double file_reach = 0;       // the largest |coordinate| of its bounding box, in the file's units
  // Per region of the object: its solid in the object frame (mesh regions), else nullopt.
  std::vector<std::optional<Solid>> regions;

  double extent(int axis) const { return file_bounds.extent()[axis] * scale; }
  double volume() const { return solid.volume; }
};

// Reads and checks the mesh of scene.objects[index] (and of its mesh regions). Throws mca::Error naming
// the scene, the object and the file: unreadable, empty or flat meshes.
MeshObject prepare_mesh_object(const SceneDef& scene, std::size_t index);


// The cells of `box` (object frame) inside the object's mesh, and per mesh region the cells inside the
// region's mesh (empty for other regions). Throws mca::Error for an open mesh whose holes are wider than a
// cell, for a fill that lets the outside in, and for a mesh that holds no cell (with the spacing that
// gives about 10,000 automata).
// Cells inside the mesh that no lattice link joins to the body of their solid shell (the face-connected
// piece holding most of its cells) are left out of `inside`: they would fall off at t = 0. `dropped`
// counts them (in `dropped_pieces` pieces, the largest of `largest_dropped` cells).
struct MeshFillResult {
  std::vector<std::uint8_t> inside;
  std::vector<std::vector<std::uint8_t>> regions;
  std::int64_t count = 0;
  std::int64_t dropped = 0, dropped_pieces = 0, largest_dropped = 0;
  double seconds = 0;
};
MeshFillResult fill_mesh_object(const SceneDef& scene, std::size_t index, const MeshObject& m,
                                const mesh::CellBox& box);

// Surface mode (the paper's counts): one automaton per triangle of non-zero area, at its centroid, linked
// to each triangle that shares an edge with it (edges of exactly two such triangles; an edge of three or
// more is left unlinked and counted).
struct SurfaceCells {
  std::vector<std::uint32_t> face;      // the triangles that get an automaton, increasing
  std::vector<mesh::Point> centroid;    // per automaton, object frame [m]
  std::vector<double> area;             // per automaton [m^2]
  std::vector<std::array<std::uint32_t, 2>> link;  // pairs of automata (indices into face, a < b), sorted
  std::vector<double> edge;             // per link: the length of the shared edge [m]
  std::size_t unlinked_edges = 0;       // non-manifold edges, left without links
  std::size_t pieces = 0;               // the shell's pieces at the start: its automata joined by its links
  std::size_t duplicate_faces = 0;      // triangles given again (the same three vertices), left out
  double mean_link = 0;                 // mean centroid distance over the links [m] (0 without links)
  double thickness = 0;                 // the shell's: shell_thickness, or mean_link when not given
};
// Throws mca::Error when no triangle has an area, or when shell_thickness is absent and no triangle
// shares an edge with another (nothing to take a thickness from).
SurfaceCells surface_cells(const SceneDef& scene, std::size_t index, const MeshObject& m);

// Whether point p (object frame) is inside the solid, by the parity of a ray's crossings of its shells.
bool inside_solid(const Solid& s, const mesh::Point& p);

}  // namespace mca::lattice
