#include "mesh/mesh.hpp"

#include <algorithm>
#include <assimp/BaseImporter.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/importerdesc.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <cmath>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string_view>
#include <numeric>
#include <unordered_map>

#include "core/fnv.hpp"
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

// Read raw first (faces counted as the file has them), then these steps. Vertices are welded by convert,
// exactly: assimp's JoinIdenticalVertices merges vertices closer than 1e-5 in the file's units, which
// collapses a model written in metres at millimetre scale.
constexpr unsigned kRawSteps = aiProcess_ValidateDataStructure;
// Leaves the importer only the readers of `ext` (glTF has two: versions 1 and 2). When the readers an
// extension names refuse the data, assimp tries every other reader it has on the content, and some of
// those (OpenGEX, Blender, Terragen) overflow buffers, hang or allocate gigabytes on a few hundred hostile
// bytes (fuzz/findings/).
void only_reader_for(Assimp::Importer& importer, const std::string& ext) {
  std::vector<Assimp::BaseImporter*> others;
  for (std::size_t k = 0; k < importer.GetImporterCount(); ++k) {
    const aiImporterDesc* info = importer.GetImporterInfo(k);
    std::istringstream list(info && info->mFileExtensions ? info->mFileExtensions : "");
    std::string e;
    bool ours = false;
    while (list >> e) ours = ours || e == ext;
    if (!ours) others.push_back(importer.GetImporter(k));
  }
  for (auto* imp : others)
    if (importer.UnregisterLoader(imp) == aiReturn_SUCCESS) delete imp;  // unregistered, the importer is ours to free
}

