#include "mesh/mesh.hpp"

#include <algorithm>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <cmath>
#include <filesystem>
#include <fmt/format.h>
#include <numeric>
#include <unordered_map>

#include "mca/error.hpp"

namespace mca::mesh {
namespace {

std::string lower_extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  if (!e.empty() && e[0] == '.') e.erase(0, 1);
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return e;
}

bool known_extension(const std::string& e) {
  const auto& all = mesh_extensions();
  return std::find(all.begin(), all.end(), e) != all.end();
}

std::string extension_list() { return fmt::format(".{}", fmt::join(mesh_extensions(), ", .")); }

void configure(Assimp::Importer& importer) {
  // Normals, texture coordinates and colours are dropped before welding: files that store them per face
  // corner (STL, most OBJ) would otherwise keep every corner a vertex of its own (the cow as STL: 17,400
  // vertices instead of 2,903).
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS |
                                                          aiComponent_COLORS | aiComponent_TEXCOORDS |
                                                          aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                                          aiComponent_TEXTURES | aiComponent_LIGHTS |
                                                          aiComponent_CAMERAS | aiComponent_MATERIALS);
}

constexpr unsigned kSteps = aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_JoinIdenticalVertices |
                            aiProcess_PreTransformVertices | aiProcess_ValidateDataStructure;

// All triangles of the file's meshes in one TriMesh (points and lines are counted, not kept).
TriMesh convert(const aiScene* scene, const std::string& name) {
  TriMesh m;
  std::size_t points = 0, other = 0;
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
    const aiMesh* am = scene->mMeshes[k];
    const auto base = static_cast<std::uint64_t>(m.vertices.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
      if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
        throw Error(fmt::format("{}: vertex {} of mesh {} has a coordinate that is not a finite number ({}, {}, {}); "
                                "repair or re-export the file",
                                name, v, k, p.x, p.y, p.z));
      }
      m.vertices.push_back({p.x, p.y, p.z});
    }
    if (m.vertices.size() > 0xfffffff0u) throw Error(fmt::format("{}: more than 4e9 vertices", name));
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) {
        (face.mNumIndices < 3 ? points : other) += 1;
        continue;
      }
      Triangle t{};
      for (int c = 0; c < 3; ++c) {
        if (face.mIndices[c] >= am->mNumVertices) {
          throw Error(fmt::format("{}: face {} of mesh {} uses vertex {}, but the mesh has {} vertices", name, f, k,
                                  face.mIndices[c], am->mNumVertices));
        }
        t[c] = static_cast<std::uint32_t>(base + face.mIndices[c]);
      }
      m.faces.push_back(t);
    }
  }
  if (m.vertices.empty()) {
    throw Error(fmt::format("{}: the file holds no vertices (an empty mesh); export the model again", name));
  }
  if (m.faces.empty()) {
    throw Error(fmt::format("{}: {} vertices but no triangles{}; mca needs a surface of triangles (a point cloud must "
                            "be meshed first, e.g. by Poisson reconstruction in MeshLab or CloudCompare)",
                            name, m.vertices.size(),
                            points > 0 ? fmt::format(" (only {} points and lines)", points) : std::string()));
  }
  const Topology t = topology(m);
  if (t.degenerate_faces == m.faces.size()) {
    throw Error(fmt::format("{}: all {} triangles are degenerate (zero area: their corners lie on a line or "
                            "coincide); the file holds no surface",
                            name, m.faces.size()));
  }
  return m;
}

[[noreturn]] void fail_import(const Assimp::Importer& importer, const std::string& name, const std::string& ext) {
  if (std::string(importer.GetErrorString()).find("contains no faces") != std::string::npos) {
    throw Error(fmt::format("{}: vertices but no triangles; mca needs a surface of triangles (a point cloud must be "
                            "meshed first, e.g. by Poisson reconstruction in MeshLab or CloudCompare)",
                            name));
  }
  throw Error(fmt::format("{}: cannot be read as a .{} mesh: {}; check that the file is a {} file (the extension "
                          "picks the reader) and not damaged",
                          name, ext, importer.GetErrorString(), ext == "glb" ? "binary glTF" : ext));
}

}  // namespace

const std::vector<std::string>& mesh_extensions() {
  static const std::vector<std::string> all = {"obj", "ply", "stl", "off", "gltf", "glb"};
  return all;
}

TriMesh read_mesh(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(fmt::format("{}: no such mesh file", path));
  if (!std::filesystem::is_regular_file(path, ec)) throw Error(fmt::format("{}: is not a file", path));
  const std::string ext = lower_extension(path);
  if (!known_extension(ext)) {
    throw Error(fmt::format("{}: unknown mesh extension '{}'; mca reads {} (convert the file, e.g. with MeshLab or "
                            "Blender)",
                            path, ext.empty() ? "(none)" : "." + ext, extension_list()));
  }
  if (std::filesystem::file_size(path, ec) == 0) throw Error(fmt::format("{}: the file is empty", path));
  Assimp::Importer importer;
  configure(importer);
  const aiScene* scene = importer.ReadFile(path, kSteps);
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE && scene->mNumMeshes == 0)) fail_import(importer, path, ext);
  return convert(scene, path);
}

