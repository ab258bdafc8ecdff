// TOML scene files <-> SceneDef. This file checks syntax, keys and types (with line numbers);
// ranges and references are validate_scene's job, so C++-built scenes get the same checks.
#include "io/scene_io.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <sstream>
#include <vector>

#include <fmt/format.h>
#include <toml++/toml.h>

#include <mca/error.hpp>

#include "core/files.hpp"
#include "core/text.hpp"
#include "io/default_scene.hpp"

namespace mca::io {

std::filesystem::path models_cache_dir() {
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  const char* home = std::getenv("HOME");
  const std::filesystem::path base = xdg && *xdg ? std::filesystem::path(xdg)
                                     : home && *home ? std::filesystem::path(home) / ".cache"
                                                     : std::filesystem::path(".cache");
  return base / "mca" / "models";
}

std::vector<std::filesystem::path> mesh_file_candidates(const std::string& mesh, const std::string& scene_source) {
  std::filesystem::path p(mesh);
  const char* home = std::getenv("HOME");
  if (mesh.rfind("~/", 0) == 0 && home && *home) p = std::filesystem::path(home) / mesh.substr(2);
  if (p.is_absolute()) return {p};
  std::vector<std::filesystem::path> out;
  // A scene compiled in (the default) or read from text has no folder: the working directory stands in.
  const std::filesystem::path scene_dir =
      scene_source.empty() || scene_source[0] == '<' ? std::filesystem::path() : std::filesystem::path(scene_source).parent_path();
  out.push_back(scene_dir / p);
  if (const char* env = std::getenv("MCA_MESH_PATH")) {
    std::string list = env;
    for (std::size_t start = 0; start <= list.size();) {
      const std::size_t end = std::min(list.find(':', start), list.size());
      if (end > start) out.push_back(std::filesystem::path(list.substr(start, end - start)) / p);
      start = end + 1;
    }
  }
  out.push_back(models_cache_dir() / p);
  return out;
}

namespace {

using text::did_you_mean;
using text::num;
using text::suggestion;

// A TOML float: num() plus ".0" where it would otherwise read as an integer.
std::string toml_double(double v) {
  std::string s = num(v);
  if (s.find_first_of(".eEn") == std::string::npos) s += ".0";
  return s;
}

std::string toml_string(std::string_view s) { return text::quoted(s); }

const char* type_name(const toml::node& n) {
  switch (n.type()) {
    case toml::node_type::string: return "a string";
    case toml::node_type::integer: return "an integer";
    case toml::node_type::floating_point: return "a float";
    case toml::node_type::boolean: return "a boolean";
    case toml::node_type::array: return "an array";
    case toml::node_type::table: return "a table";
    case toml::node_type::date: return "a date";
    case toml::node_type::time: return "a time";
    case toml::node_type::date_time: return "a date-time";
    default: return "nothing";
  }
}

// The value as written, for messages (strings quoted, arrays and tables abbreviated).
std::string shown(const toml::node& n) {
  if (const auto* s = n.as_string()) return toml_string(s->get());
  if (const auto* f = n.as_floating_point()) return num(f->get());
  if (const auto* i = n.as_integer()) return fmt::format("{}", i->get());
  if (const auto* b = n.as_boolean()) return b->get() ? "true" : "false";
  if (const auto* a = n.as_array()) return fmt::format("[...] ({} elements)", a->size());
  if (n.is_table()) return "{...}";
  std::ostringstream os;
  n.visit([&](const auto& v) { os << v; });
  return os.str();
}

class Reader {
 public:
  explicit Reader(std::string source) : source_(std::move(source)) {}

  const std::string& source() const { return source_; }

  std::string at(const toml::source_region& r) const {
    return fmt::format("{}:{}:{}", source_, r.begin.line, r.begin.column);
  }

  [[noreturn]] void fail(const toml::source_region& r, const std::string& message) const {
    throw Error(fmt::format("{}: {}", at(r), message));
  }

  [[noreturn]] void wrong_type(const toml::node& n, const std::string& key, const std::string& expected) const {
    std::string hint;
    if (const auto* s = n.as_string()) {
      char* end = nullptr;
      const std::string& text = s->get();
      std::strtod(text.c_str(), &end);
      if (!text.empty() && end == text.c_str() + text.size() && expected.find("number") != std::string::npos) {
        hint = fmt::format("; write it without quotes: {} = {}", key.substr(key.rfind('.') + 1), text);
      }
    } else if (n.is_floating_point() && expected.find("integer") != std::string::npos) {
      hint = "; write it without a decimal point";
    }
    fail(n.source(), fmt::format("{} is {} ({}), expected {}{}", key, type_name(n), shown(n), expected, hint));
  }

 private:
  std::string source_;
};

// One TOML table and its key path ("solver", "material[0]", "object[1].region[0]") for messages.
class Table {
 public:
  Table(const Reader& rd, const toml::table& t, std::string path, std::string section)
      : rd_(rd), t_(t), path_(std::move(path)), section_(std::move(section)) {}

  const Reader& reader() const { return rd_; }
  const toml::table& raw() const { return t_; }
  const std::string& path() const { return path_; }

  std::string key(std::string_view k) const {
    return path_.empty() ? std::string(k) : fmt::format("{}.{}", path_, k);
  }

  void allow(const std::vector<std::string>& keys) const {
    for (auto&& [k, v] : t_) {
      if (std::find(keys.begin(), keys.end(), k.str()) != keys.end()) continue;
      rd_.fail(k.source(), fmt::format("unknown key '{}' in {}{}", k.str(), section_, suggestion(k.str(), keys)));
    }
  }

  const toml::node* get(std::string_view k) const { return t_.get(k); }

  // Integers are accepted where floats are expected.
  bool number(std::string_view k, double& out) const {
    const toml::node* n = t_.get(k);
    if (!n) return false;
    out = to_number(*n, key(k));
    return true;
  }

  bool integer(std::string_view k, std::int64_t& out) const {
    const toml::node* n = t_.get(k);
    if (!n) return false;
    const auto* v = n->as_integer();
    if (!v) rd_.wrong_type(*n, key(k), "an integer");
    out = v->get();
    return true;
  }

