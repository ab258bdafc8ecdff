#include "mesh/gltf_check.hpp"

#include <assimp/scene.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <nlohmann/json.hpp>
#include <cmath>
#include <optional>
#include <set>
#include <utility>

#include "mca/error.hpp"

namespace mca::mesh {
namespace {

using Json = nlohmann::json;

// Exporters write a few levels of each; assimp recursed once per level (a file of 449 KB, a chain of
// 20,000 nodes or arrays nested 100,000 deep, overflowed its stack).
constexpr int kMaxJsonDepth = 64, kMaxNodeDepth = 256;

// Extensions that change a mesh's shape or number, which the reader mca uses (assimp 5.2) does not apply:
// it read the mesh as if they were not there (one instance of many, quantized positions as garbage).
struct GeometryExtension {
  const char* name;
  const char* what;
  bool even_if_optional;  // refused when only used: what a reader without it shows is not the model
};
constexpr std::array<GeometryExtension, 2> kGeometryExtensions = {{
    {"EXT_mesh_gpu_instancing",
     "instances of its meshes (the reader mca uses would read each mesh once): export with the instances made "
     "real (in Blender: Object > Apply > Make Instances Real)",
     true},
    {"EXT_meshopt_compression",
     "compressed buffers (meshoptimizer) that the reader mca uses does not decode: export without compression "
     "(gltfpack: leave out -c)",
     false},
}};

// Extensions a file may require: those that only change how a model looks, and those whose effect on the
// shape is checked here (KHR_mesh_quantization: positions must be floats; Draco: decoded by assimp).
bool may_require(const std::string& e) {
  for (const char* prefix : {"KHR_materials_", "KHR_texture_", "EXT_texture_", "MSFT_texture_", "KHR_lights_"})
    if (e.rfind(prefix, 0) == 0) return true;
  return e == "KHR_xmp_json_ld" || e == "KHR_mesh_quantization" || e == "KHR_draco_mesh_compression";
}

class Checker {
 public:
  Checker(const Json& j, const std::string& name) : j_(j), name_(name) {}

  [[noreturn]] void damaged(const std::string& what) const {
    throw Error(fmt::format("{}: {}: the file is damaged or its exporter wrote it wrong; export the model again", name_,
                            what));
  }

  // A field glTF gives as a whole number 0 or more (an index or a count), if there: the reader mca uses
  // takes any other JSON value (4.0, "4", null) as missing.
  // (-0 is 0, as the reader mca uses takes it; 36e0 or 36.0 is not a whole number to it.)
  static bool whole_number(const Json& v) {
    return v.is_number_unsigned() || (v.is_number_integer() && v.get<std::int64_t>() >= 0);
  }
  static std::string field(const std::string& path, const std::string& key) { return path.empty() ? key : path + "." + key; }
  static std::string written_as(const Json& v) {
    if (v.is_number_float() && v.get<double>() >= 0 && v.get<double>() == std::floor(v.get<double>()) &&
        v.get<double>() < 1e15)
      return fmt::format("; write it as {}", static_cast<std::uint64_t>(v.get<double>()));
    return "";
  }
  void whole(const Json& object, const char* key, const std::string& path) const {
    if (!object.is_object() || !object.contains(key)) return;
    const Json& v = object[key];
    if (!whole_number(v))
      damaged(fmt::format("{} is {}, where glTF gives a whole number 0 or more{} (the reader mca uses would take it "
                          "as missing)",
                          field(path, key), v.dump(), written_as(v)));
  }
  void whole_each(const Json& object, const char* key, const std::string& path) const {
    if (!object.is_object() || !object.contains(key) || !object[key].is_array()) return;
    const Json& a = object[key];
    for (std::size_t k = 0; k < a.size(); ++k)
      if (!whole_number(a[k]))
        damaged(fmt::format("{}[{}] is {}, where glTF gives a whole number 0 or more{}", field(path, key), k,
                            a[k].dump(), written_as(a[k])));
  }
  static std::uint64_t number(const Json& v) { return static_cast<std::uint64_t>(v.get<std::int64_t>()); }
  // An accessor's element count (checked by fields), 0 where it gives none.
  static std::uint64_t count(const Json& accessor) { return accessor.contains("count") ? number(accessor["count"]) : 0; }
  // The array `key` of the file's top level (empty where it is not there or not an array).
  const Json& list(const char* key) const {
    static const Json none = Json::array();
    return j_.contains(key) && j_[key].is_array() ? j_[key] : none;
  }