TriMesh read_mesh_memory(const void* data, std::size_t size, const std::string& extension, const std::string& name) {
  std::string ext = extension;
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (!known_extension(ext)) {
    throw Error(fmt::format("{}: unknown mesh format '{}'; mca reads {}", name, extension, extension_list()));
  }
  if (size == 0) throw Error(fmt::format("{}: the data is empty", name));
  Assimp::Importer importer;
  configure(importer);
  const aiScene* scene = importer.ReadFileFromMemory(data, size, kSteps, ext.c_str());
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE && scene->mNumMeshes == 0)) fail_import(importer, name, ext);
  return convert(scene, name);
}

double Bounds::largest_extent() const {
  const Point e = extent();
  return std::max({e[0], e[1], e[2]});
}

Bounds bounds(const TriMesh& m) {
  Bounds b;
  b.lo = {INFINITY, INFINITY, INFINITY};
  b.hi = {-INFINITY, -INFINITY, -INFINITY};
  // Only the vertices that triangles use: a stray vertex far away would otherwise move the centre.
  for (const Triangle& t : m.faces)
    for (auto v : t)
      for (int a = 0; a < 3; ++a) {
        b.lo[a] = std::min(b.lo[a], m.vertices[v][a]);
        b.hi[a] = std::max(b.hi[a], m.vertices[v][a]);
      }
  if (m.faces.empty()) b.lo = b.hi = {0, 0, 0};
  return b;
}

namespace {
double triangle_area2(const Point& a, const Point& b, const Point& c) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2], z = u[0] * w[1] - u[1] * w[0];
  return std::sqrt(x * x + y * y + z * z);
}

std::uint32_t find_root(std::vector<std::uint32_t>& parent, std::uint32_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}
}  // namespace

Topology topology(const TriMesh& m) {
  Topology t;
  std::unordered_map<std::uint64_t, std::uint32_t> uses;
  uses.reserve(m.faces.size() * 2);
  for (const Triangle& f : m.faces) {
    const Point &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
    const double scale = std::max({std::fabs(a[0]), std::fabs(a[1]), std::fabs(a[2]), 1e-300});
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || triangle_area2(a, b, c) <= 1e-14 * scale * scale) {
      ++t.degenerate_faces;
      if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) continue;
    }
    for (int e = 0; e < 3; ++e) {
      const std::uint32_t u = f[e], v = f[(e + 1) % 3];
      ++uses[u < v ? (std::uint64_t{u} << 32 | v) : (std::uint64_t{v} << 32 | u)];
    }
  }
  t.edges = uses.size();
  std::vector<std::uint32_t> parent(m.vertices.size());
  std::iota(parent.begin(), parent.end(), 0u);
  std::vector<std::uint8_t> on_rim(m.vertices.size(), 0);
  for (const auto& [key, n] : uses) {
    if (n >= 3) ++t.non_manifold_edges;
    if (n != 1) continue;
    ++t.boundary_edges;
    const auto u = static_cast<std::uint32_t>(key >> 32), v = static_cast<std::uint32_t>(key & 0xffffffffu);
    on_rim[u] = on_rim[v] = 1;
    parent[find_root(parent, u)] = find_root(parent, v);
  }
  // Holes: the rims (connected boundary edges), each measured by its bounding box.
  std::unordered_map<std::uint32_t, Bounds> rims;
  for (std::uint32_t v = 0; v < m.vertices.size(); ++v) {
    if (!on_rim[v]) continue;
    auto [it, fresh] = rims.try_emplace(find_root(parent, v));
    Bounds& b = it->second;
    for (int a = 0; a < 3; ++a) {
      b.lo[a] = fresh ? m.vertices[v][a] : std::min(b.lo[a], m.vertices[v][a]);
      b.hi[a] = fresh ? m.vertices[v][a] : std::max(b.hi[a], m.vertices[v][a]);
    }
  }
  t.holes = rims.size();
  for (const auto& [root, b] : rims) {
    const Point e = b.extent();
    t.largest_hole = std::max(t.largest_hole, std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]));
  }
  return t;
}

double signed_volume(const TriMesh& m) {
  // About the box centre: a model far from the origin would lose its volume to rounding.
  const Point o = bounds(m).centre();
  auto at = [&](std::uint32_t i) { return Point{m.vertices[i][0] - o[0], m.vertices[i][1] - o[1], m.vertices[i][2] - o[2]}; };
  double v = 0;
  for (const Triangle& f : m.faces) {
    const Point a = at(f[0]), b = at(f[1]), c = at(f[2]);
    v += a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return v / 6.0;
}

}  // namespace mca::mesh
