#pragma once
// mca's own readers of the text and PLY mesh formats (mesh.cpp's read_mesh calls them): coordinates in
// double (assimp rounds every coordinate to float32, which moves a vertex 1e6 m out by up to 3 cm), the
// header's counts checked against the bytes before anything is allocated, nothing copied but the
// vertices and faces. Polygons are split into triangles as fans from their first corner (right for the
// convex faces every exporter writes). The meshes come back unwelded and unchecked: read_mesh welds
// and checks them as it does assimp's.
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>

#include "mesh/mesh.hpp"

namespace mca::mesh::detail {

// A UTF-8 byte order mark, which some Windows editors write before text (and files joined end to end
// carry at their parts' starts).
inline constexpr std::string_view kBom = "\xEF\xBB\xBF";

struct ReadResult {
  TriMesh mesh;
  std::size_t points_and_lines = 0;  // elements of fewer than three corners (left out)
  bool float32 = false;              // the file stores its coordinates in single precision (a PLY of floats)
};

// OFF, COFF, NOFF, CNOFF, STOFF (the corners' colours, normals and texture coordinates are skipped).
// `check` is called with the header's vertex and face counts once they are known to fit the bytes,
// before anything is allocated for them (it throws to refuse them).
ReadResult read_off(std::string_view bytes, const std::string& name,
                    const std::function<void(double vertices, double faces)>& check);
// Wavefront OBJ: "v" and "f" lines (v, v/t, v//n, v/t/n corners, negative indices from the end); other
// lines (normals, texture coordinates, groups, materials) are skipped.
ReadResult read_obj(std::string_view bytes, const std::string& name);
// PLY, ascii or binary: the vertex element's x, y, z (any numeric type) and the face element's
// vertex_indices (or vertex_index) list; other elements and properties are skipped.
ReadResult read_ply(std::string_view bytes, const std::string& name);

}  // namespace mca::mesh::detail