// The files a mesh may make assimp open: those in its own folder and below (a glTF's buffers, an OBJ's
// material library), nothing else. A mesh file comes from anywhere; one naming "/etc/shadow" or
// "../../secret" as a buffer would otherwise turn that file's bytes into vertices written to the output.
// An empty folder allows nothing (data read from memory).
class FolderIOSystem : public Assimp::DefaultIOSystem {
 public:
  explicit FolderIOSystem(std::filesystem::path folder) : folder_(std::move(folder)) {}
  bool Exists(const char* file) const override { return allowed(file) && DefaultIOSystem::Exists(file); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return allowed(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
  }

 private:
  bool allowed(const char* file) const {
    if (folder_.empty() || !file) return false;
    std::error_code ec;
    const std::filesystem::path p = std::filesystem::weakly_canonical(file, ec);
    if (ec) return false;
    const auto rel = p.lexically_relative(folder_);
    return !rel.empty() && *rel.begin() != "..";
  }
  std::filesystem::path folder_;
};

constexpr unsigned kSteps = aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_PreTransformVertices |
                            aiProcess_ValidateDataStructure;

// What a PLY or OFF header declares, checked against the bytes before assimp sees them (assimp hangs on a
// PLY cut inside its header and aborts on one whose ASCII body is cut short).
struct Declared {
  std::uint64_t vertices = 0, faces = 0;
};

std::uint64_t to_count(const std::string& token, const std::string& name, const char* what) {
  std::uint64_t v = 0;
  if (token.empty() || token.size() > 12 || token.find_first_not_of("0123456789") != std::string::npos) {
    throw Error(fmt::format("{}: the header's {} count '{}' is not a number; the file is damaged", name, what, token));
  }
  v = std::stoull(token);
  if (v > 0xfffffff0ull) throw Error(fmt::format("{}: the header declares {} {}, more than mca reads (4e9)", name, v, what));
  return v;
}

Declared check_ply(const std::string& bytes, const std::string& name) {
  if (bytes.compare(0, 3, "ply") != 0) throw Error(fmt::format("{}: does not start with 'ply': not a PLY file", name));
  // "end_header" as a line of its own (assimp loops for ever on a header without one).
  std::size_t end = std::string::npos;
  for (std::size_t at = bytes.find("\nend_header"); at != std::string::npos; at = bytes.find("\nend_header", at + 1)) {
    const std::size_t after = at + 11;
    if (after == bytes.size() || bytes[after] == '\n' || bytes[after] == '\r' || bytes[after] == ' ' || bytes[after] == '\t') {
      end = at + 1;
      break;
    }
  }
  if (end == std::string::npos) {
    throw Error(fmt::format("{}: the PLY header has no end_header: the file is cut short or damaged", name));
  }
  std::size_t body = bytes.find('\n', end);
  body = body == std::string::npos ? bytes.size() : body + 1;
  std::istringstream header(bytes.substr(0, end));
  std::string line, format;
  struct Property {
    bool list = false;
    std::uint64_t bytes = 0, count_bytes = 0;  // a scalar's size; a list's count size and item size (bytes)
  };
  struct Element {
    std::string name;
    std::uint64_t count = 0;
    std::vector<Property> properties;
  };
  std::vector<Element> elements;
  auto size_of = [&](const std::string& type) -> std::uint64_t {
    if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
    if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
    if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32") return 4;
    if (type == "double" || type == "float64") return 8;
    throw Error(fmt::format("{}: the PLY header names an unknown property type '{}'; the file is damaged", name, type));
  };
  while (std::getline(header, line)) {
    std::istringstream words(line);
    std::string w;
    words >> w;
    if (w == "format") {
      words >> format;
    } else if (w == "element") {
      Element e;
      std::string count;
      words >> e.name >> count;
      e.count = to_count(count, name, e.name.c_str());
      elements.push_back(e);
    } else if (w == "property") {
      if (elements.empty()) throw Error(fmt::format("{}: a PLY property before any element; the file is damaged", name));
      std::string type;
      words >> type;
      Property p;
      if (type == "list") {
        std::string count_type, item_type;
        words >> count_type >> item_type;
        p.list = true;
        p.count_bytes = size_of(count_type);
        p.bytes = size_of(item_type);
      } else {
        p.bytes = size_of(type);
      }
      elements.back().properties.push_back(p);
    }
  }
  Declared d;
  for (const Element& e : elements) {
    if (e.name == "vertex") d.vertices = e.count;
    if (e.name == "face") d.faces = e.count;
  }
  auto cut_short = [&](const Element& e, std::uint64_t i) {
    return Error(fmt::format("{}: the PLY header declares {} vertices and {} faces, but the data ends inside {} {} of "
                             "{}: the file is cut short",
                             name, d.vertices, d.faces, e.name, i, e.count));
  };
  // Every element walked as the header describes it: a file cut anywhere is caught here, not in assimp.
  if (format == "ascii") {
    std::size_t at = body;
    for (const Element& e : elements) {
      for (std::uint64_t i = 0; i < e.count; ++i) {
        // One element per line; blank lines skipped.
        std::string_view row;
        do {
          if (at >= bytes.size()) throw cut_short(e, i);
          const std::size_t nl = std::min(bytes.find('\n', at), bytes.size());
          row = std::string_view(bytes).substr(at, nl - at);
          at = nl + 1;
        } while (row.find_first_not_of(" \t\r") == std::string_view::npos);
        std::istringstream values{std::string(row)};
        std::string v;
        for (const Property& p : e.properties) {
          if (!(values >> v)) throw cut_short(e, i);
          if (!p.list) continue;
          char* stop = nullptr;
          const unsigned long long n = std::strtoull(v.c_str(), &stop, 10);
          if (*stop != '\0' || n > 1u << 20) {
            throw Error(fmt::format("{}: {} {} has a list length '{}'; the file is damaged", name, e.name, i, v));
          }
          for (unsigned long long k = 0; k < n; ++k)
            if (!(values >> v)) throw cut_short(e, i);
        }
      }
    }
  } else if (format == "binary_little_endian" || format == "binary_big_endian") {
    const bool big = format == "binary_big_endian";
    std::uint64_t at = body;
    for (const Element& e : elements) {
      const bool fixed = std::none_of(e.properties.begin(), e.properties.end(), [](const Property& p) { return p.list; });
      if (fixed) {  // a fixed size: no walk (a header may declare 4e9 vertices)
        long double size = 0;
        for (const Property& p : e.properties) size += static_cast<long double>(p.bytes);
        if (static_cast<long double>(at) + size * static_cast<long double>(e.count) > static_cast<long double>(bytes.size())) {
          throw cut_short(e, std::min<std::uint64_t>(e.count, static_cast<std::uint64_t>((bytes.size() - std::min<std::uint64_t>(at, bytes.size())) / std::max<long double>(size, 1))));
        }
        at += static_cast<std::uint64_t>(size) * e.count;
        continue;
      }
      for (std::uint64_t i = 0; i < e.count; ++i) {
        for (const Property& p : e.properties) {
          if (!p.list) {
            at += p.bytes;
            continue;
          }
          if (at + p.count_bytes > bytes.size()) throw cut_short(e, i);
          std::uint64_t n = 0;
          for (std::uint64_t k = 0; k < p.count_bytes; ++k) {
            const auto byte = static_cast<std::uint8_t>(bytes[at + (big ? k : p.count_bytes - 1 - k)]);
            n = n << 8 | byte;
          }
          at += p.count_bytes + n * p.bytes;
        }
        if (at > bytes.size()) throw cut_short(e, i);
      }
    }
  } else {
    throw Error(fmt::format("{}: the PLY header's format '{}' is not ascii, binary_little_endian or "
                            "binary_big_endian; the file is damaged",
                            name, format));
  }
  return d;
}

// `clean`: the file without its comments and blank lines, for assimp (its OFF reader takes a comment
// between the vertices and the faces for a face).
Declared check_off(const std::string& bytes, const std::string& name, std::string& clean) {
  // "[ST][C][N][4][n]OFF", the counts "vertices faces [edges]" (on the same line or the next), then a
  // line per vertex and a line per face ("k i1 ... ik"); '#' starts a comment. assimp clamps a face's
  // out-of-range index to a valid one without a word, so the faces are checked here.
  std::istringstream in(bytes);
  std::string line;
  auto next_line = [&](std::vector<std::string>& words) {
    while (std::getline(in, line)) {
      line = line.substr(0, line.find('#'));
      std::istringstream ws(line);
      words.clear();
      std::string w;
      while (ws >> w) words.push_back(w);
      if (!words.empty()) {
        clean += line;
        clean += '\n';
        return true;
      }
    }
    return false;
  };
  std::vector<std::string> words;
  if (!next_line(words) || words[0].size() < 3 || words[0].compare(words[0].size() - 3, 3, "OFF") != 0) {
    throw Error(fmt::format("{}: does not start with OFF: not an OFF file", name));
  }
  if (words[0] != "OFF" && words[0] != "COFF" && words[0] != "NOFF" && words[0] != "CNOFF") {
    clean.clear();  // left to assimp as it is
    return {};
  }
  std::vector<std::string> counts(words.begin() + 1, words.end());
  if (counts.size() < 2) {
    if (!next_line(words)) throw Error(fmt::format("{}: the OFF header has no vertex and face counts: the file is cut short", name));
    counts = words;
  }
  if (counts.size() < 2) throw Error(fmt::format("{}: the OFF header has no face count: the file is damaged", name));
  Declared d;
  d.vertices = to_count(counts[0], name, "vertex");
  d.faces = to_count(counts[1], name, "face");
  for (std::uint64_t v = 0; v < d.vertices; ++v) {
    if (!next_line(words)) {
      throw Error(fmt::format("{}: declares {} vertices and {} faces but ends after {} vertices: it is cut short", name,
                              d.vertices, d.faces, v));
    }
  }
  for (std::uint64_t f = 0; f <= d.faces; ++f) {
    if (f == d.faces) {
      if (next_line(words)) {
        throw Error(fmt::format("{}: declares {} faces but has more lines after them ('{}'): its header's counts are "
                                "wrong or the file is damaged",
                                name, d.faces, line));
      }
      break;
    }
    if (!next_line(words)) {
      throw Error(fmt::format("{}: declares {} faces but ends after {}: it is cut short", name, d.faces, f));
    }
    char* end = nullptr;
    const unsigned long long k = std::strtoull(words[0].c_str(), &end, 10);
    if (*end != '\0' || k >= words.size()) {  // (k + 1 wraps for a count of 2^64 - 1)
      throw Error(fmt::format("{}: face {} ('{}') does not list its vertex count and that many vertices; the file is "
                              "damaged",
                              name, f, line));
    }
    for (unsigned long long i = 1; i <= k; ++i) {
      const long long idx = std::strtoll(words[i].c_str(), &end, 10);
      if (*end != '\0' || idx < 0 || static_cast<std::uint64_t>(idx) >= d.vertices) {
        throw Error(fmt::format("{}: face {} uses vertex '{}', but the file has {} vertices (0 to {}); the file is "
                                "damaged",
                                name, f, words[i], d.vertices, d.vertices - 1));
      }
    }
  }
  return d;
}

// A binary glTF's header and chunk lengths against its size (`head`: its first 20 bytes or more): assimp
// allocates whatever a chunk header declares (2.3 GB for a 621-byte file) before it reads anything.
void check_glb(const std::string& head, std::uint64_t size, const std::string& name) {
  auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    std::memcpy(&v, head.data() + at, 4);
    return v;  // little-endian, as the format and this machine
  };
  if (head.size() < 20 || head.compare(0, 4, "glTF") != 0) {
    throw Error(fmt::format("{}: does not start with a binary glTF header ('glTF' and 20 bytes): not a .glb file", name));
  }
  if (u32(4) != 2) {
    throw Error(fmt::format("{}: binary glTF version {}; mca reads version 2 (re-export it, e.g. from Blender)", name, u32(4)));
  }
  if (u32(8) > size) {
    throw Error(fmt::format("{}: its header says {} bytes, but the file has {}: it is cut short", name, u32(8), size));
  }
  if (static_cast<std::uint64_t>(u32(12)) + 20 > size) {
    throw Error(fmt::format("{}: its first chunk says {} bytes, more than the {} bytes the file has: it is cut short or "
                            "damaged",
                            name, u32(12), size));
  }
}

