#pragma once
// Triangle meshes to streams: binary PLY (little-endian, float32 vertices, or double where asked, int32
// indices: what Blender, ParaView, MeshLab and assimp read) and Wavefront OBJ. Callers write through io::write_file_atomic.
#include <array>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace mca::mesh {

struct FloatMesh {
  std::vector<std::array<float, 3>> vertices;
  std::vector<std::array<std::uint32_t, 3>> faces;
  // Optional, one per face (PLY: an int property of the face element, e.g. "fragment"); empty for none.
  std::vector<std::int32_t> face_values;
  std::string face_value_name = "value";
};

// A mesh's coordinates rounded to float32, for writing.
FloatMesh to_float(const TriMesh& m);

void write_ply(std::ostream& out, const FloatMesh& m);
// The same with double vertices ("property double x"): a mesh far from the origin, which float32 would fold.
void write_ply(std::ostream& out, const TriMesh& m);
void write_obj(std::ostream& out, const FloatMesh& m);

}  // namespace mca::mesh
