#include "mesh/mesh.hpp"

#include <algorithm>
#include <array>
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
#include <optional>
#include <limits>
#include <sstream>
#include <string_view>
#include <numeric>
#include <unordered_map>
#include <unordered_set>

#include "core/environment.hpp"
#include "core/files.hpp"
#include "core/fnv.hpp"
#include "core/text.hpp"
#include "mesh/gltf_check.hpp"
#include "mesh/readers.hpp"
#include "mca/error.hpp"

namespace mca::mesh {
namespace {

std::string lower_extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  if (!e.empty() && e[0] == '.') e.erase(0, 1);
  return text::lower(e);
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

// What reading a mesh costs beyond its bytes: per vertex its coordinates, the weld's table and the
// indices (about 120 bytes), per triangle its corners and the edge tables of the topology (about 150);
// assimp holds its own copy of the mesh besides (about 6 times the bytes of an STL or glTF).
constexpr double kBytesPerVertex = 120, kBytesPerTriangle = 150, kAssimpBytesPerFileByte = 6;

// The files a mesh may make assimp open: regular files in its own folder and below (a glTF's buffers, an
// OBJ's material library), nothing else. A mesh file comes from anywhere; one naming "/etc/shadow" or
// "../../secret" as a buffer would otherwise turn that file's bytes into vertices written to the output,
// one naming a FIFO there would hang the read for ever, and one naming a file of 20 GB would have assimp
// read it whole: the files opened count against the memory limit, as the mesh file itself does. An
// empty folder allows nothing (data read from memory). Why a file was not opened is kept (`refusal`): it
// is the message where the import then fails.
class FolderIOSystem : public Assimp::DefaultIOSystem {
 public:
  // `mesh`: the mesh file itself (counted against the limit before: refuse_over_memory).
  FolderIOSystem(std::filesystem::path folder, double max_memory_bytes, const std::string& mesh = {})
      : folder_(std::move(folder)), max_bytes_(max_memory_bytes) {
    std::error_code ec;
    if (!mesh.empty()) mesh_ = std::filesystem::canonical(mesh, ec).string();
  }
  // Names come bare (a .gltf read from memory: "buf.bin"): the mesh's folder is put before them, as assimp puts
  // it before the names of a file it opens.
  void names_come_bare() { bare_ = true; }
  bool Exists(const char* bare) const override {
    const std::string named = in_folder(bare);
    const char* given = named.c_str();
    const std::string file = on_disk(given);
    return allowed(file.c_str()) && DefaultIOSystem::Exists(file.c_str());
  }
  Assimp::IOStream* Open(const char* bare, const char* mode) override {
    const std::string named_in_folder = in_folder(bare);
    const char* given = named_in_folder.c_str();
    // (A data URI in capitals, "DATA:...", is a file name to assimp: its whole base64 was shown.)
    if (const std::string named = as_named(given); named.size() >= 5) {
      if (text::lower(named.substr(0, 5)) == "data:") {
        if (refusal_.empty())
          refusal_ = fmt::format("it names {}, a data URI the reader mca uses takes only in lower case (\"data:\"): "
                                 "write its scheme so",
                                 shortened(named));
        return nullptr;
      }
    }
    const std::string decoded = on_disk(given);
    const char* file = decoded.c_str();
    if (!allowed(file)) return nullptr;
    // (assimp, refused a buffer outside the folder or not finding it where it is named, tries a file of its
    // name in the folder: another file, which it would read in silence in its stead.)
    const std::string name = std::filesystem::path(file).filename().string();
    std::error_code ec;
    if (!std::filesystem::exists(file, ec)) {
      // (An absolute name: "folder//abs/path".)
      const std::string named = as_named(file);
      if (refusal_.empty())
        refusal_ = !named.empty() && named[0] == '/'
                       ? fmt::format("it names the absolute path {}; mca reads the files a mesh names relative to "
                                     "its folder: name it so",
                                     shortened(named))
                       : fmt::format("it names {}, which is not there; give it the file it should read",
                                     shortened(file));
      refused_names_.insert(name);
      return nullptr;
    }
    if (refused_names_.count(name)) return nullptr;
    // Each buffer that names a file is read on its own, the same file too (twelve buffers naming one file of
    // 1 GB took 13 GB).
    const std::filesystem::path p = std::filesystem::canonical(file, ec);
    if (!ec && p.string() != mesh_) {
      const auto size = static_cast<double>(std::filesystem::file_size(p, ec));
      if (ec) return nullptr;
      // (Bounded as the mesh file is: refuse_over_memory.)
      if (const MemoryLimit limit = memory_limit(max_bytes_); kAssimpBytesPerFileByte * (read_ + size) > limit.bytes) {
        refusal_ = fmt::format("it names {} ({:.4g} MB), and reading it with the rest would take about {:.3g} GB, {}; "
                               "{}, or export the model with smaller buffers",
                               p.string(), size / 1e6, kAssimpBytesPerFileByte * (read_ + size) / 1e9, limit.over,
                               limit.instead);
        return nullptr;
      }
      read_ += size;
    }
    return DefaultIOSystem::Open(file, mode);
  }
  const std::string& refusal() const { return refusal_; }