  bool boolean(std::string_view k, bool& out) const {
    const toml::node* n = t_.get(k);
    if (!n) return false;
    const auto* v = n->as_boolean();
    if (!v) rd_.wrong_type(*n, key(k), "a boolean (true or false)");
    out = v->get();
    return true;
  }

  bool string(std::string_view k, std::string& out) const {
    const toml::node* n = t_.get(k);
    if (!n) return false;
    const auto* v = n->as_string();
    if (!v) rd_.wrong_type(*n, key(k), "a string (in quotes)");
    out = v->get();
    return true;
  }

  template <std::size_t N>
  bool numbers(std::string_view k, std::array<double, N>& out, const char* form) const {
    const toml::node* n = t_.get(k);
    if (!n) return false;
    const std::string expected = fmt::format("an array of {} numbers {}", N, form);
    const auto* a = n->as_array();
    if (!a) rd_.wrong_type(*n, key(k), expected);
    if (a->size() != N) {
      rd_.fail(n->source(), fmt::format("{} has {} element{}, expected {}", key(k), a->size(),
                                        a->size() == 1 ? "" : "s", expected));
    }
    for (std::size_t i = 0; i < N; ++i) out[i] = to_number(*a->get(i), fmt::format("{}[{}]", key(k), i));
    return true;
  }

  bool vec3(std::string_view k, Vec3d& out) const { return numbers(k, out, "[x, y, z]"); }

  // A sub-table ([solver], [object.heterogeneity]); nullopt when absent.
  std::optional<Table> table(std::string_view k, std::string section) const {
    const toml::node* n = t_.get(k);
    if (!n) return std::nullopt;
    const auto* t = n->as_table();
    if (!t) rd_.wrong_type(*n, key(k), fmt::format("a table ({})", section));
    return Table(rd_, *t, key(k), std::move(section));
  }

  // An array of tables ([[material]], [[object.region]]), element i with path key(k)[i].
  std::vector<Table> tables(std::string_view k, const std::string& section) const {
    std::vector<Table> out;
    const toml::node* n = t_.get(k);
    if (!n) return out;
    const auto* a = n->as_array();
    if (!a) {
      const std::string plain = section.substr(1, section.size() - 2);  // "[[material]]" -> "[material]"
      rd_.fail(n->source(), fmt::format("{} is {}, expected an array of tables: write each block as {}{}", key(k),
                                        type_name(*n), section,
                                        n->is_table() ? fmt::format(", not {}", plain) : std::string()));
    }
    for (std::size_t i = 0; i < a->size(); ++i) {
      const toml::node& e = *a->get(i);
      const std::string path = fmt::format("{}[{}]", key(k), i);
      const auto* t = e.as_table();
      if (!t) rd_.wrong_type(e, path, fmt::format("a table ({})", section));
      out.emplace_back(rd_, *t, path, section);
    }
    return out;
  }

  // A string naming one of `choices`; `what` reads e.g. "a shape".
  std::optional<std::string> choice(std::string_view k, const std::vector<std::string>& choices,
                                    const char* what) const {
    std::string s;
    if (!string(k, s)) return std::nullopt;
    if (std::find(choices.begin(), choices.end(), s) == choices.end()) {
      std::string list;
      for (const std::string& c : choices) list += fmt::format("{}\"{}\"", list.empty() ? "" : ", ", c);
      const std::string fix = did_you_mean(s, choices);
      rd_.fail(t_.get(k)->source(),
               fmt::format("{} = \"{}\" is not {}{}; use one of {}", key(k), s, what, fix, list));
    }
    return s;
  }

 private:
  double to_number(const toml::node& n, const std::string& key) const {
    if (const auto* f = n.as_floating_point()) return f->get();
    if (const auto* i = n.as_integer()) return static_cast<double>(i->get());
    rd_.wrong_type(n, key, "a number (float or integer)");
  }