// Joins vertices at exactly the same coordinates (STL and most OBJ files store one per face corner), in
// order of first appearance.
void weld(TriMesh& m) {
  struct Key {
    double x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct Hash {
    std::size_t operator()(const Key& k) const {
      Fnv1a h;
      h.pod(k.x);
      h.pod(k.y);
      h.pod(k.z);
      return static_cast<std::size_t>(h.h);
    }
  };
  std::unordered_map<Key, std::uint32_t, Hash> first;
  first.reserve(m.vertices.size());
  std::vector<std::uint32_t> to(m.vertices.size());
  std::vector<Point> kept;
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    const Point& p = m.vertices[v];
    const Key k{p[0] == 0 ? 0.0 : p[0], p[1] == 0 ? 0.0 : p[1], p[2] == 0 ? 0.0 : p[2]};  // -0 is 0
    const auto [it, fresh] = first.try_emplace(k, static_cast<std::uint32_t>(kept.size()));
    if (fresh) kept.push_back(p);
    to[v] = it->second;
  }
  for (auto& f : m.faces)
    for (auto& v : f) v = to[v];
  m.vertices = std::move(kept);
}

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
  weld(m);
  if (m.faces.empty()) {
    throw Error(fmt::format("{}: {} vertices but no triangles{}; mca needs a surface of triangles (a point cloud must "
                            "be meshed first, e.g. by Poisson reconstruction in MeshLab or CloudCompare)",
                            name, m.vertices.size(),
                            points > 0 ? fmt::format(" (only {} points and lines)", points) : std::string()));
  }
  const Topology t = topology(m);
  if (t.degenerate_faces == m.faces.size()) {
    const Bounds b = bounds(m);
    double far = 0;
    for (int a = 0; a < 3; ++a) far = std::max({far, std::fabs(b.lo[a]), std::fabs(b.hi[a])});
    throw Error(fmt::format("{}: all {} triangles are degenerate (zero area: their corners lie on a line or "
                            "coincide); the file holds no surface{}",
                            name, m.faces.size(),
                            far > 1e4 * b.largest_extent()
                                ? fmt::format(" (its coordinates reach {:.3g} for a model {:.3g} across: single-precision "
                                              "coordinates that far out cannot tell its corners apart; move it to the "
                                              "origin in the file)",
                                              far, b.largest_extent())
                                : std::string()));
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

namespace {

// Reads with assimp (from the file, or from `bytes` when given), checking the faces the file declares.
TriMesh import(const std::string& name, const std::string& ext, const std::string* bytes, const std::string& path) {
  Declared declared;
  if (bytes && ext == "ply") declared = check_ply(*bytes, name);
  std::string clean_off;
  if (bytes && ext == "off") {
    declared = check_off(*bytes, name, clean_off);
    if (!clean_off.empty()) bytes = &clean_off;
  }
  if (bytes && ext == "glb") check_glb(*bytes, bytes->size(), name);
  Assimp::Importer importer;
  configure(importer);
  only_reader_for(importer, ext);
  std::error_code ec;
  importer.SetIOHandler(new FolderIOSystem(  // the importer owns it
      bytes ? std::filesystem::path() : std::filesystem::weakly_canonical(path, ec).parent_path()));
  const aiScene* raw = bytes ? importer.ReadFileFromMemory(bytes->data(), bytes->size(), kRawSteps, ext.c_str())
                             : importer.ReadFile(path, kRawSteps);
  if (!raw || (raw->mFlags & AI_SCENE_FLAGS_INCOMPLETE && raw->mNumMeshes == 0)) fail_import(importer, name, ext);
  std::uint64_t faces = 0;
  for (unsigned k = 0; k < raw->mNumMeshes; ++k) faces += raw->mMeshes[k]->mNumFaces;
  if (faces < declared.faces) {
    throw Error(fmt::format("{}: the header declares {} faces but {} could be read: the others use vertex indices out "
                            "of range (the file has {} vertices) or the file is cut short; repair or re-export it",
                            name, declared.faces, faces, declared.vertices));
  }
  const aiScene* scene = importer.ApplyPostProcessing(kSteps);
  if (!scene) fail_import(importer, name, ext);
  return convert(scene, name);
}

}  // namespace

TriMesh read_mesh(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(fmt::format("{}: no such mesh file", path));
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw Error(fmt::format("{}: is not a regular file (a directory, device or pipe); give a mesh file", path));
  }
  const std::string ext = lower_extension(path);
  if (!known_extension(ext)) {
    throw Error(fmt::format("{}: unknown mesh extension '{}'; mca reads {} (convert the file, e.g. with MeshLab or "
                            "Blender)",
                            path, ext.empty() ? "(none)" : "." + ext, extension_list()));
  }
  if (std::filesystem::file_size(path, ec) == 0) throw Error(fmt::format("{}: the file is empty", path));
  if (ext == "ply" || ext == "off") {
    // Checked before assimp reads them, from memory (neither format refers to other files).
    std::ifstream in(path, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in && !in.eof()) throw Error(fmt::format("{}: cannot be read: {}", path, std::strerror(errno)));
    return import(path, ext, &bytes, path);
  }
  if (ext == "glb") {
    // Read from the file (it may name buffers beside it), once its header is checked.
    std::ifstream in(path, std::ios::binary);
    std::string head(20, '\0');
    in.read(head.data(), 20);
    head.resize(static_cast<std::size_t>(in.gcount()));
    check_glb(head, std::filesystem::file_size(path, ec), path);
  }
  return import(path, ext, nullptr, path);
}