 private:
  std::string in_folder(const char* name) const {
    if (!name) return {};
    return bare_ && !folder_.empty() ? folder_.string() + "/" + name : std::string(name);
  }
  // The name as the file gave it: assimp puts the mesh's folder and "/" before every name (an absolute one
  // too); empty where `path` does not start so.
  std::string as_named(const char* path) const {
    if (!path || folder_.empty()) return {};
    const std::string f = path, prefix = folder_.string() + "/";
    return f.rfind(prefix, 0) == 0 ? f.substr(prefix.size()) : std::string();
  }
  // A name for a message: at most 200 characters (a data URI can be megabytes).
  static std::string shortened(const std::string& s) {
    return s.size() <= 200 ? text::utf8_shown(s) : text::utf8_shown(s.substr(0, 200)) + "...";
  }
  // `given` with its URI escapes decoded ("my%20model.bin" is "my model.bin", as Blender writes a buffer's
  // name), where no file has the name as given and one has it decoded (assimp does not decode them).
  static std::string on_disk(const char* given) {
    if (!given) return {};
    const std::string f = given;
    if (f.find('%') == std::string::npos) return f;
    std::string d;
    const auto hex = [](char c) {
      return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
    };
    for (std::size_t i = 0; i < f.size(); ++i) {
      if (f[i] == '%' && i + 2 < f.size() && hex(f[i + 1]) >= 0 && hex(f[i + 2]) >= 0) {
        d += static_cast<char>(hex(f[i + 1]) * 16 + hex(f[i + 2]));
        i += 2;
      } else {
        d += f[i];
      }
    }
    // (%00 would end the name early: "nul%00.bin" named the file "nul".)
    if (d.find('\0') != std::string::npos) return f;
    std::error_code ec;
    return !std::filesystem::exists(f, ec) && std::filesystem::exists(d, ec) ? d : f;
  }
  bool allowed(const char* file) const {
    if (folder_.empty() || !file) return false;
    std::error_code ec;
    const std::filesystem::path p = std::filesystem::weakly_canonical(file, ec);
    if (ec) return false;
    const auto rel = p.lexically_relative(folder_);
    if (rel.empty() || *rel.begin() == "..") {
      refused_names_.insert(p.filename().string());
      refusal_ = fmt::format("it names {}, outside the mesh's folder {}: mca reads only files in the mesh's folder "
                             "and below; copy the file there and name it relative to the mesh",
                             p.string(), folder_.string());
      return false;
    }
    // (A FIFO or a device would block the read, or never end it.)
    if (std::filesystem::exists(p, ec) && !std::filesystem::is_regular_file(p, ec)) {
      refusal_ = fmt::format("it names {}, which is not a regular file (a FIFO, a device or a folder); give it the "
                             "file it should read",
                             p.string());
      return false;
    }
    return true;
  }
  std::filesystem::path folder_;
  bool bare_ = false;
  double max_bytes_;
  double read_ = 0;
  std::string mesh_;
  mutable std::unordered_set<std::string> refused_names_;
  mutable std::string refusal_;
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
  if (token.empty() || token.find_first_not_of("0123456789") != std::string::npos) {
    throw Error(fmt::format("{}: the header's {} count '{}' is not a number; the file is damaged", name, what, token));
  }
  if (token.size() > 12) {  // (as OFF's: a whole number too large, not "not a number")
    throw Error(fmt::format("{}: the header declares {} '{}' elements, more than mca reads (4e9)", name, token, what));
  }
  v = std::stoull(token);
  if (v > 0xfffffff0ull)
    throw Error(fmt::format("{}: the header declares {} '{}' elements, more than mca reads (4e9)", name, v, what));
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
  if (end > (1u << 20)) {
    throw Error(fmt::format("{}: the PLY header is {} bytes long (end_header comes that late), more than any "
                            "exporter writes (1 MB): the file is damaged",
                            name, end));
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
          if (row.size() > (1u << 20)) {
            throw Error(fmt::format("{}: {} {} is a line of {} bytes, more than any exporter writes (1 MB): the file "
                                    "is damaged",
                                    name, e.name, i, row.size()));
          }
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
    // A line past the elements (a header that declares fewer than the file holds): the faces beyond its
    // count were left out without a word. (The OFF reader refuses the same.)
    // (Padding, NUL or end-of-file bytes, is no face.)
    for (std::size_t nl; at < bytes.size(); at = nl + 1) {
      nl = std::min(bytes.find('\n', at), bytes.size());
      const std::string_view row = std::string_view(bytes).substr(at, nl - at);
      if (row.find_first_not_of(std::string_view(" \t\r\0\x1a", 5)) != std::string_view::npos) {
        throw Error(fmt::format("{}: declares {} vertices and {} faces but has more lines after them ('{}'): its "
                                "header's counts are wrong or the file is damaged; export the model again",
                                name, d.vertices, d.faces, text::utf8_shown(row.substr(0, 60))));
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
    // Bytes past the elements (a header that declares fewer than the file holds): the faces beyond its
    // count were left out without a word. (Padding, line ends or zeros, is no face.)
    if (at < bytes.size() && std::string_view(bytes).substr(at).find_first_not_of(std::string_view(" \t\r\n\0", 5)) !=
                                 std::string_view::npos) {
      throw Error(fmt::format("{}: {} bytes follow the {} vertices and {} faces its header declares: its counts are "
                              "wrong or the file is damaged; export the model again",
                              name, bytes.size() - at, d.vertices, d.faces));
    }
  } else {
    throw Error(fmt::format("{}: the PLY header's format '{}' is not ascii, binary_little_endian or "
                            "binary_big_endian; the file is damaged",
                            name, format));
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

// What every reader's mesh goes through: finite coordinates, identical vertices welded, some triangle
// that is not degenerate. `points`: elements of fewer than three corners the reader left out.
// `precision`: to what the file rounds its coordinates, for a message (kSingle, kDouble, kText).
constexpr const char* kSingle = "the 7 digits of the file's single precision";
constexpr const char* kDouble = "the 16 digits of the file's double precision";
constexpr const char* kText = "the digits the file writes (16 at most count)";
TriMesh finish(TriMesh m, const std::string& name, std::size_t points, const char* precision) {
  for (std::size_t v = 0; v < m.vertices.size(); ++v) {
    const Point& p = m.vertices[v];
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) {
      throw Error(fmt::format("{}: vertex {} has a coordinate that is not a finite number ({}, {}, {}); repair or "
                              "re-export the file",
                              name, v, p[0], p[1], p[2]));
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
  const Bounds b = bounds(m);
  double far = 0;
  for (int a = 0; a < 3; ++a) far = std::max({far, std::fabs(b.lo[a]), std::fabs(b.hi[a])});
  if (b.largest_extent() == 0) {
    throw Error(fmt::format("{}: {} at one point ({:.6g}, {:.6g}, {:.6g}): the file holds no surface; export the "
                            "model again",
                            name, m.vertices.size() == 1 ? std::string("its one vertex lies")
                                                         : fmt::format("all its {} vertices lie", m.vertices.size()),
                            b.lo[0], b.lo[1], b.lo[2]));
  }
  // Areas and volumes are squares and cubes of the coordinates, and an area's test squares its edges'
  // products: beyond 1e75 (or a model under 1e-75 across) they leave a double, and every triangle would read
  // as degenerate.
  if (far > 1e75 || b.largest_extent() < 1e-75) {
    throw Error(fmt::format("{}: its coordinates reach {:.3g} for a model {:.3g} across, beyond what mca computes with "
                            "(areas and volumes leave the range of a double); scale the model in the file (object "
                            "scale and fit_size apply after it is read)",
                            name, far, b.largest_extent()));
  }
  const Topology t = topology(m);
  if (t.degenerate_faces == m.faces.size()) {
    throw Error(fmt::format("{}: all {} triangles are degenerate (zero area: their corners lie on a line or "
                            "coincide); the file holds no surface{}",
                            name, m.faces.size(),
                            far > 1e4 * b.largest_extent()
                                ? fmt::format(" (its coordinates reach {:.3g} for a model {:.3g} across: coordinates "
                                              "that far out, rounded to {}, cannot tell its corners apart; move it "
                                              "to the origin in the file)",
                                              far, b.largest_extent(), precision)
                                : std::string()));
  }
  return m;
}

TriMesh convert(const aiScene* scene, const std::string& name) {
  TriMesh m;
  std::size_t points = 0, other = 0;
  for (unsigned k = 0; k < scene->mNumMeshes; ++k) {
    const aiMesh* am = scene->mMeshes[k];
    const auto base = static_cast<std::uint64_t>(m.vertices.size());
    for (unsigned v = 0; v < am->mNumVertices; ++v) {
      const aiVector3D& p = am->mVertices[v];
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
  return finish(std::move(m), name, points, kSingle);  // (assimp's formats here store float32)
}

// assimp's message, for one of ours: at most 300 characters (it may quote megabytes: a data URI it took for a
// file name).
std::string assimp_error(const Assimp::Importer& importer) {
  const std::string why = importer.GetErrorString();
  return why.size() <= 300 ? why : text::utf8_shown(std::string_view(why).substr(0, 300)) + "...";
}

[[noreturn]] void fail_import(const Assimp::Importer& importer, const std::string& name, const std::string& ext) {
  if (std::string(importer.GetErrorString()).find("contains no faces") != std::string::npos) {
    throw Error(fmt::format("{}: vertices but no triangles; mca needs a surface of triangles (a point cloud must be "
                            "meshed first, e.g. by Poisson reconstruction in MeshLab or CloudCompare)",
                            name));
  }
  const std::string why = assimp_error(importer);
  // (A glTF of a scene without meshes, an exported Empty, reads as no scene and no message.)
  if (why.empty())
    throw Error(fmt::format("{}: holds no mesh (an empty scene: export the model's mesh objects with it)", name));
  throw Error(fmt::format("{}: cannot be read as a .{} mesh: {}; check that the file is a {} file (the extension "
                          "picks the reader) and not damaged",
                          name, ext, why, ext == "glb" ? "binary glTF" : ext));
}

}  // namespace

const std::vector<std::string>& mesh_extensions() {
  static const std::vector<std::string> all = {"obj", "ply", "stl", "off", "gltf", "glb"};
  return all;
}

namespace {

std::string read_file(const std::string& path, std::uint64_t size);

// Reads with assimp (from the file, or from `bytes` when given): STL, glTF and GLB, whose coordinates are
// float32 in the file.
TriMesh import_assimp(const std::string& name, const std::string& ext, const std::string* bytes,
                      const std::string& path, double max_memory_bytes) {
  if (bytes && ext == "glb") check_glb(*bytes, bytes->size(), name);
  GltfDeclared declared;
  // A .glb of its JSON chunk alone, without a binary one (its buffers data URIs or files beside it, as glTF
  // allows): assimp reads a buffer's bytes from a binary chunk there and refused it ("Buffer view out of
  // range"); it is read as the .gltf its JSON is.
  std::string json_only;
  if (ext == "gltf" || ext == "glb") {
    // The JSON: the whole .gltf, or the .glb's first chunk (check_glb: its length fits the file).
    std::error_code ec;
    const std::string file = bytes ? std::string() : read_file(path, std::filesystem::file_size(path, ec));
    const std::string_view all = bytes ? std::string_view(*bytes) : std::string_view(file);
    if (ext == "gltf") {
      declared = check_gltf_json(all, name);
    } else if (all.size() >= 20) {
      std::uint32_t length = 0;
      std::memcpy(&length, all.data() + 12, 4);
      // (A chunk's header is 8 bytes: a file with no room for one more after its JSON holds no binary chunk. Its
      // bytes, not its header's total, which may be wrong while a binary chunk follows.)
      const bool alone = all.size() < std::uint64_t{28} + length;
      declared = check_gltf_json(all.substr(20, length), name, alone);
      if (alone) json_only = all.substr(20, length);
    }
  }
  Assimp::Importer importer;
  configure(importer);
  only_reader_for(importer, ext);
  std::error_code ec;
  auto* io = new FolderIOSystem(bytes ? std::filesystem::path() : std::filesystem::weakly_canonical(path, ec).parent_path(),
                                max_memory_bytes, bytes ? std::string() : path);
  if (!json_only.empty()) io->names_come_bare();
  importer.SetIOHandler(io);  // (the importer owns it)
  const aiScene* raw = !json_only.empty() ? importer.ReadFileFromMemory(json_only.data(), json_only.size(), kRawSteps, "gltf")
                       : bytes           ? importer.ReadFileFromMemory(bytes->data(), bytes->size(), kRawSteps, ext.c_str())
                                         : importer.ReadFile(path, kRawSteps);
  if (!raw || (raw->mFlags & AI_SCENE_FLAGS_INCOMPLETE && raw->mNumMeshes == 0)) {
    if (!io->refusal().empty()) throw Error(fmt::format("{}: cannot be read: {}", name, io->refusal()));
    // (assimp's Draco decoding fails on a mesh of more than 65,535 vertices, and says the file is damaged.)
    if (declared.draco)
      throw Error(fmt::format("{}: cannot be read: it is compressed with Draco (KHR_draco_mesh_compression), and the "
                              "reader mca uses failed on it ({}); it decodes Draco meshes of up to 65,535 vertices: "
                              "export the model without Draco compression (in Blender: untick Compression)",
                              name, assimp_error(importer)));
    fail_import(importer, name, ext);
  }
  if (ext == "gltf" || ext == "glb") check_gltf_triangles(*raw, declared.primitives, name);
  const aiScene* scene = importer.ApplyPostProcessing(kSteps);
  if (!scene) fail_import(importer, name, ext);
  return convert(scene, name);
}

// What reading may take: solver.max_memory_gb, and 90 % of the machine's memory where that is less (as a
// model: mca::memory_limit): a sparse file of 30 GB under the default 16 GB was read whole on a machine of
// 23 GB, until the system's memory ran out.
void refuse_over_memory(const std::string& name, double need, double max_bytes, const std::string& what) {
  const MemoryLimit limit = memory_limit(max_bytes);
  if (need <= limit.bytes) return;
  throw Error(fmt::format("{}: reading it would take about {:.3g} GB ({}), {}; {}, or simplify the mesh (MeshLab: "
                          "Filters > Remeshing, Simplification and Reconstruction > Quadric Edge Collapse Decimation)",
                          name, need / 1e9, what, limit.over, limit.instead));
}

// The vertex and face counts a PLY or OFF file declares in its first bytes (`head`), to weigh the file
// before it is read: each at most what `size` bytes can hold (an element takes a byte or more; counts the
// file cannot hold are the reader's to refuse, with its own message), and zero where they are not there or
// not whole numbers (the reader then says what is wrong).
Declared declared_counts(std::string_view head, const std::string& ext, std::uint64_t size) {
  Declared d;
  const auto count = [&](const std::string& word) -> std::uint64_t {
    if (word.empty() || word.size() > 19 || word.find_first_not_of("0123456789") != std::string::npos) return 0;
    return std::min<std::uint64_t>(std::stoull(word), size);
  };
  std::istringstream in{std::string(head.substr(0, ext == "ply" ? head.find("end_header") : head.size()))};
  if (ext == "ply") {
    for (std::string line; std::getline(in, line);) {
      std::istringstream w(line);
      std::string key, element, n;
      w >> key >> element >> n;
      if (key == "element" && element == "vertex") d.vertices = count(n);
      if (key == "element" && element == "face") d.faces = count(n);
    }
  } else if (ext == "off") {
    std::vector<std::string> words;  // the words of the lines that are not comments, until the counts
    for (std::string line; words.size() < 3 && std::getline(in, line);) {
      std::istringstream w(line.substr(0, line.find('#')));
      for (std::string word; w >> word;) words.push_back(word);
    }
    if (words.size() >= 3 && words[0].ends_with("OFF")) {
      d.vertices = count(words[1]);
      d.faces = count(words[2]);
    }
  }
  return d;
}

std::string mb(double bytes) {
  return bytes >= 1e9 ? fmt::format("{:.4g} GB", bytes / 1e9) : fmt::format("{:.4g} MB", bytes / 1e6);
}

// Whether an STL of `size` bytes whose first bytes are `head` is binary: 84 + 50 N bytes for the N
// triangles its header declares.
bool stl_binary(std::string_view head, std::uint64_t size) {
  std::uint32_t n = 0;
  if (head.size() >= 84) std::memcpy(&n, head.data() + 80, 4);
  return size >= 84 && 84 + 50 * static_cast<std::uint64_t>(n) == size;
}

using detail::kBom;

// `text` without the byte order marks at the starts of its lines (files saved with one, then joined end to
// end: assimp's STL reader took a second solid's "\xEF\xBB\xBFsolid" for the end and left it out).
std::string without_line_boms(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (std::size_t at = 0; at < text.size();) {
    while (text.substr(at, kBom.size()) == kBom) at += kBom.size();
    const std::size_t nl = std::min(text.find('\n', at), text.size());
    out.append(text.substr(at, nl + 1 - at));
    at = nl + 1;
  }
  return out;
}

// An ASCII STL's last line that is not blank opens with "endsolid" (`tail`: the file's last bytes, up to
// 1 MB): one cut short lost its last triangles without a word from assimp (half of them in a file cut in
// half; a second solid cut short behind a whole first one).
void check_stl_end(std::string_view tail, const std::string& name) {
  const std::size_t last = tail.find_last_not_of(" \t\r\n");
  std::string_view line;
  if (last != std::string_view::npos) {
    const std::size_t start = tail.find_last_of('\n', last);
    const std::size_t first = start == std::string_view::npos ? 0 : start + 1;
    line = tail.substr(first, last + 1 - first);
    while (line.substr(0, kBom.size()) == kBom) line.remove_prefix(kBom.size());
    line.remove_prefix(std::min(line.size(), line.find_first_not_of(" \t")));
  }
  if (line.substr(0, 8) != "endsolid") {
    throw Error(fmt::format("{}: an ASCII STL whose last line is not its closing 'endsolid' ('{}'): the file is cut "
                            "short, or text follows its last solid; export it again",
                            name, text::utf8_shown(line.substr(0, 60))));
  }
}

// An ASCII STL's text for assimp: its end checked (check_stl_end), the byte order marks at its lines'
// starts left out (without_line_boms); nullopt where it has none (the text as it is). (From memory: an STL
// names no other file.)
std::optional<std::string> ascii_stl_text(std::string_view bytes, const std::string& name) {
  check_stl_end(bytes.substr(bytes.size() - std::min<std::size_t>(bytes.size(), 1 << 20)), name);
  if (bytes.find(kBom) == std::string_view::npos) return std::nullopt;
  return without_line_boms(bytes);
}

// The format's signature in the first bytes of the file (`head`; `size`: the whole file's), checked before
// the file is read: a file of zeros or of another format is refused at once, whatever its size.
void check_head(std::string_view head, std::uint64_t size, const std::string& ext, const std::string& name) {
  const bool nul = head.find('\0') != std::string_view::npos;
  // A UTF-8 byte order mark, which some Windows editors write before text: skipped before the text formats
  // (their readers skip it too), named before PLY and glTF, whose readers do not take it.
  const std::size_t bom = head.substr(0, kBom.size()) == kBom ? kBom.size() : 0;
  const bool text_format = ext == "off" || ext == "obj" || (ext == "stl" && !stl_binary(head, size));
  if (bom && (ext == "ply" || ext == "gltf"))
    throw Error(fmt::format("{}: starts with a UTF-8 byte order mark (bytes EF BB BF), which the reader of {} files "
                            "does not take: save it without one (as \"UTF-8\", not \"UTF-8 with BOM\")",
                            name, ext == "ply" ? "PLY" : "glTF"));
  // Text in UTF-16 or UTF-32 (a byte order mark FF FE or FE FF, then two or four bytes a character), as some
  // Windows programs save it.
  if (const int wide = text::wide_unicode_bom(head); wide && (text_format || ext == "ply" || ext == "gltf"))
    throw Error(fmt::format("{}: is text in UTF-{} (it starts with its byte order mark); mca reads it in ASCII or "
                            "UTF-8: save it as UTF-8",
                            name, wide));
  auto first_word = [&](std::string_view comment) {
    std::size_t i = bom;
    for (;;) {
      while (i < head.size() && std::isspace(static_cast<unsigned char>(head[i]))) ++i;
      if (i < head.size() && comment.find(head[i]) != std::string_view::npos) {
        i = head.find('\n', i);
        if (i == std::string_view::npos) return std::string_view();
        continue;
      }
      const std::size_t start = i;
      while (i < head.size() && !std::isspace(static_cast<unsigned char>(head[i])) && head[i] != '#') ++i;
      return head.substr(start, i - start);
    }
  };
  if (ext == "ply") {
    if (head.substr(0, 3) != "ply" || (head.size() > 3 && head[3] != '\n' && head[3] != '\r'))
      throw Error(fmt::format("{}: does not start with 'ply': not a PLY file", name));
  } else if (ext == "off") {
    // (A head of nothing but comments is left to the reader, which reads on.)
    const std::string_view w = first_word("#");
    if (w.empty() ? head.size() == size : w.size() < 3 || w.substr(w.size() - 3) != "OFF")
      throw Error(fmt::format("{}: does not start with OFF: not an OFF file", name));
    // "OFF BINARY": the binary variant, whose numbers are bytes after that line (the key's line, its comment
    // left out).
    if (!w.empty()) {
      const std::size_t from = static_cast<std::size_t>(w.data() - head.data());
      const std::size_t end = head.find('\n', from);
      std::string_view line = head.substr(from, end == std::string_view::npos ? end : end - from);
      line = line.substr(0, line.find('#'));
      std::string upper(line);
      for (char& c : upper) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      std::istringstream words(upper);
      std::string word;
      bool binary = false;
      while (words >> word) binary = binary || word == "BINARY";
      if (binary) {
        throw Error(fmt::format("{}: is a binary OFF file ('{}'); mca reads OFF as text: convert it (e.g. in MeshLab: "
                                "File > Export Mesh As, .off or .ply)",
                                name, text::utf8_shown(line.substr(0, 40))));
      }
    }
    if (nul) throw Error(fmt::format("{}: holds NUL bytes: not a text file, so not an OFF file", name));
  } else if (ext == "obj") {
    if (nul) throw Error(fmt::format("{}: holds NUL bytes: not a text file, so not an OBJ file", name));
    // Another text format under the name .obj (its reader would find no 'v' line and call it empty).
    const std::string_view w = first_word("#");
    const bool off = w.size() >= 3 && w.size() <= 5 && w.substr(w.size() - 3) == "OFF";
    if (off || w == "ply" || w == "solid")
      throw Error(fmt::format("{}: starts with '{}': {} file, not OBJ; give it the extension .{}", name, w,
                              off ? "an OFF" : w == "ply" ? "a PLY" : "an ASCII STL", off ? "off" : w == "ply" ? "ply" : "stl"));
  } else if (ext == "stl") {
    std::uint32_t n = 0;
    if (head.size() >= 84) std::memcpy(&n, head.data() + 80, 4);
    const bool binary = stl_binary(head, size);
    const bool ascii = !nul && first_word("") == "solid";
    if (!binary && !ascii) {
      throw Error(fmt::format("{}: cannot be read as a .stl mesh: it is neither a binary STL (84 + 50 N bytes for the N "
                              "triangles its header declares: {} declared, {} bytes) nor an ASCII STL (text starting "
                              "with 'solid'); the file is damaged or not an STL file",
                              name, n, size));
    }
  } else if (ext == "gltf") {
    const std::string_view t = head.substr(bom);
    const std::size_t i = t.find_first_not_of(" \t\r\n");
    if (nul || i == std::string_view::npos || t[i] != '{')
      throw Error(fmt::format("{}: does not start with '{{': not a glTF file (JSON)", name));
  } else if (ext == "glb") {
    check_glb(std::string(head.substr(0, 20)), size, name);
  }
}

// Reads `bytes` of format `ext` (after check_head): mca's readers for the text and PLY formats, assimp
// for the rest (`path`: the file, for formats that name other files; empty for data in memory).
TriMesh import(const std::string& name, const std::string& ext, const std::string* bytes, const std::string& path,
               double max_bytes) {
  if (ext == "off" || ext == "obj" || ext == "ply") {
    const std::string_view b(*bytes);
    auto check = [&](double vertices, double triangles) {
      refuse_over_memory(name, static_cast<double>(b.size()) + kBytesPerVertex * vertices + kBytesPerTriangle * triangles,
                         max_bytes, fmt::format("a file of {} with {:.0f} vertices and {:.0f} triangles", mb(b.size()),
                                                vertices, triangles));
    };
    if (ext == "ply") {
      const Declared d = check_ply(*bytes, name);
      check(static_cast<double>(d.vertices), static_cast<double>(d.faces));
    } else if (ext == "obj") {
      // Its "v" lines and the triangles of its "f" lines, counted before anything is stored.
      double vertices = 0, triangles = 0;
      for (std::size_t at = 0; at < b.size();) {
        const std::size_t nl = std::min(b.find('\n', at), b.size());
        const std::string_view line = b.substr(at, nl - at);
        at = nl + 1;
        if (line.size() < 2 || (line[1] != ' ' && line[1] != '\t')) continue;
        if (line[0] == 'v') ++vertices;
        if (line[0] == 'f') triangles += std::max<double>(1, static_cast<double>(std::count(line.begin(), line.end(), ' ')) - 2);
      }
      check(vertices, triangles);
    }
    detail::ReadResult r = ext == "off" ? detail::read_off(b, name, check) : ext == "obj" ? detail::read_obj(b, name)
                                                                                   : detail::read_ply(b, name);
    return finish(std::move(r.mesh), name, r.points_and_lines,
                  ext != "ply" ? kText : r.float32 ? kSingle : kDouble);
  }
  return import_assimp(name, ext, bytes, path, max_bytes);
}

std::string read_file(const std::string& path, std::uint64_t size) {
  std::ifstream in(path, std::ios::binary);
  std::string bytes(size, '\0');
  in.read(bytes.data(), static_cast<std::streamsize>(size));
  if (in.bad()) throw Error(fmt::format("{}: cannot be read: {}", path, std::strerror(errno)));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  return bytes;
}

}  // namespace

bool float32_format(const std::string& path_or_extension) {
  std::string e = lower_extension(path_or_extension);
  if (e.empty()) e = path_or_extension;
  if (e == "ply") {
    // A PLY says in its header: its vertices' x as float (float32) or double. (A file that cannot be read
    // here is refused by the reader.)
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path_or_extension, ec)) return false;
    const std::string head = read_file(path_or_extension, std::min<std::uint64_t>(
                                                              std::filesystem::file_size(path_or_extension, ec), 1 << 16));
    std::istringstream lines(head.substr(0, head.find("end_header")));
    bool vertex = false;
    for (std::string line; std::getline(lines, line);) {
      std::istringstream w(line);
      std::string a, b, c;
      w >> a >> b >> c;
      if (a == "element") vertex = b == "vertex";
      if (vertex && a == "property" && c == "x") return b == "float" || b == "float32";
    }
    return false;
  }
  return e == "stl" || e == "gltf" || e == "glb";
}

TriMesh read_mesh(const std::string& path, double max_memory_bytes) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(fmt::format("{}: no such mesh file", path));
  files::require_regular_file(path, "a mesh file", "give the path of a mesh file");
  const std::string ext = lower_extension(path);
  if (!known_extension(ext)) {
    throw Error(fmt::format("{}: unknown mesh extension '{}'; mca reads {} (convert the file, e.g. with MeshLab or "
                            "Blender)",
                            path, ext.empty() ? "(none)" : "." + ext, extension_list()));
  }
  const std::uint64_t size = std::filesystem::file_size(path, ec);
  if (size == 0) throw Error(fmt::format("{}: the file is empty", path));
  // The signature first, from the first 64 KB; then the size against the memory limit; then the file.
  const std::string head = read_file(path, std::min<std::uint64_t>(size, 1 << 16));
  check_head(head, size, ext, path);
  if (ext == "off" || ext == "obj" || ext == "ply") {
    // The counts a header declares weighed before the file is read (a sparse file of 4 GB declaring 3e8
    // vertices was read whole, then refused for them).
    const Declared d = declared_counts(head, ext, size);
    refuse_over_memory(path,
                       static_cast<double>(size) + kBytesPerVertex * static_cast<double>(d.vertices) +
                           kBytesPerTriangle * static_cast<double>(d.faces),
                       max_memory_bytes,
                       d.vertices || d.faces
                           ? fmt::format("a file of {} declaring {} vertices and {} faces", mb(size), d.vertices, d.faces)
                           : fmt::format("a file of {}", mb(size)));
    const std::string bytes = read_file(path, size);
    return import(path, ext, &bytes, path, max_memory_bytes);
  }
  refuse_over_memory(path, kAssimpBytesPerFileByte * static_cast<double>(size), max_memory_bytes,
                     fmt::format("a file of {}, read by assimp", mb(size)));
  if (ext == "stl" && !stl_binary(head, size)) {
    // (Read here for its end and its byte order marks; without any, assimp reads the file itself.)
    if (const std::optional<std::string> text = ascii_stl_text(read_file(path, size), path))
      return import(path, ext, &*text, path, max_memory_bytes);
  }
  return import(path, ext, nullptr, path, max_memory_bytes);
}

TriMesh read_mesh_memory(const void* data, std::size_t size, const std::string& extension, const std::string& name,
                         double max_memory_bytes) {
  const std::string ext = text::lower(extension);
  if (!known_extension(ext)) {
    throw Error(fmt::format("{}: unknown mesh format '{}'; mca reads {}", name, extension, extension_list()));
  }
  if (size == 0) throw Error(fmt::format("{}: the data is empty", name));
  const std::string_view view(static_cast<const char*>(data), size);
  check_head(view.substr(0, 1 << 16), size, ext, name);
  if (ext != "off" && ext != "obj" && ext != "ply")
    refuse_over_memory(name, kAssimpBytesPerFileByte * static_cast<double>(size), max_memory_bytes,
                       fmt::format("{} of data, read by assimp", mb(size)));
  std::optional<std::string> text;
  if (ext == "stl" && !stl_binary(view, size)) text = ascii_stl_text(view, name);
  const std::string bytes = text ? std::move(*text) : std::string(view);
  return import(name, ext, &bytes, name, max_memory_bytes);
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

double height_across_longest_edge(const Point& a, const Point& b, const Point& c) {
  const double longest = std::max({std::hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]),
                                   std::hypot(c[0] - b[0], c[1] - b[1], c[2] - b[2]),
                                   std::hypot(a[0] - c[0], a[1] - c[1], a[2] - c[2])});
  return longest > 0 ? twice_area(a, b, c) / longest : 0;
}

bool zero_area(const TriMesh& m, const Triangle& f) {
  if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) return true;
  const Point &a = m.vertices[f[0]], &b = m.vertices[f[1]], &c = m.vertices[f[2]];
  double edge = 0, far = 0;
  for (int k = 0; k < 3; ++k) {
    edge = std::max({edge, std::fabs(b[k] - a[k]), std::fabs(c[k] - b[k]), std::fabs(a[k] - c[k])});
    far = std::max({far, std::fabs(a[k]), std::fabs(b[k]), std::fabs(c[k])});
  }
  // (Coordinates rounded by up to eps |x| move a line's corners off it by that much: an area of about
  // that times the edge.)
  constexpr double eps = std::numeric_limits<double>::epsilon();
  return twice_area(a, b, c) <= std::max(1e-14 * edge * edge, 16 * eps * far * edge);
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
    if (zero_area(m, f)) {
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
  std::uint32_t largest = 0;
  for (const auto& [root, b] : rims) {
    const Point e = b.extent();
    const double across = std::sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]);
    if (across > t.largest_hole || t.largest_hole == 0) largest = root;
    t.largest_hole = std::max(t.largest_hole, across);
  }
  // The largest rim's width: 4 A / P of its vector area A and length P (a round hole's diameter, twice a
  // slot's width; near 0 for a seam whose two sides meet without sharing vertices, a T-junction or
  // vertices a hair apart, which the extent above reads as a hole as wide as the seam is long). Each rim
  // edge runs as its one triangle runs it; about the rim's box centre (far from the origin).
  if (t.holes > 0) {
    const Point c = rims.at(largest).centre();
    double area[3] = {0, 0, 0}, length = 0;
    for (const Triangle& f : m.faces) {
      if (zero_area(m, f) && (f[0] == f[1] || f[1] == f[2] || f[0] == f[2])) continue;
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t u = f[e], v = f[(e + 1) % 3];
        if (uses[u < v ? (std::uint64_t{u} << 32 | v) : (std::uint64_t{v} << 32 | u)] != 1) continue;
        if (find_root(parent, u) != largest) continue;
        const double a[3] = {m.vertices[u][0] - c[0], m.vertices[u][1] - c[1], m.vertices[u][2] - c[2]};
        const double b[3] = {m.vertices[v][0] - c[0], m.vertices[v][1] - c[1], m.vertices[v][2] - c[2]};
        area[0] += 0.5 * (a[1] * b[2] - a[2] * b[1]);
        area[1] += 0.5 * (a[2] * b[0] - a[0] * b[2]);
        area[2] += 0.5 * (a[0] * b[1] - a[1] * b[0]);
        length += std::sqrt((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
      }
    }
    const double A = std::sqrt(area[0] * area[0] + area[1] * area[1] + area[2] * area[2]);
    t.largest_hole_width = length > 0 ? 4 * A / length : 0;
  }
  return t;
}

std::vector<std::uint32_t> unique_triangles(const TriMesh& m, const std::vector<std::uint32_t>* faces) {
  const std::size_t n = faces ? faces->size() : m.faces.size();
  std::vector<std::array<std::uint32_t, 4>> keys(n);  // sorted vertices, face
  for (std::size_t k = 0; k < n; ++k) {
    const std::uint32_t f = faces ? (*faces)[k] : static_cast<std::uint32_t>(k);
    std::array<std::uint32_t, 3> v = m.faces[f];
    std::sort(v.begin(), v.end());
    keys[k] = {v[0], v[1], v[2], f};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<std::uint32_t> out;
  out.reserve(n);
  for (std::size_t k = 0; k < n; ++k)
    if (k == 0 || !std::equal(keys[k].begin(), keys[k].begin() + 3, keys[k - 1].begin())) out.push_back(keys[k][3]);
  std::sort(out.begin(), out.end());
  return out;
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
    const std::vector<std::uint32_t> unique_faces = unique_triangles(m, &sh.faces);
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

void keep_faces(TriMesh& m, std::vector<Triangle>&& faces) {
  std::vector<std::uint32_t> number(m.vertices.size(), 0xffffffffu);
  std::vector<Point> vertices;
  for (auto& t : faces)
    for (auto& v : t) {
      if (number[v] == 0xffffffffu) {
        number[v] = static_cast<std::uint32_t>(vertices.size());
        vertices.push_back(m.vertices[v]);
      }
      v = number[v];
    }
  m.vertices = std::move(vertices);
  m.faces = std::move(faces);
}

std::size_t drop_small_shells(TriMesh& m, double small) {
  const std::size_t nv = m.vertices.size();
  std::vector<std::uint32_t> root(nv);
  std::iota(root.begin(), root.end(), 0u);
  for (const auto& f : m.faces)
    for (int e = 1; e < 3; ++e) {
      const std::uint32_t a = find_root(root, f[0]), b = find_root(root, f[e]);
      if (a != b) root[std::max(a, b)] = std::min(a, b);
    }
  // Each shell's box, kept at its root (a vertex no triangle uses is a shell of its own, and small).
  std::vector<Bounds> box(nv, Bounds{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}});
  for (std::uint32_t v = 0; v < nv; ++v) {
    Bounds& b = box[find_root(root, v)];
    for (int c = 0; c < 3; ++c) {
      b.lo[c] = std::min(b.lo[c], m.vertices[v][c]);
      b.hi[c] = std::max(b.hi[c], m.vertices[v][c]);
    }
  }
  std::vector<std::uint8_t> small_shell(nv, 0);
  std::size_t shells = 0, dropped = 0;
  for (const auto& f : m.faces) {
    const std::uint32_t r = find_root(root, f[0]);
    if (small_shell[r]) continue;
    const Point e = box[r].extent();
    small_shell[r] = e[0] < small && e[1] < small && e[2] < small ? 1 : 2;
    ++shells;
    dropped += small_shell[r] == 1;
  }
  if (dropped == 0 || dropped == shells) return 0;
  std::vector<Triangle> faces;
  faces.reserve(m.faces.size());
  for (const auto& f : m.faces)
    if (small_shell[find_root(root, f[0])] == 2) faces.push_back(f);
  keep_faces(m, std::move(faces));
  return dropped;
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