  void fields() const {
    whole(j_, "scene", "");
    const Json& scenes = list("scenes");
    for (std::size_t i = 0; i < scenes.size(); ++i) whole_each(scenes[i], "nodes", fmt::format("scenes[{}]", i));
    const Json& nodes = list("nodes");
    for (std::size_t i = 0; i < nodes.size(); ++i)
      for (const char* key : {"mesh", "camera", "skin"}) whole(nodes[i], key, fmt::format("nodes[{}]", i));
    const Json& meshes = list("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      if (!meshes[m].is_object() || !meshes[m].contains("primitives") || !meshes[m]["primitives"].is_array()) continue;
      const Json& prims = meshes[m]["primitives"];
      for (std::size_t p = 0; p < prims.size(); ++p) {
        const std::string path = fmt::format("meshes[{}].primitives[{}]", m, p);
        for (const char* key : {"indices", "material", "mode"}) whole(prims[p], key, path);
        if (prims[p].is_object() && prims[p].contains("attributes") && prims[p]["attributes"].is_object())
          for (const auto& [attribute, v] : prims[p]["attributes"].items())
            whole(prims[p]["attributes"], attribute.c_str(), path + ".attributes");
      }
    }
    const Json& accessors = list("accessors");
    for (std::size_t i = 0; i < accessors.size(); ++i) {
      const std::string path = fmt::format("accessors[{}]", i);
      for (const char* key : {"bufferView", "byteOffset", "componentType", "count"}) whole(accessors[i], key, path);
      if (!accessors[i].is_object() || !accessors[i].contains("sparse")) continue;
      const Json& sparse = accessors[i]["sparse"];
      whole(sparse, "count", path + ".sparse");
      for (const char* part : {"indices", "values"}) {
        if (!sparse.is_object() || !sparse.contains(part)) continue;
        for (const char* key : {"bufferView", "byteOffset", "componentType"})
          whole(sparse[part], key, fmt::format("{}.sparse.{}", path, part));
      }
    }
    const Json& views = list("bufferViews");
    for (std::size_t i = 0; i < views.size(); ++i)
      for (const char* key : {"buffer", "byteOffset", "byteLength", "byteStride", "target"})
        whole(views[i], key, fmt::format("bufferViews[{}]", i));
    const Json& buffers = list("buffers");
    for (std::size_t i = 0; i < buffers.size(); ++i) whole(buffers[i], "byteLength", fmt::format("buffers[{}]", i));
  }

  // Refuses the extensions the reader mca uses does not apply to the shape; returns whether the file uses
  // Draco compression.
  bool extensions() const {
    std::set<std::string> required, used;
    for (const auto& [key, into] : {std::pair<const char*, std::set<std::string>*>{"extensionsRequired", &required},
                                    {"extensionsUsed", &used}})
      for (const Json& e : list(key))
        if (e.is_string()) into->insert(e.get<std::string>());
    // (A node may carry one without the file listing it, which is invalid; it is used all the same.)
    for (const Json& node : list("nodes"))
      if (node.is_object() && node.contains("extensions") && node["extensions"].is_object())
        for (const auto& [e, v] : node["extensions"].items()) used.insert(e);
    for (const GeometryExtension& g : kGeometryExtensions) {
      const bool req = required.count(g.name) > 0;
      if (req || (g.even_if_optional && used.count(g.name)))
        throw Error(fmt::format("{}: {} the glTF extension {}: {}", name_, req ? "requires" : "uses", g.name, g.what));
    }
    for (const std::string& e : required) {
      if (may_require(e)) continue;
      throw Error(fmt::format("{}: requires the glTF extension {}, which the reader mca uses does not know: what it "
                              "would read may not be the model; export it without {}",
                              name_, e, e));
    }
    return used.count("KHR_draco_mesh_compression") > 0 || required.count("KHR_draco_mesh_compression") > 0;
  }

  // The accessor `index` names for `what` (validated by fields: a whole number), which must be there.
  const Json& accessor(const Json& index, const std::string& what) const {
    const Json& accessors = list("accessors");
    const std::uint64_t k = number(index);
    if (k >= accessors.size())
      damaged(fmt::format("{} names accessors[{}], but the file has {} accessors", what, k, accessors.size()));
    return accessors[k];
  }