TriMesh read_mesh_memory(const void* data, std::size_t size, const std::string& extension, const std::string& name) {
  std::string ext = extension;
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (!known_extension(ext)) {
    throw Error(fmt::format("{}: unknown mesh format '{}'; mca reads {}", name, extension, extension_list()));
  }
  if (size == 0) throw Error(fmt::format("{}: the data is empty", name));
  const std::string bytes(static_cast<const char*>(data), size);
  return import(name, ext, &bytes, name);
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

double twice_area(const Point& a, const Point& b, const Point& c) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  const double x = u[1] * w[2] - u[2] * w[1], y = u[2] * w[0] - u[0] * w[2], z = u[0] * w[1] - u[1] * w[0];
  return std::sqrt(x * x + y * y + z * z);
}

namespace {

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
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2] || twice_area(a, b, c) <= 1e-14 * scale * scale) {
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

std::vector<Shell> shells(const TriMesh& m) {
  // Triangles joined through shared edges (two surfaces touching at a vertex stay two shells).
  const std::size_t nf = m.faces.size();
  std::vector<std::uint32_t> parent(nf);
  std::iota(parent.begin(), parent.end(), 0u);
  {
    std::unordered_map<std::uint64_t, std::uint32_t> first_face;
    first_face.reserve(nf * 2);
    for (std::uint32_t f = 0; f < nf; ++f)
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t u = m.faces[f][e], v = m.faces[f][(e + 1) % 3];
        if (u == v) continue;
        const auto [it, fresh] = first_face.try_emplace(u < v ? (std::uint64_t{u} << 32 | v) : (std::uint64_t{v} << 32 | u), f);
        if (!fresh) parent[find_root(parent, f)] = find_root(parent, it->second);
      }
  }
  std::vector<Shell> out;
  std::unordered_map<std::uint32_t, std::uint32_t> shell_of_root;
  for (std::uint32_t f = 0; f < nf; ++f) {
    const auto [it, fresh] = shell_of_root.try_emplace(find_root(parent, f), static_cast<std::uint32_t>(out.size()));
    if (fresh) out.emplace_back();
    out[it->second].faces.push_back(f);
  }
  for (Shell& sh : out) {
    sh.bounds.lo = {INFINITY, INFINITY, INFINITY};
    sh.bounds.hi = {-INFINITY, -INFINITY, -INFINITY};
    // Edges -> (face, direction); a manifold shell has each edge twice.
    std::unordered_map<std::uint64_t, std::vector<std::pair<std::uint32_t, bool>>> edges;
    // A triangle repeated (the same three vertices, a doubled surface) counts once.
    std::vector<std::array<std::uint32_t, 3>> sorted;
    for (auto f : sh.faces) {
      std::array<std::uint32_t, 3> t = m.faces[f];
      std::sort(t.begin(), t.end());
      sorted.push_back(t);
    }
    std::vector<std::uint32_t> order(sh.faces.size());
    std::iota(order.begin(), order.end(), 0u);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return sorted[a] < sorted[b]; });
    std::vector<std::uint32_t> unique_faces;
    for (std::size_t k = 0; k < order.size(); ++k)
      if (k == 0 || sorted[order[k]] != sorted[order[k - 1]]) unique_faces.push_back(sh.faces[order[k]]);
    std::sort(unique_faces.begin(), unique_faces.end());
    for (auto f : unique_faces) {
      const Triangle& t = m.faces[f];
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t u = t[e], v = t[(e + 1) % 3];
        for (int a = 0; a < 3; ++a) {
          sh.bounds.lo[a] = std::min(sh.bounds.lo[a], m.vertices[u][a]);
          sh.bounds.hi[a] = std::max(sh.bounds.hi[a], m.vertices[u][a]);
        }
        edges[u < v ? (std::uint64_t{u} << 32 | v) : (std::uint64_t{v} << 32 | u)].push_back({f, u < v});
      }
    }
    sh.manifold = std::all_of(edges.begin(), edges.end(), [](const auto& e) { return e.second.size() == 2; });
    // Orientation by breadth-first search: a neighbour across a manifold edge must run it the other way.
    std::unordered_map<std::uint32_t, std::int8_t> flip;  // face -> +1 kept, -1 turned
    flip.reserve(sh.faces.size());
    for (auto seed : unique_faces) {
      if (flip.count(seed)) continue;
      flip[seed] = 1;
      std::vector<std::uint32_t> queue{seed};
      while (!queue.empty()) {
        const std::uint32_t f = queue.back();
        queue.pop_back();
        const Triangle& t = m.faces[f];
        for (int e = 0; e < 3; ++e) {
          const std::uint32_t u = t[e], v = t[(e + 1) % 3];
          const auto& users = edges[u < v ? (std::uint64_t{u} << 32 | v) : (std::uint64_t{v} << 32 | u)];
          if (users.size() != 2) continue;
          const auto& other = users[0].first == f ? users[1] : users[0];
          const bool mine = users[0].first == f ? users[0].second : users[1].second;
          if (flip.count(other.first)) continue;
          // Same direction in the file: the neighbour is turned relative to this face.
          flip[other.first] = static_cast<std::int8_t>(other.second == mine ? -flip[f] : flip[f]);
          queue.push_back(other.first);
        }
      }
    }
    const Point c = sh.bounds.centre();
    double v6 = 0;
    for (auto f : unique_faces) {
      const Triangle& t = m.faces[f];
      Point p[3];
      for (int k = 0; k < 3; ++k)
        for (int a = 0; a < 3; ++a) p[k][a] = m.vertices[t[k]][a] - c[a];
      const double det = p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                         p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0]);
      v6 += flip[f] * det;
    }
    sh.volume = std::fabs(v6) / 6.0;
  }
  return out;
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