  const Reader& rd_;
  const toml::table& t_;
  std::string path_;
  std::string section_;
};

const std::vector<std::string> kHeterogeneityKeys = {"preset", "shares", "class_factors", "grain_size"};

HeterogeneityDef read_heterogeneity(const Table& tb, HeterogeneityDef h) {
  tb.allow(kHeterogeneityKeys);
  const toml::node* preset_node = tb.get("preset");
  const toml::node* shares_node = tb.get("shares");
  if (preset_node && shares_node) {
    tb.reader().fail(shares_node->source(),
                     fmt::format("{} and {} (line {}) are both given; give either preset = \"none|low|medium|high\" "
                                 "or shares = [p1, p2, p3, p4], not both",
                                 tb.key("shares"), tb.key("preset"), preset_node->source().begin.line));
  }
  std::string preset;
  if (tb.string("preset", preset)) {
    if (preset == "custom") {
      tb.reader().fail(preset_node->source(),
                       fmt::format("{} = \"custom\" is implied by shares; remove preset and give "
                                   "shares = [p1, p2, p3, p4] instead",
                                   tb.key("preset")));
    }
    if (!heterogeneity_preset(preset, h.shares)) {
      const std::vector<std::string> names = {"none", "low", "medium", "high"};
      const std::string fix = did_you_mean(preset, names);
      tb.reader().fail(preset_node->source(),
                       fmt::format("{} = \"{}\" is not a preset{}; use \"none\", \"low\", \"medium\" or \"high\", "
                                   "or give shares = [p1, p2, p3, p4]",
                                   tb.key("preset"), preset, fix));
    }
    h.preset = preset;
  }
  if (tb.numbers("shares", h.shares, "[p1, p2, p3, p4] (class 1 = weakest)")) h.preset = "custom";
  tb.numbers("class_factors", h.class_factors, "[k1, k2, k3, k4]");
  tb.number("grain_size", h.grain_size);
  return h;
}


const char* law_name(StrengtheningLaw l) {
  switch (l) {
    case StrengtheningLaw::exponential: return "exponential";
    case StrengtheningLaw::quadratic: return "quadratic";
    default: return "none";
  }
}

MaterialDef read_material(const Table& tb, const std::vector<MaterialDef>& earlier) {
  tb.allow({"name", "base", "youngs_modulus", "poisson_ratio", "density", "tensile_strength",
            "compressive_strength", "fracture_strain", "friction", "restitution", "rolling_friction",
            "twisting_friction", "damping_time", "strengthening", "strengthening_alpha", "fracture_energy",
            "weibull_modulus"});
  MaterialDef m;  // no base: the struct's defaults (concrete)
  std::string base;
  if (tb.string("base", base)) {
    const MaterialDef* found = nullptr;
    for (const MaterialDef& e : earlier) {
      if (e.name == base) found = &e;
    }
    if (!found) found = find_builtin_material(base);
    if (!found) {
      std::vector<std::string> names;
      for (const MaterialDef& e : earlier) names.push_back(e.name);
      for (const MaterialDef& b : builtin_materials()) names.push_back(b.name);
      tb.reader().fail(tb.get("base")->source(),
                       fmt::format("{} = \"{}\" is not a built-in or earlier material{}", tb.key("base"), base,
                                   suggestion(base, names)));
    }
    m = *found;
  }
  if (!tb.string("name", m.name)) {
    tb.reader().fail(tb.raw().source(), fmt::format("{} has no name; add name = \"...\" (objects and projectiles "
                                                    "refer to materials by name)",
                                                    tb.path()));
  }
  tb.number("youngs_modulus", m.youngs_modulus);
  tb.number("poisson_ratio", m.poisson_ratio);
  tb.number("density", m.density);
  tb.number("tensile_strength", m.tensile_strength);
  tb.number("compressive_strength", m.compressive_strength);
  tb.number("fracture_strain", m.fracture_strain);
  tb.number("friction", m.friction);
  tb.number("restitution", m.restitution);
  tb.number("rolling_friction", m.rolling_friction);
  tb.number("twisting_friction", m.twisting_friction);
  tb.number("damping_time", m.damping_time);
  if (auto law = tb.choice("strengthening", {"none", "exponential", "quadratic"}, "a strengthening law")) {
    m.strengthening = *law == "exponential" ? StrengtheningLaw::exponential
                      : *law == "quadratic" ? StrengtheningLaw::quadratic
                                            : StrengtheningLaw::none;
  }
  tb.number("strengthening_alpha", m.strengthening_alpha);
  tb.number("fracture_energy", m.fracture_energy);
  tb.number("weibull_modulus", m.weibull_modulus);
  return m;
}

// The mesh file `key` names: found (mesh_file_candidates) and made absolute, so that a scene written back
// by scene_to_toml (a checkpoint's) finds it again from anywhere.
// `resolve`: only for a mesh shape (any other shape's `mesh` key is refused by validate_scene).
void read_mesh_path(const Table& tb, std::string& out, bool resolve) {
  if (!tb.string("mesh", out) || !resolve) return;
  const toml::node* n = tb.get("mesh");
  if (out.empty()) tb.reader().fail(n->source(), fmt::format("{} is empty; give the mesh file's path", tb.key("mesh")));
  if (std::any_of(out.begin(), out.end(), text::is_control)) {
    tb.reader().fail(n->source(), fmt::format("{} holds a control character (a line break, tab or NUL); give the "
                                              "mesh file's path",
                                              tb.key("mesh")));
  }
  const auto candidates = mesh_file_candidates(out, tb.reader().source());
  const std::string given = out;
  std::error_code ec;
  for (const auto& c : candidates) {
    if (std::filesystem::is_regular_file(c, ec)) {
      out = std::filesystem::absolute(c, ec).lexically_normal().string();
      // The run writes the path into its scene.toml, which TOML wants in UTF-8: a path of other bytes made
      // a run whose scene.toml and checkpoints no resume could read.
      if (!text::is_utf8(out)) {
        tb.reader().fail(n->source(), fmt::format("{} = \"{}\": the file was found at a path that is not UTF-8 text "
                                                  "({}); mca writes the path into the run's scene.toml, which must "
                                                  "be UTF-8: rename the file or its folder",
                                                  tb.key("mesh"), given, text::utf8_shown(out)));
      }
      return;
    }
    if (ec && ec != std::errc::no_such_file_or_directory) {  // a loop of symbolic links, a name too long
      tb.reader().fail(n->source(), fmt::format("{} = \"{}\": {} cannot be reached ({}); check the path",
                                                tb.key("mesh"), out, c.string(), ec.message()));
    }
    if (const std::string kind = files::non_regular_kind(c); !kind.empty()) {
      tb.reader().fail(n->source(), fmt::format("{} = \"{}\": {} is {}, not a mesh file (mca reads only regular "
                                                "files); give the path of a mesh file",
                                                tb.key("mesh"), out, c.string(), kind));
    }
  }
  std::string looked;
  for (const auto& c : candidates) looked += fmt::format("{}{}", looked.empty() ? "" : ", ", c.string());
  tb.reader().fail(n->source(),
                   fmt::format("{} = \"{}\": no such file (looked for {}); a path is relative to the scene file's "
                               "folder, then to the folders of MCA_MESH_PATH and the models cache {}. The paper's "
                               "models (cow, bunny, armadillo) come with scripts/get_models.sh",
                               tb.key("mesh"), out, looked, models_cache_dir().string()));
}

RegionDef read_region(const Table& tb) {
  tb.allow({"shape", "center", "size", "radius", "mesh", "material"});
  RegionDef r;
  if (auto s = tb.choice("shape", {"box", "sphere", "mesh"}, "a region shape")) r.shape = to_shape(*s);
  tb.vec3("center", r.center);
  tb.vec3("size", r.size);
  tb.number("radius", r.radius);
  read_mesh_path(tb, r.mesh, r.shape == Shape::mesh);
  if (!tb.string("material", r.material)) {
    tb.reader().fail(tb.raw().source(),
                     fmt::format("{} has no material; add material = \"...\" (the group its automata get)", tb.path()));
  }
  return r;
}

ObjectDef read_object(const Table& tb, std::size_t index, const HeterogeneityDef& scene_heterogeneity) {
  tb.allow({"name", "shape", "size", "radius", "height", "mesh", "scale", "fit_size", "fill", "shell_thickness",
            "position", "rotation", "velocity", "material", "heterogeneity", "region"});
  ObjectDef o;
  if (index > 0) o.name = fmt::format("object{}", index);
  tb.string("name", o.name);
  if (auto s = tb.choice("shape", {"box", "sphere", "cylinder", "mesh"}, "a shape")) o.shape = to_shape(*s);
  tb.vec3("size", o.size);
  tb.number("radius", o.radius);
  tb.number("height", o.height);
  read_mesh_path(tb, o.mesh, o.shape == Shape::mesh);
  tb.number("scale", o.scale);
  tb.number("fit_size", o.fit_size);
  if (tb.get("scale") && tb.get("fit_size")) {
    tb.reader().fail(tb.get("fit_size")->source(),
                     fmt::format("{} gives both scale and fit_size; give one: scale multiplies the file's coordinates, "
                                 "fit_size sets the largest extent",
                                 tb.path()));
  }
  if (auto f = tb.choice("fill", {"volume", "surface"},
                         "a fill mode (\"volume\": the lattice cells inside the mesh; \"surface\": one automaton per "
                         "triangle)"))
    o.fill = *f == "surface" ? MeshFill::surface : MeshFill::volume;
  tb.number("shell_thickness", o.shell_thickness);
  tb.vec3("position", o.position);
  tb.vec3("rotation", o.rotation);
  tb.vec3("velocity", o.velocity);
  tb.string("material", o.material);
  if (auto h = tb.table("heterogeneity", "[object.heterogeneity]")) {
    o.heterogeneity = read_heterogeneity(*h, scene_heterogeneity);
  }
  for (const Table& r : tb.tables("region", "[[object.region]]")) o.regions.push_back(read_region(r));
  return o;
}

ProjectileDef read_projectile(const Table& tb, std::size_t index) {
  tb.allow({"name", "radius", "material", "density", "position", "velocity", "angular_velocity", "kinematic",
            "rolling_friction", "twisting_friction"});
  ProjectileDef p;
  if (index > 0) p.name = fmt::format("ball{}", index);
  tb.string("name", p.name);
  tb.number("radius", p.radius);
  tb.string("material", p.material);
  tb.number("density", p.density);
  tb.vec3("position", p.position);
  tb.vec3("velocity", p.velocity);
  tb.vec3("angular_velocity", p.angular_velocity);
  tb.boolean("kinematic", p.kinematic);
  tb.number("rolling_friction", p.rolling_friction);
  tb.number("twisting_friction", p.twisting_friction);
  return p;
}

GripDef read_grip(const Table& tb, std::size_t index) {
  tb.allow({"name", "min", "max", "velocity"});
  GripDef g;
  if (index > 0) g.name = fmt::format("grip{}", index);
  tb.string("name", g.name);
  if (!tb.vec3("min", g.min) || !tb.vec3("max", g.max)) {
    tb.reader().fail(tb.raw().source(), fmt::format("{} needs both min = [x, y, z] and max = [x, y, z] (the box "
                                                    "whose automata it holds)",
                                                    tb.path()));
  }
  tb.vec3("velocity", g.velocity);
  return g;
}

LoadDef read_load(const Table& tb, std::size_t index) {
  tb.allow({"name", "min", "max", "force"});
  LoadDef l;
  if (index > 0) l.name = fmt::format("load{}", index);
  tb.string("name", l.name);
  if (!tb.vec3("min", l.min) || !tb.vec3("max", l.max)) {
    tb.reader().fail(tb.raw().source(), fmt::format("{} needs both min = [x, y, z] and max = [x, y, z] (the box "
                                                    "whose automata it pushes)",
                                                    tb.path()));
  }
  tb.vec3("force", l.force);
  return l;
}

SceneDef read_scene(const Table& root, const std::string& source) {
  root.allow({"name", "solver", "output", "heterogeneity", "material", "object", "projectile", "grip", "load",
              "ground", "camera"});
  SceneDef scene;
  scene.source = source;
  scene.name = std::filesystem::path(source).stem().string();
  if (scene.name.empty()) scene.name = "scene";
  root.string("name", scene.name);

  if (auto tb = root.table("solver", "[solver]")) {
    tb->allow({"spacing", "target_automata", "safety", "time_step", "mass_scaling", "gravity", "link_damping",
               "local_damping", "stress_coefficient", "lattice", "lattice_jitter", "link_bending", "skin", "seed", "max_memory_gb",
               "backend"});
    SolverDef& s = scene.solver;
    tb->number("spacing", s.spacing);
    tb->integer("target_automata", s.target_automata);
    tb->number("safety", s.safety);
    tb->number("time_step", s.time_step);
    tb->number("mass_scaling", s.mass_scaling);
    tb->vec3("gravity", s.gravity);
    tb->number("link_damping", s.link_damping);
    tb->number("local_damping", s.local_damping);
    tb->number("stress_coefficient", s.stress_coefficient);
    if (auto f = tb->choice("lattice", {"cubic", "random"}, "a lattice")) {
      s.lattice = *f == "random" ? SolverDef::Lattice::random : SolverDef::Lattice::cubic;
    }
    if (auto f = tb->choice("backend", {"auto", "cpu", "cuda", "cuda-emulation"}, "a backend")) s.backend = *parse_backend(*f);
    tb->number("lattice_jitter", s.lattice_jitter);
    tb->number("link_bending", s.link_bending);
    if (s.link_bending == 0) s.link_bending = 0;  // -0 is 0 (and printed so)
    tb->number("skin", s.skin);
    std::int64_t seed = 0;
    // TOML integers are signed 64-bit: seeds above 2^63-1 are written (and read) as their two's
    // complement, so every std::uint64_t seed round-trips.
    if (tb->integer("seed", seed)) s.seed = static_cast<std::uint64_t>(seed);
    tb->number("max_memory_gb", s.max_memory_gb);
  }

  if (auto tb = root.table("output", "[output]")) {
    tb->allow({"duration", "frame_rate", "links", "vtk", "checkpoint_every", "surface", "surface_format", "fragments",
               "fragment_min_automata"});
    OutputDef& o = scene.output;
    tb->number("duration", o.duration);
    tb->number("frame_rate", o.frame_rate);
    tb->boolean("links", o.links);
    tb->boolean("vtk", o.vtk);
    tb->boolean("surface", o.surface);
    tb->boolean("fragments", o.fragments);
    tb->integer("fragment_min_automata", o.fragment_min_automata);
    if (auto f = tb->choice("surface_format", {"ply", "obj"}, "a surface format")) {
      o.surface_format = *f == "obj" ? OutputDef::SurfaceFormat::obj : OutputDef::SurfaceFormat::ply;
    }
    std::int64_t every = 0;
    if (tb->integer("checkpoint_every", every)) {
      if (every < std::numeric_limits<int>::min() || every > std::numeric_limits<int>::max()) {
        root.reader().fail(tb->get("checkpoint_every")->source(),
                           fmt::format("output.checkpoint_every = {} is out of range: must be in [0, {}]", every,
                                       std::numeric_limits<int>::max()));
      }
      o.checkpoint_every = static_cast<int>(every);
    }
  }

  if (auto tb = root.table("heterogeneity", "[heterogeneity]")) {
    scene.heterogeneity = read_heterogeneity(*tb, scene.heterogeneity);
  }

  if (auto tb = root.table("ground", "[ground]")) {
    tb->allow({"enabled", "height", "friction", "restitution", "rolling_friction", "twisting_friction"});
    tb->boolean("enabled", scene.ground.enabled);
    tb->number("height", scene.ground.height);
    tb->number("friction", scene.ground.friction);
    tb->number("restitution", scene.ground.restitution);
    tb->number("rolling_friction", scene.ground.rolling_friction);
    tb->number("twisting_friction", scene.ground.twisting_friction);
  }

  if (auto tb = root.table("camera", "[camera]")) {
    tb->allow({"position", "target", "fov"});
    Vec3d v{};
    if (tb->vec3("position", v)) scene.camera.position = v;
    if (tb->vec3("target", v)) scene.camera.target = v;
    tb->number("fov", scene.camera.fov);
  }

  for (const Table& tb : root.tables("material", "[[material]]")) {
    scene.materials.push_back(read_material(tb, scene.materials));
  }
  const std::vector<Table> objects = root.tables("object", "[[object]]");
  for (std::size_t i = 0; i < objects.size(); ++i) {
    scene.objects.push_back(read_object(objects[i], i, scene.heterogeneity));
  }
  const std::vector<Table> projectiles = root.tables("projectile", "[[projectile]]");
  for (std::size_t i = 0; i < projectiles.size(); ++i) {
    scene.projectiles.push_back(read_projectile(projectiles[i], i));
  }
  const std::vector<Table> grips = root.tables("grip", "[[grip]]");
  for (std::size_t i = 0; i < grips.size(); ++i) scene.grips.push_back(read_grip(grips[i], i));
  const std::vector<Table> loads = root.tables("load", "[[load]]");
  for (std::size_t i = 0; i < loads.size(); ++i) scene.loads.push_back(read_load(loads[i], i));
  return scene;
}

// Writing.

std::string vec(const Vec3d& v) {
  return fmt::format("[{}, {}, {}]", toml_double(v[0]), toml_double(v[1]), toml_double(v[2]));
}

std::string arr4(const std::array<double, 4>& v) {
  return fmt::format("[{}, {}, {}, {}]", toml_double(v[0]), toml_double(v[1]), toml_double(v[2]),
                     toml_double(v[3]));
}

void write_heterogeneity(std::string& out, const HeterogeneityDef& h) {
  std::array<double, 4> preset_shares{};
  // A named preset is written by name (it reads back to the same shares, bit for bit); anything else
  // as explicit shares, which reads back as preset "custom".
  if (h.preset != "custom" && heterogeneity_preset(h.preset, preset_shares) && preset_shares == h.shares) {
    out += fmt::format("preset = {}  # shares = {}\n", toml_string(h.preset), arr4(h.shares));
  } else {
    out += fmt::format("shares = {}\n", arr4(h.shares));
  }
  out += fmt::format("class_factors = {}\n", arr4(h.class_factors));
  out += fmt::format("grain_size = {}\n", toml_double(h.grain_size));
}

// toml++ recurses once per part of a dotted key ("a.b.c") and of a table header ("[a.b.c]"): a key of
// 50,000 parts overflowed the stack (exit 139). Scene keys have at most three parts
// (object.heterogeneity.preset), so the text is scanned first, strings and comments skipped, and a run
// of more dots than any scene needs, or a key longer than any name, is refused with its line.
//
// The same scan bounds what parsing takes: toml++ keeps a node of about 70 bytes per array item, 170 per
// key, 120 per table and 300 per inline table (measured: a 62 MB array of zeros took 2.3 GB, 60 MB of
// "k = {}" lines 1.31 GB), and each [[object]], [[projectile]] ... becomes a definition of its own
// besides: about 1.2 KB a header in all (500,000 "[[object]]" lines peaked at 580 MB). Scene arrays hold at
// most 4 numbers, so an array of more than kMaxArrayItems is refused with its line, and a text whose nodes
// would take more than kMaxParseBytes is refused whole (by this count a scene of 100,000 objects of five
// keys takes about 0.25 GB).
constexpr std::size_t kMaxKeyParts = 64;
constexpr std::size_t kMaxKeyLength = 1024;
constexpr std::size_t kMaxArrayItems = 1024;
constexpr std::size_t kMaxNesting = 64;
constexpr double kMaxParseBytes = 1e9;
constexpr double kParseBytesPerItem = 70, kParseBytesPerKey = 170, kParseBytesPerTable = 120;
constexpr double kParseBytesPerInlineTable = 300, kParseBytesPerArrayTable = 1200;

void check_keys(std::string_view t, const std::string& source) {
  std::size_t line = 1, dots = 0, run = 0;
  // header: the run began with '[' at the start of a line; in_value: after an '=', nest: the arrays and
  // inline tables open in that value (a multi-line array's rows may start with '[').
  bool line_start = true, header = false, in_value = false;
  int nest = 0;
  // The arrays and inline tables open in the value: '[' or '{', its items so far, its line.
  struct Open {
    char bracket;
    std::size_t items, line;
  };
  std::vector<Open> open;
  double items = 0, keys = 0, tables = 0, inline_tables = 0, array_tables = 0;
  auto refuse_value = [&](std::size_t at, const std::string& what) {
    throw Error(fmt::format("{}:{}: {}; scene arrays hold at most 4 numbers (e.g. size = [2, 0.2, 1.5]): the line is "
                            "damaged or the file is not a scene",
                            source, at, what));
  };
  auto fail = [&](const std::string& what) {
    throw Error(fmt::format("{}:{}: {}; scene keys have at most 3 parts (e.g. object.heterogeneity.preset) and "
                            "names of a few words: the line is damaged or the file is not a scene",
                            source, line, what));
  };
  auto check_length = [&] {
    if (run > kMaxKeyLength) fail(fmt::format("a key of {} characters, more than {}", run, kMaxKeyLength));
  };
  // Skips a string opened at t[i] (quote q, three of them for a multi-line one); returns the index after it.
  auto skip_string = [&](std::size_t i, char q) {
    const bool multi = t.compare(i, 3, std::string(3, q)) == 0;
    std::size_t k = i + (multi ? 3 : 1);
    while (k < t.size()) {
      const char c = t[k];
      if (c == '\\' && q == '"') {
        if (k + 1 < t.size() && t[k + 1] == '\n') ++line;
        k += 2;
        continue;
      }
      if (c == '\n') {
        if (!multi) return k;  // unterminated: toml++ reports it
        ++line;
      }
      if (c == q && (!multi || t.compare(k, 3, std::string(3, q)) == 0)) {
        if (!multi) return k + 1;
        k += 3;
        for (int extra = 0; extra < 2 && k < t.size() && t[k] == q; ++extra) ++k;  // """a"""" ends after 4
        return k;
      }
      ++k;
    }
    return k;
  };
  for (std::size_t i = 0; i < t.size();) {
    const char c = t[i];
    if (c == '"' || c == '\'') {
      const std::size_t end = skip_string(i, c);
      run += end - i;
      i = end;
      line_start = false;
      continue;
    }
    if (c == '#') {
      while (i < t.size() && t[i] != '\n') ++i;
      continue;
    }
    switch (c) {
      case '\n':
        ++line;
        if (header) check_length();
        if (nest == 0) in_value = false;
        dots = run = 0;
        header = false;
        line_start = true;
        ++i;
        continue;
      case ' ': case '\t': case '\r':
        ++i;
        continue;
      case '=':
        check_length();
        in_value = true;
        ++keys;
        dots = run = 0;
        break;
      case '[': case '{':
        if (in_value) {
          ++nest;
          if (open.size() >= kMaxNesting)
            refuse_value(line, fmt::format("arrays or inline tables nested more than {} deep", kMaxNesting));
          if (c == '[') ++items;  // its first item
          else ++inline_tables;
          open.push_back({c, 1, line});
        } else if (c == '[' && line_start) {
          header = true;
          ++(i + 1 < t.size() && t[i + 1] == '[' ? array_tables : tables);
        }
        dots = run = 0;
        break;
      case ']': case '}':
        if (nest > 0) {
          --nest;
          if (!open.empty()) open.pop_back();
        } else if (header) {
          check_length();
          header = false;
        }
        dots = run = 0;
        break;
      case ',':
        if (!open.empty() && open.back().bracket == '[') {
          ++items;
          if (++open.back().items > kMaxArrayItems)
            refuse_value(open.back().line, fmt::format("an array of more than {} items", kMaxArrayItems));
        }
        dots = run = 0;
        break;
      case '.':
        if (++dots >= kMaxKeyParts) fail(fmt::format("a key or table header of more than {} dotted parts", kMaxKeyParts));
        ++run;
        break;
      default:
        ++run;
    }
    line_start = false;
    ++i;
  }
  const double bytes = kParseBytesPerItem * items + kParseBytesPerKey * keys + kParseBytesPerTable * tables +
                       kParseBytesPerInlineTable * inline_tables + kParseBytesPerArrayTable * array_tables;
  if (bytes > kMaxParseBytes) {
    throw Error(fmt::format("{}: reading this scene would take about {:.2g} GB ({:.0f} array items, {:.0f} keys, {:.0f} "
                            "tables{}), more than the {:.0f} GB a scene may take (by this count a scene of 100,000 "
                            "objects of five keys takes about 0.25 GB); the file is damaged or not a scene",
                            source, bytes / 1e9, items, keys, tables,
                            fmt::format("{}{}", inline_tables > 0 ? fmt::format(", {:.0f} inline tables", inline_tables) : "",
                                        array_tables > 0 ? fmt::format(", {:.0f} [[...]] headers", array_tables) : ""),
                            kMaxParseBytes / 1e9));
  }
}

}  // namespace

Shape to_shape(const std::string& s) {
  if (s == "sphere") return Shape::sphere;
  if (s == "cylinder") return Shape::cylinder;
  if (s == "mesh") return Shape::mesh;
  return Shape::box;
}

const char* shape_name(Shape s) {
  switch (s) {
    case Shape::sphere: return "sphere";
    case Shape::cylinder: return "cylinder";
    case Shape::mesh: return "mesh";
    default: return "box";
  }
}

namespace {
// Line `n` (from 1) of `text`, without its end; empty past the last.
std::string_view line_of(std::string_view text, std::size_t n) {
  std::size_t at = 0;
  for (; n > 1; --n) {
    at = text.find('\n', at);
    if (at == std::string_view::npos) return {};
    ++at;
  }
  return text.substr(at, text.find('\n', at) - at);
}
}  // namespace

SceneDef parse_scene(std::string_view toml_text, const std::string& source) {
  // (toml++ says "invalid utf-8 sequence" at 1:1, and no more.)
  if (const int wide = text::wide_unicode_bom(toml_text))
    throw Error(fmt::format("{}: is text in UTF-{} (it starts with its byte order mark); a scene file is TOML, which "
                            "is UTF-8: save it as UTF-8 (in Notepad: Save as, Encoding \"UTF-8\")",
                            source, wide));
  check_keys(toml_text, source);
  toml::table root;
  try {
    root = toml::parse(toml_text, source);
  } catch (const toml::parse_error& e) {
    const toml::source_region& r = e.source();
    // TOML's integers are signed 64-bit: a seed above 2^63 - 1 is written as its two's complement.
    std::string what(e.description());
    const bool too_large = what.find("not representable in 64 bits") != std::string::npos;
    // (toml++ quotes the digits of a negative one without its sign: '9223372036854775809' for
    // -9223372036854775809. The number ends where the error is reported: a '-' before its digits, and
    // underscores, is its sign.)
    const std::size_t q0 = what.find('\''), q1 = q0 == std::string::npos ? q0 : what.find('\'', q0 + 1);
    if (too_large && q1 != std::string::npos && q1 > q0 + 1 && what[q0 + 1] != '-' && r.begin.column >= 1) {
      const std::string_view line = line_of(toml_text, r.begin.line);
      std::size_t at = std::min<std::size_t>(r.begin.column - 1, line.size());
      while (at > 0 && ((line[at - 1] >= '0' && line[at - 1] <= '9') || line[at - 1] == '_')) --at;
      if (at > 0 && line[at - 1] == '-') what = what.substr(0, q0 + 1) + "-" + what.substr(q0 + 1);
    }
    throw Error(fmt::format("{}:{}:{}: TOML syntax error: {}{}", source, r.begin.line, r.begin.column, what,
                            too_large ? "; TOML integers are -2^63 .. 2^63-1 (a seed above 2^63-1 is written as its "
                                        "two's complement: 18446744073709551615 is -1, docs/scene-format.md; a "
                                        "key that takes a number takes a float, 1e20)"
                                      : ""));
  }
  const Reader reader(source);
  SceneDef scene = read_scene(Table(reader, root, "", "the top level"), source);
  validate_scene(scene);
  return scene;
}

SceneDef load_scene_file(const std::filesystem::path& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory) {
    // A loop of symbolic links, a name too long, a folder on the way without permission: the system's
    // reason, not "not found".
    throw Error(fmt::format("{}: cannot reach the scene file ({}); check the path", path.string(), ec.message()));
  }
  if (!std::filesystem::exists(status)) {
    throw Error(fmt::format("{}: scene file not found (current directory: {}); check the path, or start from "
                            "one of the example scenes in the scenes/ folder",
                            path.string(), std::filesystem::current_path(ec).string()));
  }
  files::require_regular_file(path, "a scene file",
                              "give the path of a .toml file (a scene made by a program: write it to a file first)");
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw Error(fmt::format("{}: cannot open the scene file ({}); check its permissions", path.string(),
                            std::strerror(errno)));
  }
  // Read at most 64 MB (a scene of 100,000 objects is about 10 MB): /dev/zero or a wrong file must not
  // fill the memory.
  // Read in pieces: a buffer of the whole limit, zero-filled, made every run's peak 64 MB larger.
  constexpr std::size_t kMaxSceneBytes = 64u << 20;
  std::string text;
  char piece[1 << 16];
  while (text.size() <= kMaxSceneBytes && in.read(piece, sizeof piece).gcount() > 0)
    text.append(piece, static_cast<std::size_t>(in.gcount()));
  if (in.bad()) {
    throw Error(fmt::format("{}: reading the scene file failed ({}); check the file and the disk", path.string(),
                            std::strerror(errno)));
  }
  if (text.size() > kMaxSceneBytes) {
    throw Error(fmt::format("{}: is larger than 64 MB, which no scene file is; check the path", path.string()));
  }
  return parse_scene(text, path.string());
}