  std::vector<GltfPrimitive> primitives() const {
    std::vector<GltfPrimitive> all;
    const Json& meshes = list("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      const Json& mesh = meshes[m];
      if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) continue;
      morphs(mesh, m);
      for (std::size_t p = 0; p < mesh["primitives"].size(); ++p) {
        const Json& prim = mesh["primitives"][p];
        const std::string path = fmt::format("meshes[{}].primitives[{}]", m, p);
        GltfPrimitive g{m, p, 0};
        const std::uint64_t mode = prim.is_object() && prim.contains("mode") ? number(prim["mode"]) : 4;
        if (mode > 6)
          damaged(fmt::format("{}.mode is {}; glTF's modes are 0 to 6 (0 points, 1 to 3 lines, 4 triangles, 5 a "
                              "strip, 6 a fan)",
                              path, mode));
        const bool indexed = prim.is_object() && prim.contains("indices");
        std::uint64_t n = 0;
        if (indexed) {
          const Json& a = accessor(prim["indices"], path + ".indices");
          const std::uint64_t type = a.contains("componentType") ? number(a["componentType"]) : 0;
          if (a.value("type", std::string()) != "SCALAR" || (type != 5121 && type != 5123 && type != 5125))
            damaged(fmt::format("{}.indices names accessors[{}], of type {} and componentType {}, where indices are "
                                "SCALAR of unsigned bytes, shorts or ints (5121, 5123, 5125)",
                                path, number(prim["indices"]), a.value("type", Json()).dump(),
                                a.value("componentType", Json()).dump()));
          n = count(a);
        }
        if (prim.is_object() && prim.contains("attributes") && prim["attributes"].is_object() &&
            prim["attributes"].contains("POSITION")) {
          const Json& a = accessor(prim["attributes"]["POSITION"], path + ".attributes.POSITION");
          if (a.value("type", std::string()) != "VEC3" || !a.contains("componentType") || number(a["componentType"]) != 5126)
            damaged(fmt::format("{}.attributes.POSITION names accessors[{}], of type {} and componentType {}, where "
                                "positions are VEC3 of floats (5126; quantized positions, KHR_mesh_quantization, the "
                                "reader mca uses does not scale back: export without, e.g. gltfpack -noq)",
                                path, number(prim["attributes"]["POSITION"]),
                                a.value("type", Json()).dump(), a.value("componentType", Json()).dump()));
          if (!indexed) n = count(a);
        }
        if (mode == 4) {
          if (n % 3 != 0)
            damaged(fmt::format("{} lists {} {}, which is not a whole number of triangles (3 each)", path, n,
                                indexed ? "indices" : "vertices"));
          g.triangles = n / 3;
        } else if (mode == 5 || mode == 6) {
          g.triangles = n >= 3 ? n - 2 : 0;
        }
        all.push_back(g);
      }
    }
    return all;
  }

  // A mesh whose morph targets are weighted (a node's weights, else its own): assimp reads its base shape.
  void morphs(const Json& mesh, std::size_t m) const {
    const bool targets = std::any_of(mesh["primitives"].begin(), mesh["primitives"].end(), [](const Json& p) {
      return p.is_object() && p.contains("targets") && p["targets"].is_array() && !p["targets"].empty();
    });
    if (!targets) return;
    // Whether `o`'s weights (if it has them) shape the mesh; nullopt where it gives none.
    auto weighted = [&](const Json& o, const std::string& path) -> std::optional<bool> {
      if (!o.is_object() || !o.contains("weights")) return std::nullopt;
      if (!o["weights"].is_array()) damaged(fmt::format("{}.weights is {}, where glTF gives an array of numbers", path, o["weights"].dump()));
      bool any = false;
      for (std::size_t k = 0; k < o["weights"].size(); ++k) {
        const Json& w = o["weights"][k];
        if (!w.is_number())
          damaged(fmt::format("{}.weights[{}] is {}, where glTF gives a number", path, k, w.dump()));
        any = any || w.get<double>() != 0;
      }
      return any;
    };
    const std::optional<bool> own = weighted(mesh, fmt::format("meshes[{}]", m));
    bool shaped = false, placed = false;
    const Json& nodes = list("nodes");
    for (std::size_t k = 0; k < nodes.size(); ++k) {
      if (!nodes[k].is_object() || !nodes[k].contains("mesh") || number(nodes[k]["mesh"]) != m) continue;
      placed = true;
      shaped = shaped || weighted(nodes[k], fmt::format("nodes[{}]", k)).value_or(own.value_or(false));
    }
    if (!placed) shaped = own.value_or(false);
    if (shaped)
      throw Error(fmt::format("{}: meshes[{}] is shaped by its morph targets (weights not 0), which the reader mca "
                              "uses does not apply (it reads the base shape): apply them in the program that wrote "
                              "it (in Blender: Object > Apply > Visual Geometry to Mesh, or apply the shape keys), "
                              "then export again",
                              name_, m));
  }

