#pragma once
// A glTF's JSON checked before assimp reads it, and assimp's meshes against what that JSON declares.
// assimp recurses over the JSON and the node hierarchy (a deep file overflowed its stack), takes a field of
// the wrong JSON type (a count of 4.0, a mode of "4") as missing, ignores extensions that change the
// geometry, and drops a triangle naming a vertex its primitive lacks, each without a word.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

struct aiScene;

namespace mca::mesh {

// A primitive of a glTF mesh, in file order (assimp makes one mesh of each): the triangles its indices (or,
// without indices, its vertices) make; 0 for points and lines (not compared).
struct GltfPrimitive {
  std::size_t mesh = 0, primitive = 0;
  std::uint64_t triangles = 0;
};

// What a glTF's JSON declares: its primitives, and whether it uses Draco compression (assimp's decoding of
// it fails on meshes of more than 65,535 vertices, with a message that blames the file).
struct GltfDeclared {
  std::vector<GltfPrimitive> primitives;
  bool draco = false;
};

// Checks the JSON of a .gltf file or a .glb's first chunk (`name`: the file, for messages) and returns what
// it declares. Throws mca::Error naming the field, its value and the fix, or where the JSON does not parse.
// `no_binary_chunk`: a .glb that ends after its JSON chunk (a buffer without a uri then has no bytes).
GltfDeclared check_gltf_json(std::string_view json, const std::string& name, bool no_binary_chunk = false);

// assimp's meshes (`raw`, read with no step after) against `declared`: a triangle assimp dropped is an
// error naming its primitive. Compares nothing where assimp made another count of meshes.
void check_gltf_triangles(const aiScene& raw, const std::vector<GltfPrimitive>& declared, const std::string& name);

}  // namespace mca::mesh
