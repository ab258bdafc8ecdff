// mca.Scene and its parts: the definition structs of include/mca/scene.hpp under the key names of
// docs/scene-format.md, read and written by the scene reader and writer of src/io and checked by
// validate_scene, so a scene built in Python gets the messages a scene file gets.
#include <pybind11/numpy.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <cmath>
#include <filesystem>
#include <limits>
#include <type_traits>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <fmt/format.h>

#include "bindings.hpp"
#include "core/text.hpp"
#include "io/output_files.hpp"
#include "io/scene_io.hpp"
#include "mca/error.hpp"

namespace mca::python {
namespace {

// ---- values given from Python ----------------------------------------------------------------------------

std::string type_name(py::handle h) { return py::str(py::type::handle_of(h).attr("__name__")); }

// N numbers from any sequence of them (a list, a tuple, a one-dimensional numpy array), each a number as
// to_number takes it: not text, bytes (b"abc" was taken as its three character codes) or bools.
template <std::size_t N>
std::array<double, N> to_array(py::handle value, const std::string& key, const char* form) {
  const bool flat = !py::isinstance<py::array>(value) || py::reinterpret_borrow<py::array>(value).ndim() == 1;
  if (!py::isinstance<py::sequence>(value) || PyUnicode_Check(value.ptr()) || PyBytes_Check(value.ptr()) ||
      PyByteArray_Check(value.ptr()) || !flat || py::len(value) != N)
    throw Error(fmt::format("{} = {} is not {} numbers; give {}", key, shown(value),
                            N == 3 ? "three" : N == 4 ? "four" : std::to_string(N), form));
  std::array<double, N> a{};
  const auto seq = py::reinterpret_borrow<py::sequence>(value);
  for (std::size_t k = 0; k < N; ++k)
    a[k] = to_number(seq[k], fmt::format("{} = {}: component {}", key, shown(value), k), form);
  return a;
}
Vec3d to_vec3(py::handle value, const std::string& key) { return to_array<3>(value, key, "[x, y, z]"); }
py::tuple from_vec3(const Vec3d& v) { return py::make_tuple(v[0], v[1], v[2]); }

}  // namespace

// A key whose value is one of a few words (shape, fill, ...): the reader's message for anything else.
std::string choice(const std::string& key, const std::string& value, const std::vector<std::string>& allowed,
                   const std::string& what) {
  if (std::find(allowed.begin(), allowed.end(), value) != allowed.end()) return value;
  std::string list;
  for (std::size_t k = 0; k < allowed.size(); ++k)
    list += (k == 0 ? "" : k + 1 == allowed.size() ? " or " : ", ") + text::quoted(allowed[k]);
  throw Error(fmt::format("{} = {} is not {}{}; use {}", key, text::quoted(value), what,
                          text::did_you_mean(value, allowed), list));
}

std::optional<SolverDef::Backend> to_backend(py::handle value, const std::string& key) {
  if (value.is_none()) return std::nullopt;
  const std::string v = to_text(value, key, "a str: \"auto\", \"cpu\", \"cuda\" or \"cuda-emulation\"");
  return parse_backend(choice(key, v, {"auto", "cpu", "cuda", "cuda-emulation"}, "a backend"));
}


// ---- plain values: one conversion per kind (number, whole number, text, bool) ----------------------------

std::string shown(py::handle value) {
  std::string r;
  try {
    r = py::repr(value).cast<std::string>();
  } catch (const py::error_already_set&) {
    r = "<" + type_name(value) + ">";
  }
  if (r.size() > 80) r = r.substr(0, 77) + "...";
  return r;
}

namespace {
bool is_bool(py::handle v) {
  if (PyBool_Check(v.ptr())) return true;
  const py::handle t = py::type::handle_of(v);
  if (!py::hasattr(t, "__module__") || py::str(t.attr("__module__")).cast<std::string>() != "numpy") return false;
  const std::string n = py::str(t.attr("__name__"));
  return n == "bool_" || n == "bool";
}
}  // namespace

double to_number(py::handle v, const std::string& key, const std::string& what) {
  const auto refuse = [&](const char* why) {
    return Error(fmt::format("{} = {} {}; give {}", key, shown(v), why, what));
  };
  if (is_bool(v) || PyUnicode_Check(v.ptr()) || PyBytes_Check(v.ptr()) || PyComplex_Check(v.ptr()) ||
      !PyNumber_Check(v.ptr()))
    throw refuse("is not a number");
  const double d = PyFloat_AsDouble(v.ptr());
  if (d == -1.0 && PyErr_Occurred()) {
    const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError) != 0;
    PyErr_Clear();
    throw refuse(overflow ? "is too large for a number" : "is not a number");
  }
  return d;
}

std::int64_t to_whole(py::handle v, const std::string& key, std::int64_t min, std::int64_t max, const std::string& what) {
  if (is_bool(v) || !PyIndex_Check(v.ptr()))
    throw Error(fmt::format("{} = {} is not a whole number; give {}", key, shown(v), what));
  const py::object i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
  if (!i) {
    PyErr_Clear();
    throw Error(fmt::format("{} = {} is not a whole number; give {}", key, shown(v), what));
  }
  int overflow = 0;
  const long long x = PyLong_AsLongLongAndOverflow(i.ptr(), &overflow);
  if (x == -1 && PyErr_Occurred()) {
    PyErr_Clear();
    throw Error(fmt::format("{} = {} is not a whole number; give {}", key, shown(v), what));
  }
  if (overflow != 0 || x < min || x > max)
    throw Error(fmt::format("{} = {} is out of range; give {}", key, shown(v), what));
  return x;
}

std::string to_text(py::handle v, const std::string& key, const std::string& what) {
  if (!PyUnicode_Check(v.ptr())) throw Error(fmt::format("{} = {} is not text; give {}", key, shown(v), what));
  Py_ssize_t size = 0;
  const char* utf8 = PyUnicode_AsUTF8AndSize(v.ptr(), &size);
  if (!utf8) {  // (a lone surrogate: the name of a file that is not UTF-8, as os.listdir gives it)
    PyErr_Clear();
    throw Error(fmt::format("{} = {} is text that is not valid Unicode (a lone surrogate); give {}", key, shown(v),
                            what));
  }
  return std::string(utf8, static_cast<std::size_t>(size));
}

bool to_bool(py::handle v, const std::string& key, const std::string& what) {
  if (!is_bool(v)) throw Error(fmt::format("{} = {} is not True or False; give {}", key, shown(v), what));
  return PyObject_IsTrue(v.ptr()) == 1;
}