  // The node hierarchy: children that are nodes, no cycle, at most kMaxNodeDepth levels (iteratively).
  void hierarchy() const {
    const Json& nodes = list("nodes");
    const std::size_t n = nodes.size();
    std::vector<std::vector<std::size_t>> children(n);
    std::vector<char> is_child(n, 0);
    for (std::size_t k = 0; k < n; ++k) {
      if (!nodes[k].is_object() || !nodes[k].contains("children") || !nodes[k]["children"].is_array()) continue;
      for (const auto& c : nodes[k]["children"]) {
        if (!whole_number(c) || number(c) >= n) {
          throw Error(fmt::format("{}: nodes[{}] names a child {} that is not one of its {} nodes: the file is "
                                  "damaged",
                                  name_, k, c.dump(), n));
        }
        children[k].push_back(static_cast<std::size_t>(number(c)));
        is_child[static_cast<std::size_t>(number(c))] = 1;
      }
    }
    std::vector<int> state(n, 0);  // 0 unseen, 1 on the current path, 2 done
    std::vector<std::pair<std::size_t, std::size_t>> stack;  // node, next child to visit
    std::size_t deepest = 0, at = 0;
    auto walk = [&](std::size_t root) {
      stack.push_back({root, 0});
      state[root] = 1;
      while (!stack.empty()) {
        auto& [node, next] = stack.back();
        if (stack.size() > deepest) {
          deepest = stack.size();
          at = node;
        }
        if (next == children[node].size()) {
          state[node] = 2;
          stack.pop_back();
          continue;
        }
        const std::size_t c = children[node][next++];
        if (state[c] == 1) {
          throw Error(fmt::format("{}: its node hierarchy has a cycle (nodes[{}] is among its own ancestors): the "
                                  "file is damaged",
                                  name_, c));
        }
        if (state[c] == 0) {
          state[c] = 1;
          stack.push_back({c, 0});
        }
      }
    };
    for (std::size_t k = 0; k < n; ++k)
      if (!is_child[k] && state[k] == 0) walk(k);
    for (std::size_t k = 0; k < n; ++k)  // nodes only on cycles have no root
      if (state[k] == 0) walk(k);
    if (deepest > static_cast<std::size_t>(kMaxNodeDepth)) {
      throw Error(fmt::format("{}: its node hierarchy is {} levels deep (down to nodes[{}]); mca reads up to {} "
                              "levels (the reader recurses once per level): flatten it in the program that wrote it "
                              "(in Blender: select all, Object > Parent > Clear and Keep Transformation), then export "
                              "again",
                              name_, deepest, at, kMaxNodeDepth));
    }
  }

 private:
  const Json& j_;
  const std::string& name_;
};

// Refuses JSON nested deeper than kMaxJsonDepth (before it is parsed: the parser recurses too).
void check_depth(std::string_view json, const std::string& name) {
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < json.size(); ++i) {
    const char c = json[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > kMaxJsonDepth) {
        throw Error(fmt::format("{}: its JSON is nested deeper than {} levels (at byte {}); a glTF exporter writes "
                                "a few: the file is damaged or not a glTF file",
                                name, kMaxJsonDepth, i));
      }
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
}

}  // namespace