SceneDef load_default_scene() {
  return parse_scene(kDefaultSceneToml, fmt::format("<built-in>/{}", kDefaultSceneName));
}

std::string scene_to_toml(const SceneDef& s) {
  std::string out;
  out += fmt::format("{}; every key is given. Format: docs/scene-format.md\n", kWrittenByMca);
  out += fmt::format("name = {}\n", toml_string(s.name));

  out += "\n[solver]\n";
  out += fmt::format("spacing = {}\n", toml_double(s.solver.spacing));
  out += fmt::format("target_automata = {}\n", s.solver.target_automata);
  out += fmt::format("safety = {}\n", toml_double(s.solver.safety));
  out += fmt::format("time_step = {}\n", toml_double(s.solver.time_step));
  out += fmt::format("mass_scaling = {}\n", toml_double(s.solver.mass_scaling));
  out += fmt::format("gravity = {}\n", vec(s.solver.gravity));
  out += fmt::format("link_damping = {}\n", toml_double(s.solver.link_damping));
  out += fmt::format("local_damping = {}\n", toml_double(s.solver.local_damping));
  out += fmt::format("stress_coefficient = {}\n", toml_double(s.solver.stress_coefficient));
  out += s.solver.lattice == SolverDef::Lattice::random ? "lattice = \"random\"\n" : "lattice = \"cubic\"\n";
  out += fmt::format("lattice_jitter = {}\n", toml_double(s.solver.lattice_jitter));
  out += fmt::format("link_bending = {}\n", toml_double(s.solver.link_bending));
  out += fmt::format("backend = \"{}\"\n", backend_name(s.solver.backend));
  out += fmt::format("skin = {}\n", toml_double(s.solver.skin));
  out += fmt::format("seed = {}\n", static_cast<std::int64_t>(s.solver.seed));
  out += fmt::format("max_memory_gb = {}\n", toml_double(s.solver.max_memory_gb));

  out += "\n[output]\n";
  out += fmt::format("duration = {}\n", toml_double(s.output.duration));
  out += fmt::format("frame_rate = {}\n", toml_double(s.output.frame_rate));
  out += fmt::format("links = {}\n", s.output.links);
  out += fmt::format("vtk = {}\n", s.output.vtk);
  out += fmt::format("checkpoint_every = {}\n", s.output.checkpoint_every);
  out += fmt::format("surface = {}\n", s.output.surface);
  out += fmt::format("fragments = {}\n", s.output.fragments);
  out += fmt::format("fragment_min_automata = {}\n", s.output.fragment_min_automata);
  out += fmt::format("surface_format = \"{}\"\n", s.output.surface_format == OutputDef::SurfaceFormat::obj ? "obj" : "ply");

  out += "\n[heterogeneity]\n";
  write_heterogeneity(out, s.heterogeneity);

  out += "\n[ground]\n";
  out += fmt::format("enabled = {}\n", s.ground.enabled);
  out += fmt::format("height = {}\n", toml_double(s.ground.height));
  out += fmt::format("friction = {}\n", toml_double(s.ground.friction));
  out += fmt::format("restitution = {}\n", toml_double(s.ground.restitution));
  out += fmt::format("rolling_friction = {}\n", toml_double(s.ground.rolling_friction));
  out += fmt::format("twisting_friction = {}\n", toml_double(s.ground.twisting_friction));

  out += "\n[camera]\n";
  if (s.camera.position) out += fmt::format("position = {}\n", vec(*s.camera.position));
  if (s.camera.target) out += fmt::format("target = {}\n", vec(*s.camera.target));
  out += fmt::format("fov = {}\n", toml_double(s.camera.fov));

  for (const MaterialDef& m : s.materials) {
    out += "\n[[material]]\n";
    out += fmt::format("name = {}\n", toml_string(m.name));
    out += fmt::format("youngs_modulus = {}\n", toml_double(m.youngs_modulus));
    out += fmt::format("poisson_ratio = {}\n", toml_double(m.poisson_ratio));
    out += fmt::format("density = {}\n", toml_double(m.density));
    out += fmt::format("tensile_strength = {}\n", toml_double(m.tensile_strength));
    out += fmt::format("compressive_strength = {}\n", toml_double(m.compressive_strength));
    out += fmt::format("fracture_strain = {}\n", toml_double(m.fracture_strain));
    out += fmt::format("friction = {}\n", toml_double(m.friction));
    out += fmt::format("restitution = {}\n", toml_double(m.restitution));
    out += fmt::format("rolling_friction = {}\n", toml_double(m.rolling_friction));
    out += fmt::format("twisting_friction = {}\n", toml_double(m.twisting_friction));
    out += fmt::format("damping_time = {}\n", toml_double(m.damping_time));
    out += fmt::format("strengthening = {}\n", toml_string(law_name(m.strengthening)));
    out += fmt::format("strengthening_alpha = {}\n", toml_double(m.strengthening_alpha));
    out += fmt::format("fracture_energy = {}\n", toml_double(m.fracture_energy));
    out += fmt::format("weibull_modulus = {}\n", toml_double(m.weibull_modulus));
  }

  for (const ObjectDef& o : s.objects) {
    out += "\n[[object]]\n";
    out += fmt::format("name = {}\n", toml_string(o.name));
    out += fmt::format("shape = {}\n", toml_string(shape_name(o.shape)));
    out += fmt::format("size = {}\n", vec(o.size));
    out += fmt::format("radius = {}\n", toml_double(o.radius));
    out += fmt::format("height = {}\n", toml_double(o.height));
    if (o.shape == Shape::mesh) {
      out += fmt::format("mesh = {}\n", toml_string(o.mesh));
      if (o.fit_size > 0) out += fmt::format("fit_size = {}\n", toml_double(o.fit_size));
      else out += fmt::format("scale = {}\n", toml_double(o.scale));
      out += o.fill == MeshFill::surface ? "fill = \"surface\"\n" : "fill = \"volume\"\n";
      if (o.shell_thickness > 0) out += fmt::format("shell_thickness = {}\n", toml_double(o.shell_thickness));
    }
    out += fmt::format("position = {}\n", vec(o.position));
    out += fmt::format("rotation = {}\n", vec(o.rotation));
    out += fmt::format("velocity = {}\n", vec(o.velocity));
    out += fmt::format("material = {}\n", toml_string(o.material));
    if (o.heterogeneity) {
      out += "\n[object.heterogeneity]\n";
      write_heterogeneity(out, *o.heterogeneity);
    }
    for (const RegionDef& r : o.regions) {
      out += "\n[[object.region]]\n";
      out += fmt::format("shape = {}\n", toml_string(shape_name(r.shape)));
      out += fmt::format("center = {}\n", vec(r.center));
      out += fmt::format("size = {}\n", vec(r.size));
      out += fmt::format("radius = {}\n", toml_double(r.radius));
      if (r.shape == Shape::mesh) out += fmt::format("mesh = {}\n", toml_string(r.mesh));
      out += fmt::format("material = {}\n", toml_string(r.material));
    }
  }

  for (const ProjectileDef& p : s.projectiles) {
    out += "\n[[projectile]]\n";
    out += fmt::format("name = {}\n", toml_string(p.name));
    out += fmt::format("radius = {}\n", toml_double(p.radius));
    out += fmt::format("material = {}\n", toml_string(p.material));
    out += fmt::format("density = {}\n", toml_double(p.density));
    out += fmt::format("position = {}\n", vec(p.position));
    out += fmt::format("velocity = {}\n", vec(p.velocity));
    out += fmt::format("angular_velocity = {}\n", vec(p.angular_velocity));
    out += fmt::format("kinematic = {}\n", p.kinematic);
    out += fmt::format("rolling_friction = {}\n", toml_double(p.rolling_friction));
    out += fmt::format("twisting_friction = {}\n", toml_double(p.twisting_friction));
  }

  for (const GripDef& g : s.grips) {
    out += "\n[[grip]]\n";
    out += fmt::format("name = {}\n", toml_string(g.name));
    out += fmt::format("min = {}\n", vec(g.min));
    out += fmt::format("max = {}\n", vec(g.max));
    out += fmt::format("velocity = {}\n", vec(g.velocity));
  }

  for (const LoadDef& l : s.loads) {
    out += "\n[[load]]\n";
    out += fmt::format("name = {}\n", toml_string(l.name));
    out += fmt::format("min = {}\n", vec(l.min));
    out += fmt::format("max = {}\n", vec(l.max));
    out += fmt::format("force = {}\n", vec(l.force));
  }
  return out;
}

}  // namespace mca::io