std::filesystem::path to_path(py::handle v, const std::string& key) {
  if (PyUnicode_Check(v.ptr()) || py::hasattr(v, "__fspath__")) {
    // The file system's bytes of the name (os.fsencode): a name that is not UTF-8, which os.listdir gives
    // with lone surrogates, is the file's own name again.
    py::object b;
    try {
      b = py::module_::import("os").attr("fsencode")(v);
    } catch (const py::error_already_set&) {
      throw Error(fmt::format("{} = {} is not a path; give a str or a pathlib.Path", key, shown(v)));
    }
    if (PyBytes_Check(b.ptr())) {
      std::string bytes = py::reinterpret_borrow<py::bytes>(b);
      // (As open() does: the system would end the name at the NUL, and "notes.txt\0.mcack" wrote notes.txt.)
      if (bytes.find('\0') != std::string::npos)
        throw Error(fmt::format("{} = {} holds a NUL character (embedded null byte), which no file name can; give "
                                "the path without it",
                                key, shown(v)));
      return bytes;
    }
  }
  throw Error(fmt::format("{} = {} is not a path; give a str or a pathlib.Path", key, shown(v)));
}

namespace {

// A plain key of a table: the value converted by its kind, so a wrong type names the key. Whole numbers are
// held to their field's range (the seed to -2^63 .. 2^64 - 1, as a scene file's).
const char* table_of(const MaterialDef*) { return "material"; }
const char* table_of(const HeterogeneityDef*) { return "heterogeneity"; }
const char* table_of(const RegionDef*) { return "region"; }
const char* table_of(const ProjectileDef*) { return "projectile"; }
const char* table_of(const GripDef*) { return "grip"; }
const char* table_of(const LoadDef*) { return "load"; }
const char* table_of(const GroundDef*) { return "ground"; }
const char* table_of(const SolverDef*) { return "solver"; }
const char* table_of(const OutputDef*) { return "output"; }
const char* table_of(const CameraDef*) { return "camera"; }

template <class V>
V convert(py::handle v, const std::string& key, const std::string& doc) {
  if constexpr (std::is_same_v<V, double>) {
    return to_number(v, key, fmt::format("a number ({})", doc));
  } else if constexpr (std::is_same_v<V, bool>) {
    return to_bool(v, key, fmt::format("True or False ({})", doc));
  } else if constexpr (std::is_same_v<V, std::string>) {
    return to_text(v, key, fmt::format("a str ({})", doc));
  } else if constexpr (std::is_same_v<V, std::uint64_t>) {
    // The seed: unsigned 64-bit, as the reader takes it; a negative one is its two's complement, as in a scene
    // file (docs/scene-format.md: -1 is 18446744073709551615).
    const std::string what =
        fmt::format("a whole number from -2^63 to 2^64 - 1, a negative one standing for its two's complement ({})", doc);
    if (is_bool(v) || !PyIndex_Check(v.ptr()))
      throw Error(fmt::format("{} = {} is not a whole number; give {}", key, shown(v), what));
    const py::object i = py::reinterpret_steal<py::object>(PyNumber_Index(v.ptr()));
    if (!i) {
      PyErr_Clear();
      throw Error(fmt::format("{} = {} is not a whole number; give {}", key, shown(v), what));
    }
    const unsigned long long x = PyLong_AsUnsignedLongLong(i.ptr());
    if (x == static_cast<unsigned long long>(-1) && PyErr_Occurred()) {
      PyErr_Clear();
      const long long negative = PyLong_AsLongLong(i.ptr());
      if (negative == -1 && PyErr_Occurred()) {
        PyErr_Clear();
        throw Error(fmt::format("{} = {} is out of range; give {}", key, shown(v), what));
      }
      return static_cast<V>(negative);  // (below 0: 2^64 + negative)
    }
    return static_cast<V>(x);
  } else {
    static_assert(std::is_integral_v<V>, "a plain key is a number, a whole number, text or a bool");
    constexpr auto lo = static_cast<std::int64_t>(std::numeric_limits<V>::min());
    constexpr auto hi = static_cast<std::int64_t>(
        std::min<std::uint64_t>(std::numeric_limits<V>::max(), std::numeric_limits<std::int64_t>::max()));
    // (The key's own range, narrower than its type's, is in `doc` and is the scene check's.)
    return static_cast<V>(to_whole(v, key, lo, hi, fmt::format("a whole number ({})", doc)));
  }
}

template <class T, class V>
auto key_getter(V T::*member) {
  return [member](const T& t) { return t.*member; };
}
template <class T, class V>
auto key_setter(V T::*member, const char* name, const char* doc) {
  return [member, key = fmt::format("{}.{}", table_of(static_cast<const T*>(nullptr)), name), doc = std::string(doc)](
             T& t, py::handle v) { t.*member = convert<V>(v, key, doc); };
}
// .def_property(MCA_KEY(SolverDef, spacing, "doc")): the key `spacing` of SolverDef, checked when set.
#define MCA_KEY(T, member, doc) #member, key_getter(&T::member), key_setter(&T::member, #member, doc), doc
// The same for a key of PyObjectDef's ObjectDef.
#define MCA_OBJECT_KEY(member, doc)                                                                          \
  #member, [](const PyObjectDef& o) { return o.def.member; },                                                \
      [](PyObjectDef& o, py::handle v) { o.def.member = convert<decltype(ObjectDef::member)>(v, "object." #member, doc); }, \
      doc

// A mesh key's value: a relative path resolved when it is set, as a scene file's are when it is read, from
// the current folder (for the scene file's), MCA_MESH_PATH and the models cache (it was resolved when the
// Simulation was built, from whatever folder was current then: a script that changed folder in between
// lost its mesh).
std::string mesh_path(py::handle v, const std::string& key) {
  const std::filesystem::path path = to_path(v, key);
  if (!text::is_utf8(path.string()))
    throw Error(fmt::format("{} = \"{}\": the path is not UTF-8 text, which a scene (TOML) holds; rename the file or "
                            "its folder",
                            key, text::utf8_shown(path.string())));
  if (path.empty()) return "";
  // Where a scene file's would be looked for (the current folder standing in for the scene file's, then
  // MCA_MESH_PATH and the models cache): the first that is a file; else the current folder's.
  std::error_code ec;
  const auto candidates = io::mesh_file_candidates(path.string(), "<python>");
  std::filesystem::path found = candidates.front();
  for (const auto& c : candidates)
    if (std::filesystem::is_regular_file(c, ec)) {
      found = c;
      break;
    }
  const std::filesystem::path absolute = std::filesystem::absolute(found, ec);
  return ec ? found.string() : absolute.lexically_normal().string();
}

// ---- keyword construction: Material(name="weak", tensile_strength=1e6) ----------------------------------

// The keys of a bound class: its properties (what dir() lists that is a `property`).
std::vector<std::string> keys_of(py::handle cls) {
  std::vector<std::string> keys;
  const py::object property = py::module_::import("builtins").attr("property");
  for (const auto& name : py::module_::import("builtins").attr("dir")(cls)) {
    const std::string n = py::str(name);
    if (n.rfind("_", 0) == 0) continue;
    if (py::isinstance(cls.attr("__dict__").attr("get")(name, py::none()), property)) keys.push_back(n);
  }
  return keys;
}

// Sets each keyword on `obj` through its property (so every key is checked as an assignment is), refusing
// a key the class does not have with the reader's did-you-mean.
void apply_keys(py::handle obj, const py::kwargs& kw, const std::string& table) {
  const py::handle cls = py::type::handle_of(obj);
  std::vector<std::string> keys;
  for (const auto& item : kw) {
    const std::string key = py::str(item.first);
    if (keys.empty()) keys = keys_of(cls);
    if (std::find(keys.begin(), keys.end(), key) == keys.end())
      throw Error(fmt::format("mca.{}: '{}' is not a key of {}{}", type_name(obj), key, table,
                              text::suggestion(key, keys)));
    py::setattr(obj, item.first, item.second);
  }
}

// T(**keys) for a struct bound by value: a default T with each key set through its property.
template <class T>
void keyword_init(py::class_<T>& c, const std::string& table) {
  c.def(py::init([table](const py::kwargs& kw) {
          T value{};
          apply_keys(py::cast(&value, py::return_value_policy::reference), kw, table);
          return value;
        }),
        fmt::format("A {} with the defaults of docs/scene-format.md, changed by the keys given (by their names "
                    "there); an unknown key raises mca.Error.",
                    table)
            .c_str());
}

// A field of three numbers (a tuple when read: change it by assigning three numbers).
template <class T>
void vec3(py::class_<T>& c, const char* name, Vec3d T::*field, const char* doc) {
  const std::string key = fmt::format("{}.{}", table_of(static_cast<const T*>(nullptr)), name);
  c.def_property(
      name, [field](const T& t) { return from_vec3(t.*field); },
      [field, key](T& t, py::handle v) { t.*field = to_vec3(v, key); }, doc);
}

template <class T>
std::string repr_of(const T& value, const char* cls);

// ---- conversions between the Python lists and the C++ vectors ---------------------------------------------

template <class T>
std::vector<T> vector_of(const py::list& list, const std::string& key, const char* cls) {
  std::vector<T> out;
  out.reserve(list.size());
  for (std::size_t k = 0; k < list.size(); ++k) {
    if (!py::isinstance<T>(list[k]))
      throw Error(fmt::format("{}[{}] is a {}, not an mca.{}; append mca.{}(...) (or use the add_ method)", key, k,
                              type_name(list[k]), cls, cls));
    out.push_back(list[k].cast<T>());
  }
  return out;
}
template <class T>
py::list list_of(const std::vector<T>& v) {
  py::list out;
  for (const T& x : v) out.append(py::cast(x));
  return out;
}
// A list key (scene.objects = [...]): a list (its elements are checked when the scene is used).
py::list list_value(const py::object& v, const std::string& key, const char* cls) {
  if (!py::isinstance<py::list>(v))
    throw Error(fmt::format("{} = {} is not a list; give a list of mca.{}", key, shown(v), cls));
  // Its items are checked now, as a key's value is when it is set (a list appended to later is checked by
  // validate() and when a Simulation is built).
  const py::object type = py::module_::import("mca._mca").attr(cls);
  const auto list = py::reinterpret_borrow<py::list>(v);
  for (std::size_t k = 0; k < list.size(); ++k)
    if (!py::isinstance(list[k], type))
      throw Error(fmt::format("{}[{}] is a {}, not an mca.{}; give a list of mca.{}", key, k, type_name(list[k]), cls, cls));
  return list;
}
template <class T>
T value_of(const py::object& o, const std::string& key, const char* cls) {
  if (!py::isinstance<T>(o))
    throw Error(fmt::format("{} is a {}, not an mca.{}; assign mca.{}(...)", key, type_name(o), cls, cls));
  return o.cast<T>();
}

// The heterogeneity's preset: the reader's rules (a named preset sets the shares; "custom" is what shares
// given by hand are called).
void set_preset(HeterogeneityDef& h, const std::string& preset) {
  if (preset == "custom")
    throw Error("heterogeneity.preset = \"custom\" is implied by shares; assign shares = [p1, p2, p3, p4] instead");
  std::array<double, 4> shares{};
  if (!heterogeneity_preset(preset, shares))
    throw Error(fmt::format("heterogeneity.preset = {} is not a preset{}; use \"none\", \"low\", \"medium\" or "
                            "\"high\", or give shares = [p1, p2, p3, p4]",
                            text::quoted(preset), text::did_you_mean(preset, {"none", "low", "medium", "high"})));
  h.preset = preset;
  h.shares = shares;
}

}  // namespace

// ---- PyObjectDef and PyScene --------------------------------------------------------------------------------

ObjectDef PyObjectDef::to_def(const std::string& key) const {
  ObjectDef o = def;
  o.regions = vector_of<RegionDef>(regions, key + ".regions", "Region");
  if (heterogeneity.is_none()) o.heterogeneity.reset();
  else o.heterogeneity = value_of<HeterogeneityDef>(heterogeneity, key + ".heterogeneity", "Heterogeneity");
  return o;
}

PyObjectDef PyObjectDef::from_def(const ObjectDef& d) {
  PyObjectDef o;
  o.def = d;
  o.def.regions.clear();
  o.def.heterogeneity.reset();
  o.regions = list_of(d.regions);
  if (d.heterogeneity) o.heterogeneity = py::cast(*d.heterogeneity);
  return o;
}

PyScene::PyScene()
    : heterogeneity(py::cast(HeterogeneityDef{})),
      solver(py::cast(SolverDef{})),
      output(py::cast(OutputDef{})),
      ground(py::cast(GroundDef{})),
      camera(py::cast(CameraDef{})) {}

SceneDef PyScene::to_def() const {
  SceneDef s;
  s.name = name;
  s.source = source;
  s.materials = vector_of<MaterialDef>(materials, "scene.materials", "Material");
  s.heterogeneity = value_of<HeterogeneityDef>(heterogeneity, "scene.heterogeneity", "Heterogeneity");
  for (std::size_t k = 0; k < objects.size(); ++k) {
    const std::string key = fmt::format("scene.objects[{}]", k);
    if (!py::isinstance<PyObjectDef>(objects[k]))
      throw Error(fmt::format("{} is a {}, not an mca.Object; append mca.Object(...) (or use scene.add_object)", key,
                              type_name(objects[k])));
    s.objects.push_back(objects[k].cast<const PyObjectDef&>().to_def(key));
  }
  s.projectiles = vector_of<ProjectileDef>(projectiles, "scene.projectiles", "Projectile");
  s.grips = vector_of<GripDef>(grips, "scene.grips", "Grip");
  s.loads = vector_of<LoadDef>(loads, "scene.loads", "Load");
  s.ground = value_of<GroundDef>(ground, "scene.ground", "Ground");
  s.solver = value_of<SolverDef>(solver, "scene.solver", "Solver");
  s.output = value_of<OutputDef>(output, "scene.output", "Output");
  s.camera = value_of<CameraDef>(camera, "scene.camera", "Camera");
  // A scene read from a file, then changed here: its messages must not send the user to the file for a value
  // it does not hold (a ball placed in the wall from Python was "<built-in>/wall_ball.toml: ...").
  static constexpr std::string_view kChanged = " (as changed from Python)";
  if (!read_as.empty() && !s.source.ends_with(kChanged) && io::scene_to_toml(s) != read_as) s.source += kChanged;
  return s;
}

namespace {
// A deep copy, with the source and the scene as read (a copy of a scene changed from Python says so).
PyScene copy_of(const PyScene& s) {
  PyScene c = PyScene::from_def(s.to_def());
  c.source = s.source;
  c.read_as = s.read_as;
  return c;
}
}  // namespace

PyScene PyScene::from_def(const SceneDef& d) {
  PyScene s;
  s.name = d.name;
  s.source = d.source;
  if (d.source != "<python>") s.read_as = io::scene_to_toml(d);
  s.materials = list_of(d.materials);
  s.heterogeneity = py::cast(d.heterogeneity);
  for (const ObjectDef& o : d.objects) s.objects.append(py::cast(PyObjectDef::from_def(o)));
  s.projectiles = list_of(d.projectiles);
  s.grips = list_of(d.grips);
  s.loads = list_of(d.loads);
  s.ground = py::cast(d.ground);
  s.solver = py::cast(d.solver);
  s.output = py::cast(d.output);
  s.camera = py::cast(d.camera);
  return s;
}

namespace {

// scene.add_object(...) and the like: a new element named by its index as the reader names them
// ("object1", "ball2", ...), the keys applied, appended; returns the element (the list's own).
template <class T>
py::object add_to(py::list& list, const char* base, const py::kwargs& kw, const std::string& table,
                  std::string T::*name) {
  T value{};
  if (list.size() > 0) value.*name = fmt::format("{}{}", base, list.size());
  py::object obj = py::cast(value);
  apply_keys(obj, kw, table);
  list.append(obj);
  return obj;
}

}  // namespace

void bind_scene(py::module_& m) {
  // ---- [[material]] ----
  py::class_<MaterialDef> material(m, "Material", "A [[material]] of docs/scene-format.md (SI units).");
  keyword_init(material, "[[material]]");
  material.def_property(MCA_KEY(MaterialDef, name, "name objects refer to (non-empty, unique)"))
      .def_property(MCA_KEY(MaterialDef, youngs_modulus, "E [Pa], in [1e3, 1e13]"))
      .def_property(MCA_KEY(MaterialDef, poisson_ratio, "nu, in (-1, 0.5)"))
      .def_property(MCA_KEY(MaterialDef, density, "rho [kg/m^3], in [0.1, 1e5]"))
      .def_property(MCA_KEY(MaterialDef, tensile_strength, "sigma_b in tension [Pa], > 0"))
      .def_property(MCA_KEY(MaterialDef, compressive_strength, "[Pa], >= tensile_strength"))
      .def_property(MCA_KEY(MaterialDef, fracture_strain, "eps_b of the displacement criterion, > 0"))
      .def_property(MCA_KEY(MaterialDef, friction, "Coulomb mu of contacts, >= 0"))
      .def_property(MCA_KEY(MaterialDef, restitution, "coefficient of restitution, in [0.01, 1]"))
      .def_property(MCA_KEY(MaterialDef, rolling_friction, "mu_r of contacts, in [0, 1]"))
      .def_property(MCA_KEY(MaterialDef, twisting_friction, "mu_t of contacts, in [0, 1]"))
      .def_property(MCA_KEY(MaterialDef, damping_time, "Kelvin-Voigt viscosity time [s], in [0, 1e-3]"))
      .def_property(
          "strengthening",
          [](const MaterialDef& d) {
            return std::string(d.strengthening == StrengtheningLaw::exponential ? "exponential"
                               : d.strengthening == StrengtheningLaw::quadratic ? "quadratic"
                                                                                 : "none");
          },
          [](MaterialDef& d, py::handle value) {
            const std::string v = to_text(value, "material.strengthening", "a str");
            const std::string s = choice("material.strengthening", v, {"none", "exponential", "quadratic"},
                                         "a strengthening law");
            d.strengthening = s == "exponential" ? StrengtheningLaw::exponential
                              : s == "quadratic" ? StrengtheningLaw::quadratic
                                                 : StrengtheningLaw::none;
          },
          "paper eq. 7: \"none\", \"exponential\" or \"quadratic\"")
      .def_property(MCA_KEY(MaterialDef, strengthening_alpha, "alpha of eq. 7, >= 0"))
      .def_property(MCA_KEY(MaterialDef, fracture_energy,
                            "G_f [J/m^2] of the links' softening, in [0, 1e6]; 0: the instant break"))
      .def_property(MCA_KEY(MaterialDef, weibull_modulus,
                            "Weibull modulus of the links' own strengths, 0 (no spread) or in [1, 100]"))
      .def_static(
          "builtin",
          [](Given<py_type::str> name_arg) {
            const std::string name = to_text(name_arg, "Material.builtin: name", "a str: concrete, glass, ceramic, granite or steel");
            const MaterialDef* d = find_builtin_material(name);
            if (!d) {
              std::vector<std::string> names;
              for (const auto& b : builtin_materials()) names.push_back(b.name);
              throw Error(fmt::format("'{}' is not a built-in material{}", name, text::suggestion(name, names)));
            }
            return *d;
          },
          py::arg("name"), "A copy of the built-in material of that name (concrete, glass, ceramic, granite, steel).")
      .def("__repr__", [](const MaterialDef& d) {
        return fmt::format("mca.Material(name={}, youngs_modulus={}, tensile_strength={}, density={})",
                           text::quoted(d.name), text::num(d.youngs_modulus), text::num(d.tensile_strength),
                           text::num(d.density));
      });

  // ---- [heterogeneity] ----
  py::class_<HeterogeneityDef> het(m, "Heterogeneity",
                                   "[heterogeneity] (scene.heterogeneity) or [object.heterogeneity] (object.heterogeneity).");
  het.def(py::init([](const py::kwargs& kw) {
            if (kw.contains("preset") && kw.contains("shares"))
              throw Error("heterogeneity: preset and shares are both given; give either preset = "
                          "\"none|low|medium|high\" or shares = [p1, p2, p3, p4]");
            HeterogeneityDef h;
            apply_keys(py::cast(&h, py::return_value_policy::reference), kw, "[heterogeneity]");
            return h;
          }),
          "A heterogeneity with the defaults (preset \"none\": every automaton of class 4), changed by the keys given.");
  het.def_property(
         "preset", [](const HeterogeneityDef& h) { return h.preset; },
         [](HeterogeneityDef& h, py::handle v) { set_preset(h, to_text(v, "heterogeneity.preset", "a str: \"none\", \"low\", \"medium\" or \"high\"")); },
         "\"none\", \"low\", \"medium\" or \"high\": sets the shares of the paper's distribution; reads \"custom\" "
         "once shares are assigned")
      .def_property(
          "shares", [](const HeterogeneityDef& h) { return py::make_tuple(h.shares[0], h.shares[1], h.shares[2], h.shares[3]); },
          [](HeterogeneityDef& h, py::handle v) {
            h.shares = to_array<4>(v, "heterogeneity.shares", "[p1, p2, p3, p4] (class 1 = weakest)");
            h.preset = "custom";
          },
          "share of automata in strength class 1..4 (sum 1); assigning them makes the preset \"custom\"")
      .def_property(
          "class_factors",
          [](const HeterogeneityDef& h) {
            return py::make_tuple(h.class_factors[0], h.class_factors[1], h.class_factors[2], h.class_factors[3]);
          },
          [](HeterogeneityDef& h, py::handle v) {
            h.class_factors = to_array<4>(v, "heterogeneity.class_factors", "[k1, k2, k3, k4]");
          },
          "strength factor k_c of class 1..4 (each > 0, non-decreasing)")
      .def_property(MCA_KEY(HeterogeneityDef, grain_size, "[m]; 0: classes drawn per automaton, > 0: grains"))
      .def("__repr__", [](const HeterogeneityDef& h) {
        return fmt::format("mca.Heterogeneity(preset={}, shares=[{}, {}, {}, {}])", text::quoted(h.preset),
                           text::num(h.shares[0]), text::num(h.shares[1]), text::num(h.shares[2]),
                           text::num(h.shares[3]));
      });

  // ---- [[object.region]] ----
  py::class_<RegionDef> region(m, "Region", "An [[object.region]]: a material for the automata inside it.");
  keyword_init(region, "[[object.region]]");
  region
      .def_property(
          "shape", [](const RegionDef& r) { return std::string(io::shape_name(r.shape)); },
          [](RegionDef& r, py::handle value) {
            const std::string v = to_text(value, "region.shape", "a str");
            r.shape = io::to_shape(choice("region.shape", v, {"box", "sphere", "mesh"}, "a region shape"));
          },
          "\"box\", \"sphere\" or \"mesh\"")
      .def_property(
          "mesh", [](const RegionDef& r) { return r.mesh; },
          [](RegionDef& r, py::handle v) { r.mesh = mesh_path(v, "region.mesh"); },
          "a closed mesh file (shape \"mesh\"), the path to open (a relative one resolved when set: the current folder, "
          "MCA_MESH_PATH, the models cache)")
      .def_property(MCA_KEY(RegionDef, radius, "[m] (sphere)"))
      .def_property(MCA_KEY(RegionDef, material, "the material of the automata inside (required)"));
  vec3(region, "center", &RegionDef::center, "[m], world frame");
  vec3(region, "size", &RegionDef::size, "[m], full extents along the world axes (box)");

  // ---- [[object]] ----
  py::class_<PyObjectDef> object(m, "Object", "An [[object]] of docs/scene-format.md.");
  object.def(py::init([](const py::kwargs& kw) {
               PyObjectDef o;
               apply_keys(py::cast(&o, py::return_value_policy::reference), kw, "[[object]]");
               return o;
             }),
             "An object with the defaults (a 1 m concrete box at the origin), changed by the keys given.");
  object.def_property(MCA_OBJECT_KEY(name, "non-empty, unique"))
      .def_property(
          "shape", [](const PyObjectDef& o) { return std::string(io::shape_name(o.def.shape)); },
          [](PyObjectDef& o, py::handle value) {
            const std::string v = to_text(value, "object.shape", "a str");
            o.def.shape = io::to_shape(choice("object.shape", v, {"box", "sphere", "cylinder", "mesh"}, "a shape"));
          },
          "\"box\", \"sphere\", \"cylinder\" or \"mesh\"")
      .def_property(
          "size", [](const PyObjectDef& o) { return from_vec3(o.def.size); },
          [](PyObjectDef& o, py::handle v) { o.def.size = to_vec3(v, "object.size"); }, "[m], full extents (box)")
      .def_property(MCA_OBJECT_KEY(radius, "[m] (sphere, cylinder)"))
      .def_property(MCA_OBJECT_KEY(height, "[m] (cylinder, along its local z)"))
      .def_property(
          "mesh", [](const PyObjectDef& o) { return o.def.mesh; },
          [](PyObjectDef& o, py::handle v) { o.def.mesh = mesh_path(v, "object.mesh"); },
          "a triangle mesh file (shape \"mesh\"): the path to open (a relative one resolved when set, as a scene file's "
          "when it is read: the current folder for the scene file's, MCA_MESH_PATH, the models cache)")
      .def_property(MCA_OBJECT_KEY(scale, "file units to metres (mesh), > 0"))
      .def_property(MCA_OBJECT_KEY(fit_size, "[m]: > 0 scales the mesh to this largest extent"))
      .def_property(
          "fill", [](const PyObjectDef& o) { return std::string(o.def.fill == MeshFill::surface ? "surface" : "volume"); },
          [](PyObjectDef& o, py::handle value) {
            const std::string v = to_text(value, "object.fill", "a str");
            o.def.fill = choice("object.fill", v, {"volume", "surface"}, "a fill mode") == "surface" ? MeshFill::surface
                                                                                                     : MeshFill::volume;
          },
          "\"volume\" or \"surface\" (mesh)")
      .def_property(MCA_OBJECT_KEY(shell_thickness, "[m] (surface fill); 0: the mean link length"))
      .def_property(
          "position", [](const PyObjectDef& o) { return from_vec3(o.def.position); },
          [](PyObjectDef& o, py::handle v) { o.def.position = to_vec3(v, "object.position"); }, "[m], its centre")
      .def_property(
          "rotation", [](const PyObjectDef& o) { return from_vec3(o.def.rotation); },
          [](PyObjectDef& o, py::handle v) { o.def.rotation = to_vec3(v, "object.rotation"); },
          "degrees about x, then y, then z")
      .def_property(
          "velocity", [](const PyObjectDef& o) { return from_vec3(o.def.velocity); },
          [](PyObjectDef& o, py::handle v) { o.def.velocity = to_vec3(v, "object.velocity"); },
          "[m/s], initial velocity of its automata")
      .def_property(MCA_OBJECT_KEY(material, "a built-in or scene material"))
      .def_property(
          "regions", [](const PyObjectDef& o) { return o.regions; },
          [](PyObjectDef& o, const py::object& v) { o.regions = list_value(v, "object.regions", "Region"); },
          "a list of mca.Region")
      .def_property(
          "heterogeneity", [](const PyObjectDef& o) { return o.heterogeneity; },
          [](PyObjectDef& o, const py::object& v) {
            if (!v.is_none() && !py::isinstance<HeterogeneityDef>(v))
              throw Error(fmt::format("object.heterogeneity is a {}, not an mca.Heterogeneity or None", type_name(v)));
            o.heterogeneity = v;
          },
          "an mca.Heterogeneity of its own (it starts from the defaults, where a scene file's "
          "[object.heterogeneity] starts from the scene's), or None for the scene's")
      .def(
          "add_region",
          [](PyObjectDef& o, const py::kwargs& kw) {
            py::object r = py::cast(RegionDef{});
            apply_keys(r, kw, "[[object.region]]");
            o.regions.append(r);
            return r;
          },
          "Appends an mca.Region with the keys given and returns it.")
      .def("__repr__", [](const PyObjectDef& o) {
        return fmt::format("mca.Object(name={}, shape={}, material={})", text::quoted(o.def.name),
                           text::quoted(io::shape_name(o.def.shape)), text::quoted(o.def.material));
      });

  // ---- [[projectile]] ----
  py::class_<ProjectileDef> projectile(m, "Projectile", "A [[projectile]]: a rigid ball.");
  keyword_init(projectile, "[[projectile]]");
  projectile.def_property(MCA_KEY(ProjectileDef, name, "names the ball (\"ball\", \"ball1\", ... by index)"))
      .def_property(MCA_KEY(ProjectileDef, radius, "[m], > 0"))
      .def_property(MCA_KEY(ProjectileDef, material, "a known material (default steel)"))
      .def_property(MCA_KEY(ProjectileDef, density, "[kg/m^3]; 0: the material's"))
      .def_property(MCA_KEY(ProjectileDef, kinematic, "True: moves at its initial velocity whatever it hits"))
      .def_property(MCA_KEY(ProjectileDef, rolling_friction, "in [0, 1]"))
      .def_property(MCA_KEY(ProjectileDef, twisting_friction, "in [0, 1]"))
      .def("__repr__", [](const ProjectileDef& p) {
        return fmt::format("mca.Projectile(name={}, radius={}, velocity=[{}, {}, {}])", text::quoted(p.name),
                           text::num(p.radius), text::num(p.velocity[0]), text::num(p.velocity[1]),
                           text::num(p.velocity[2]));
      });
  vec3(projectile, "position", &ProjectileDef::position, "[m], its centre");
  vec3(projectile, "velocity", &ProjectileDef::velocity, "[m/s], initial velocity");
  vec3(projectile, "angular_velocity", &ProjectileDef::angular_velocity, "[rad/s]");

  // ---- [[grip]] and [[load]] ----
  py::class_<GripDef> grip(m, "Grip", "A [[grip]]: the automata in the box move at a fixed velocity.");
  keyword_init(grip, "[[grip]]");
  grip.def_property(MCA_KEY(GripDef, name, "unique; names its force columns in stats.csv"));
  vec3(grip, "min", &GripDef::min, "[m], box corner (required)");
  vec3(grip, "max", &GripDef::max, "[m], box corner (required)");
  vec3(grip, "velocity", &GripDef::velocity, "[m/s]");
  py::class_<LoadDef> load(m, "Load", "A [[load]]: a constant force on each automaton in the box.");
  keyword_init(load, "[[load]]");
  load.def_property(MCA_KEY(LoadDef, name, "names the load (\"load\", \"load1\", ... by index)"));
  vec3(load, "min", &LoadDef::min, "[m], box corner (required)");
  vec3(load, "max", &LoadDef::max, "[m], box corner (required)");
  vec3(load, "force", &LoadDef::force, "[N] per automaton");

  // ---- [ground], [solver], [output], [camera] ----
  py::class_<GroundDef> ground(m, "Ground", "[ground]: a rigid plane normal to the up axis.");
  keyword_init(ground, "[ground]");
  ground.def_property(MCA_KEY(GroundDef, enabled, "True: the ground plane is there"))
      .def_property(MCA_KEY(GroundDef, height, "[m] along the up axis"))
      .def_property(MCA_KEY(GroundDef, friction, ">= 0"))
      .def_property(MCA_KEY(GroundDef, restitution, "in [0.01, 1]"))
      .def_property(MCA_KEY(GroundDef, rolling_friction, "in [0, 1]"))
      .def_property(MCA_KEY(GroundDef, twisting_friction, "in [0, 1]"));

  py::class_<SolverDef> solver(m, "Solver", "[solver]: the lattice and the integration.");
  keyword_init(solver, "[solver]");
  solver.def_property(MCA_KEY(SolverDef, spacing, "lattice spacing d [m], > 0"))
      .def_property(MCA_KEY(SolverDef, target_automata, "> 0: d chosen so the count lands within 2 %"))
      .def_property(MCA_KEY(SolverDef, safety, "the step's share of the critical step, in (0, 1]"))
      .def_property(MCA_KEY(SolverDef, time_step, "[s]; 0: automatic"))
      .def_property(MCA_KEY(SolverDef, mass_scaling, "surface-mode mass scaling, in [0, 1]"))
      .def_property(MCA_KEY(SolverDef, link_damping, "share of critical, in [0, 1]"))
      .def_property(MCA_KEY(SolverDef, local_damping, "Cundall alpha, in [0, 0.2]"))
      .def_property(MCA_KEY(SolverDef, stress_coefficient, "K_v of the stress criterion, > 0"))
      .def_property(
          "lattice",
          [](const SolverDef& s) { return std::string(s.lattice == SolverDef::Lattice::random ? "random" : "cubic"); },
          [](SolverDef& s, py::handle value) {
            const std::string v = to_text(value, "solver.lattice", "a str");
            s.lattice = choice("solver.lattice", v, {"cubic", "random"}, "a lattice") == "random" ? SolverDef::Lattice::random
                                                                                                : SolverDef::Lattice::cubic;
          },
          "\"random\" (the default: random sites, Voronoi neighbours) or \"cubic\" (the paper's)")
      .def_property(
          "backend", [](const SolverDef& s) { return std::string(backend_name(s.backend)); },
          [](SolverDef& s, py::handle value) {
            if (value.is_none()) throw Error("solver.backend = None is not text; give a str");
            s.backend = *to_backend(value, "solver.backend");
          },
          "where the step runs: \"auto\" (the default: an NVIDIA GPU where there is one, else the CPU), \"cpu\", "
          "\"cuda\" (an NVIDIA GPU) or \"cuda-emulation\" (the CUDA backend's algorithm on one core, for tests)")
      .def_property(MCA_KEY(SolverDef, lattice_jitter, "sites moved by up to this share of d, in [0, 0.3] (the cubic lattice); 0: its sites at the cells' centres"))
      .def_property(MCA_KEY(SolverDef, link_bending, "the random lattice's links' bending springs, share of a beam of their section: 0, or in [0.01, 1]; 0.1 the calibrated default"))
      .def_property(MCA_KEY(SolverDef, skin, "contact search skin, share of d, in (0, 0.4]"))
      .def_property(MCA_KEY(SolverDef, seed, "random seed of the strength classes"))
      .def_property(MCA_KEY(SolverDef, max_memory_gb, "refuse models whose estimate exceeds this [GB]"));
  vec3(solver, "gravity", &SolverDef::gravity, "[m/s^2]; defines up");

  py::class_<OutputDef> output(m, "Output", "[output]: the duration, frames and files of a run.");
  keyword_init(output, "[output]");
  output.def_property(MCA_KEY(OutputDef, duration, "simulated time [s], > 0"))
      .def_property(MCA_KEY(OutputDef, frame_rate, "output frames per simulated second, > 0"))
      .def_property(MCA_KEY(OutputDef, links, "also write intact links as VTK lines"))
      .def_property(MCA_KEY(OutputDef, vtk, "write per-frame VTK files"))
      .def_property(MCA_KEY(OutputDef, checkpoint_every, "frames between checkpoints (mca run); 0 = none"))
      .def_property(MCA_KEY(OutputDef, surface, "write the mesh objects' surface per frame"))
      .def_property(
          "surface_format",
          [](const OutputDef& o) { return std::string(o.surface_format == OutputDef::SurfaceFormat::obj ? "obj" : "ply"); },
          [](OutputDef& o, py::handle value) {
            const std::string v = to_text(value, "output.surface_format", "a str");
            o.surface_format = choice("output.surface_format", v, {"ply", "obj"}, "a surface format") == "obj"
                                   ? OutputDef::SurfaceFormat::obj
                                   : OutputDef::SurfaceFormat::ply;
          },
          "\"ply\" or \"obj\"")
      .def_property(MCA_KEY(OutputDef, fragments, "a closed mesh per fragment at the end (mca run)"))
      .def_property(MCA_KEY(OutputDef, fragment_min_automata, ">= 0"));

  py::class_<CameraDef> camera(m, "Camera", "[camera]: the renderer's camera (None: automatic).");
  keyword_init(camera, "[camera]");
  const auto optional_vec3 = [&camera](const char* name, std::optional<Vec3d> CameraDef::*field, const char* doc) {
    const std::string key = fmt::format("camera.{}", name);
    camera.def_property(
        name, [field](const CameraDef& c) -> py::object { return c.*field ? py::object(from_vec3(*(c.*field))) : py::none(); },
        [field, key](CameraDef& c, py::handle v) {
          if (v.is_none()) (c.*field).reset();
          else c.*field = to_vec3(v, key);
        },
        doc);
  };
  optional_vec3("position", &CameraDef::position, "[m], or None: a 3/4 view framing the objects");
  optional_vec3("target", &CameraDef::target, "[m], or None: the centre of the objects' box");
  camera.def_property(MCA_KEY(CameraDef, fov, "vertical field of view [degrees], in [5, 150]"));

  // ---- the scene ----
  py::class_<PyScene> scene(m, "Scene", R"(A scene: the keys of docs/scene-format.md.

Read one with Scene.load(path), Scene.from_toml(text) or Scene.default(); or start from Scene(name) and
add objects, projectiles, materials. validate() checks it with the command's messages; a Simulation
validates it too.)");
  scene.def(py::init([](Given<py_type::str> name) {
              PyScene s;
              s.name = to_text(name, "Scene: name", "a str");
              return s;
            }),
            py::arg("name") = "scene", "An empty scene (no objects) with every default.")
      .def_static(
          "load",
          [](Given<py_type::path> path) {
            return PyScene::from_def(io::load_scene_file(to_path(path, "Scene.load: path")));
          },
          py::arg("path"), "Reads a scene file (TOML); mesh paths are resolved as the command resolves them.")
      .def_static(
          "from_toml",
          [](Given<py_type::str> text, Given<py_type::str> source) {
            return PyScene::from_def(io::parse_scene(to_text(text, "Scene.from_toml: text", "the scene's TOML as a str"),
                                                     to_text(source, "Scene.from_toml: source", "a str naming the text")));
          },
          py::arg("text"), py::arg("source") = "<string>",
          "Parses a scene from TOML text; `source` names it in messages (and gives the name when the text has none).")
      .def_static(
          "default", [] { return PyScene::from_def(io::load_default_scene()); },
          "The built-in default scene (scenes/wall_ball.toml), as `mca run` with no scene uses.")
      .def_property(
          "name", [](const PyScene& s) { return s.name; },
          [](PyScene& s, py::handle v) { s.name = to_text(v, "scene.name", "a str"); }, "the scene's name (summary.json, the default output folder)")
      .def_property(
          "source",
          [](const PyScene& s) {  // (as os.fsdecode: a file name that is not UTF-8 keeps its bytes)
            return py::reinterpret_steal<py::str>(
                PyUnicode_DecodeFSDefaultAndSize(s.source.data(), static_cast<Py_ssize_t>(s.source.size())));
          },
          [](PyScene& s, py::handle v) { s.source = to_text(v, "scene.source", "a str"); }, "what messages call the scene (the file it came from; once changed from what was read, they add \" (as "
          "changed from Python)\")")
      .def_property(
          "materials", [](const PyScene& s) { return s.materials; },
          [](PyScene& s, const py::object& v) { s.materials = list_value(v, "scene.materials", "Material"); }, "list of mca.Material ([[material]])")
      .def_property(
          "objects", [](const PyScene& s) { return s.objects; },
          [](PyScene& s, const py::object& v) { s.objects = list_value(v, "scene.objects", "Object"); }, "list of mca.Object ([[object]])")
      .def_property(
          "projectiles", [](const PyScene& s) { return s.projectiles; },
          [](PyScene& s, const py::object& v) { s.projectiles = list_value(v, "scene.projectiles", "Projectile"); }, "list of mca.Projectile ([[projectile]])")
      .def_property(
          "grips", [](const PyScene& s) { return s.grips; },
          [](PyScene& s, const py::object& v) { s.grips = list_value(v, "scene.grips", "Grip"); }, "list of mca.Grip ([[grip]])")
      .def_property(
          "loads", [](const PyScene& s) { return s.loads; },
          [](PyScene& s, const py::object& v) { s.loads = list_value(v, "scene.loads", "Load"); }, "list of mca.Load ([[load]])")
      .def_property(
          "heterogeneity", [](const PyScene& s) { return s.heterogeneity; },
          [](PyScene& s, const py::object& v) { s.heterogeneity = py::cast(value_of<HeterogeneityDef>(v, "scene.heterogeneity", "Heterogeneity")); }, "mca.Heterogeneity ([heterogeneity])")
      .def_property(
          "solver", [](const PyScene& s) { return s.solver; }, [](PyScene& s, const py::object& v) { s.solver = py::cast(value_of<SolverDef>(v, "scene.solver", "Solver")); },
          "mca.Solver ([solver])")
      .def_property(
          "output", [](const PyScene& s) { return s.output; }, [](PyScene& s, const py::object& v) { s.output = py::cast(value_of<OutputDef>(v, "scene.output", "Output")); },
          "mca.Output ([output])")
      .def_property(
          "ground", [](const PyScene& s) { return s.ground; }, [](PyScene& s, const py::object& v) { s.ground = py::cast(value_of<GroundDef>(v, "scene.ground", "Ground")); },
          "mca.Ground ([ground])")
      .def_property(
          "camera", [](const PyScene& s) { return s.camera; }, [](PyScene& s, const py::object& v) { s.camera = py::cast(value_of<CameraDef>(v, "scene.camera", "Camera")); },
          "mca.Camera ([camera])")
      .def(
          "add_object",
          [](PyScene& s, const py::kwargs& kw) {
            PyObjectDef o;
            if (s.objects.size() > 0) o.def.name = fmt::format("object{}", s.objects.size());
            py::object obj = py::cast(std::move(o));
            apply_keys(obj, kw, "[[object]]");
            const std::string& name = obj.cast<const PyObjectDef&>().def.name;
            for (std::size_t k = 0; k < s.objects.size(); ++k)
              if (py::isinstance<PyObjectDef>(s.objects[k]) && s.objects[k].cast<const PyObjectDef&>().def.name == name)
                throw Error(fmt::format("add_object: scene.objects[{}] is named {} already; object names are unique, "
                                        "give name=\"...\" another",
                                        k, text::quoted(name)));
            s.objects.append(obj);
            return obj;
          },
          "Appends an mca.Object with the keys given (named \"object\", \"object1\", ... by index unless named) and "
          "returns it.")
      .def(
          "add_projectile",
          [](PyScene& s, const py::kwargs& kw) {
            return add_to<ProjectileDef>(s.projectiles, "ball", kw, "[[projectile]]", &ProjectileDef::name);
          },
          "Appends an mca.Projectile with the keys given (named \"ball\", \"ball1\", ... unless named) and returns it.")
      .def(
          "add_grip",
          [](PyScene& s, const py::kwargs& kw) { return add_to<GripDef>(s.grips, "grip", kw, "[[grip]]", &GripDef::name); },
          "Appends an mca.Grip with the keys given and returns it.")
      .def(
          "add_load",
          [](PyScene& s, const py::kwargs& kw) { return add_to<LoadDef>(s.loads, "load", kw, "[[load]]", &LoadDef::name); },
          "Appends an mca.Load with the keys given and returns it.")
      .def(
          "add_material",
          [](PyScene& s, Given<py_type::str> name_arg, Given<py_type::optional_str> base_arg, const py::kwargs& kw) {
            const std::string name = to_text(name_arg, "add_material: name", "a str naming the material");
            std::optional<std::string> base;
            if (!base_arg.value.is_none())
              base = to_text(base_arg, "add_material: base", "a str: an earlier scene material or a built-in");
            for (std::size_t k = 0; k < s.materials.size(); ++k)
              if (py::isinstance<MaterialDef>(s.materials[k]) && s.materials[k].cast<const MaterialDef&>().name == name)
                throw Error(fmt::format("add_material: scene.materials[{}] is named {} already; material names are "
                                        "unique, give another name (or change that one's keys)",
                                        k, text::quoted(name)));
            MaterialDef d;
            if (base) {
              // As the reader's `base`: an earlier [[material]] of the scene, then a built-in.
              const MaterialDef* from = nullptr;
              std::vector<std::string> names;
              for (std::size_t k = 0; k < s.materials.size(); ++k) {
                if (!py::isinstance<MaterialDef>(s.materials[k])) continue;
                const MaterialDef& e = s.materials[k].cast<const MaterialDef&>();
                names.push_back(e.name);
                if (e.name == *base) from = &e;
              }
              for (const auto& b : builtin_materials()) names.push_back(b.name);
              if (!from) from = find_builtin_material(*base);
              if (!from)
                throw Error(fmt::format("material base = {} is not a built-in or earlier material{}", text::quoted(*base),
                                        text::suggestion(*base, names)));
              d = *from;
            }
            d.name = name;
            py::object obj = py::cast(d);
            apply_keys(obj, kw, "[[material]]");
            s.materials.append(obj);
            return obj;
          },
          py::arg("name"), py::arg("base") = py::none(),
          "Appends a material named `name`: a copy of `base` (an earlier scene material or a built-in; without it, "
          "concrete's values) with the keys given; returns it.")
      .def(
          "validate", [](const PyScene& s) { validate_scene(s.to_def()); },
          "Checks ranges and references with the command's code; raises mca.Error naming the key, the value and the "
          "fix.")
      .def(
          "to_toml", [](const PyScene& s) { return io::scene_to_toml(s.to_def()); },
          "The complete scene as TOML, every key written (what `mca run` writes as scene.toml); Scene.from_toml "
          "reads it back to the same scene.")
      .def(
          "save",
          [](const PyScene& s, Given<py_type::path> path_arg) {
            namespace fs = std::filesystem;
            const fs::path given = to_path(path_arg, "Scene.save: path");
            const std::string text = io::scene_to_toml(s.to_def());
            // To a temporary name, then renamed: a full disk leaves the file that was there, not half a scene.
            // As writing the file in place would: through a link to the file it names, not over a file the
            // user may not write, and with the mode the file had.
            std::error_code ec;
            const fs::path path = fs::is_symlink(given, ec) ? fs::weakly_canonical(given, ec) : given;
            const fs::file_status before = fs::status(path, ec);
            if (fs::exists(before) && ::access(path.c_str(), W_OK) != 0)
              throw Error(fmt::format("{}: cannot be written ({}); save to another path, or make it writable",
                                      given.string(), std::strerror(errno)));
            io::write_file_atomic(path, [&](std::ostream& os) { os << text; }, false);
            if (fs::exists(before)) fs::permissions(path, before.permissions(), ec);
          },
          py::arg("path"), "Writes to_toml() to a file.")
      .def("copy", &copy_of, "A deep copy: changing it leaves this scene as it is.")
      .def("__copy__", &copy_of, "A deep copy (copy.copy).")
      .def("__deepcopy__", [](const PyScene& s, const py::object&) { return copy_of(s); }, py::arg("memo"),
           "A deep copy (copy.deepcopy).")
      // Pickled as its TOML (what a process pool sends its workers): read back by Scene.from_toml, which is
      // called here first, so that a scene it would refuse (validate_scene's checks, a mesh not found) is
      // refused where it is pickled, not in the process that reads it. (__reduce__, not py::pickle: pickle's
      // protocols 0 and 1 aborted the interpreter on the latter.)
      .def("__reduce__", [](const PyScene& s) {
        const SceneDef def = s.to_def();  // (its source says whether it was changed from Python)
        const std::string text = io::scene_to_toml(def);
        (void)io::parse_scene(text, def.source);
        // (mca._scene_from_toml, a Python function: pickle names it by reference, which it cannot do for a
        // function of this extension, bound to a capsule.)
        return py::make_tuple(py::module_::import("mca").attr("_scene_from_toml"), py::make_tuple(text, def.source));
      }, "For pickle: Scene.from_toml of its TOML and its source, tried first (mca.Error here for a scene it would "
         "refuse: validate()'s checks, a mesh not found).")
      .def(
          "__eq__",
          [](const PyScene& a, const PyScene& b) { return io::scene_to_toml(a.to_def()) == io::scene_to_toml(b.to_def()); },
          py::is_operator(), "Equal when every key is (their to_toml() texts are equal).")
      .def("__repr__", [](const PyScene& s) {
        const std::string r = fmt::format("<mca.Scene {} from {}: {} objects, {} projectiles>", text::quoted(s.name),
                                          s.source, s.objects.size(), s.projectiles.size());
        // (a file name that is not UTF-8: its bytes as \xNN)
        return py::reinterpret_steal<py::str>(
            PyUnicode_DecodeUTF8(r.data(), static_cast<Py_ssize_t>(r.size()), "backslashreplace"));
      });
  scene.attr("__hash__") = py::none();
}

}  // namespace mca::python