GltfDeclared check_gltf_json(std::string_view json, const std::string& name, bool no_binary_chunk) {
  // (A .glb's JSON chunk is padded to 4 bytes, with spaces or, as some writers do, NULs.)
  while (!json.empty() && (json.back() == '\0' || json.back() == ' ')) json.remove_suffix(1);
  check_depth(json, name);
  // A key given twice in one object ("mode": 1, "mode": 4): readers differ in which they take (the reader mca
  // uses took the first, a check the last).
  std::vector<std::set<std::string>> keys;
  std::string twice;
  const auto watch = [&](int, Json::parse_event_t event, Json& parsed) {
    if (event == Json::parse_event_t::object_start) keys.emplace_back();
    else if (event == Json::parse_event_t::object_end && !keys.empty()) keys.pop_back();
    else if (event == Json::parse_event_t::key && !keys.empty() && twice.empty() &&
             !keys.back().insert(parsed.get<std::string>()).second)
      twice = parsed.get<std::string>();
    return true;
  };
  Json j;
  try {
    j = Json::parse(json, watch);
  } catch (const Json::exception& e) {  // (the byte where it fails, and what it found there)
    throw Error(fmt::format("{}: its JSON does not parse ({}): the file is damaged, or not a glTF file", name,
                            e.what()));
  }
  if (!j.is_object())
    throw Error(fmt::format("{}: its JSON is {}, not an object: not a glTF file", name, j.type_name()));
  if (!twice.empty()) {
    throw Error(fmt::format("{}: its JSON gives the key \"{}\" twice in one object; readers differ in which they "
                            "take: the file is damaged or its exporter wrote it wrong; export the model again",
                            name, twice));
  }
  const Checker check(j, name);
  check.hierarchy();
  check.fields();
  GltfDeclared d;
  d.draco = check.extensions();
  // Meshes no scene places (glTF allows a file without scenes; the reader mca uses reads nothing of it).
  if (check.list("scenes").empty() && !check.list("meshes").empty())
    throw Error(fmt::format("{}: has meshes but no scene to place them, and the reader mca uses reads a glTF's "
                            "scene: export it with its objects in a scene",
                            name));
  d.primitives = check.primitives();
  // (assimp: "Buffer view with offset/length (96/72) is out of range".)
  if (no_binary_chunk) {
    const Json& buffers = check.list("buffers");
    const Json& views = check.list("bufferViews");
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      if (!buffers[i].is_object()) continue;
      // (One of no bytes that no view reads is harmless.)
      const bool read = std::any_of(views.begin(), views.end(), [&](const Json& v) {
        return v.is_object() && v.contains("buffer") && v["buffer"].is_number() && v["buffer"].get<double>() == static_cast<double>(i);
      });
      const bool sized = buffers[i].contains("byteLength") && buffers[i]["byteLength"].is_number() &&
                         buffers[i]["byteLength"].get<double>() > 0;
      if (!buffers[i].contains("uri") && (read || sized))
        throw Error(fmt::format("{}: buffers[{}] has no uri, so its bytes are the file's binary chunk, and the file "
                                "ends after its JSON: it is cut short or damaged; export the model again",
                                name, i));
      // (The reader mca uses reads such a JSON from memory, under a name of its own, which a uri could name.)
      if (buffers[i].contains("uri") && buffers[i]["uri"].is_string() &&
          buffers[i]["uri"].get<std::string>().rfind("$$$___magic___$$$", 0) == 0)
        throw Error(fmt::format("{}: buffers[{}] names a file whose name begins with $$$___magic___$$$, which the "
                                "reader mca uses keeps for itself; rename the file",
                                name, i));
    }
  }
  return d;
}

void check_gltf_triangles(const aiScene& raw, const std::vector<GltfPrimitive>& declared, const std::string& name) {
  if (raw.mNumMeshes != declared.size()) return;  // not one mesh a primitive: nothing to compare
  for (std::size_t k = 0; k < declared.size(); ++k) {
    const aiMesh& m = *raw.mMeshes[k];
    if (m.mNumFaces >= declared[k].triangles) continue;  // (0 declared: points or lines, not compared)
    const std::uint64_t lost = declared[k].triangles - m.mNumFaces;
    throw Error(fmt::format("{}: {} of the {} triangles of meshes[{}].primitives[{}] {} vertices it does not have "
                            "(it has {}): the file is damaged; export the model again",
                            name, lost, declared[k].triangles, declared[k].mesh, declared[k].primitive,
                            lost == 1 ? "uses" : "use", m.mNumVertices));
  }
}

}  // namespace mca::mesh
