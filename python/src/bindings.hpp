#pragma once
// The Python module `mca` (python/CMakeLists.txt): shared declarations of its binding files.
//
// A scene as Python holds it: the leaf definitions (Material, Region, Projectile, Grip, Load, Ground,
// Solver, Output, Camera, Heterogeneity) are the C++ structs of include/mca/scene.hpp, each owned by its
// Python object; the lists (scene.objects, object.regions, ...) are plain Python lists of them. A SceneDef
// is assembled from them when it is needed (validate, to_toml, Simulation), so a Python reference to an
// element never points into a C++ vector that may move.
#include <pybind11/pybind11.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "mca/scene.hpp"

namespace mca::python {

namespace py = pybind11;

// An [[object]]: its keys, its regions (a list of Region) and its heterogeneity (None: the scene's).
struct PyObjectDef {
  ObjectDef def;
  py::list regions;
  py::object heterogeneity = py::none();
  // `key` names the object in messages ("scene.objects[2]").
  ObjectDef to_def(const std::string& key) const;
  static PyObjectDef from_def(const ObjectDef& def);
};

struct PyScene {
  std::string name = "scene";
  std::string source = "<python>";
  std::string read_as;  // the scene as read (its TOML), where it came from a file or text: to_def's source
                        // says where it has been changed since
  py::list materials, objects, projectiles, grips, loads;
  py::object heterogeneity, solver, output, ground, camera;
  PyScene();
  SceneDef to_def() const;
  static PyScene from_def(const SceneDef& def);
};

// Values given from Python for a key or an argument, checked as the three-number keys are: anything else
// raises mca.Error naming `key`, the value given and what to give (`what`, which says the range of a whole
// number). Numbers take int, float and
// numpy scalars (not bool, not text); whole numbers take int and numpy integers within [min, max] (not
// bool, not float); text takes str only; a bool takes True or False (and numpy.bool_), not 0, 1 or 2.
std::string shown(py::handle value);
double to_number(py::handle value, const std::string& key, const std::string& what);
std::int64_t to_whole(py::handle value, const std::string& key, std::int64_t min, std::int64_t max,
                      const std::string& what);
std::string to_text(py::handle value, const std::string& key, const std::string& what);
// A key whose value is one of a few words (shape, fill, ...): the value, or the reader's message (with a
// did-you-mean) for anything else.
std::string choice(const std::string& key, const std::string& value, const std::vector<std::string>& allowed,
                   const std::string& what);
// backend=: None (the scene's own) or auto, cpu, cuda, cuda-emulation.
std::optional<SolverDef::Backend> to_backend(py::handle value, const std::string& key);
bool to_bool(py::handle value, const std::string& key, const std::string& what);
// A path: a str or an os.PathLike naming a str path.
std::filesystem::path to_path(py::handle value, const std::string& key);

// An argument the binding converts itself (with to_path, to_whole, ...; pybind11 would refuse a wrong type
// with its own message, not mca's), shown by help() and in errors as `Shown::name`, the type the .pyi stubs
// give, instead of pybind11's "handle": Given<py_type::path> for a path.
template <typename Shown>
struct Given {
  py::handle value;
  operator py::handle() const { return value; }  // NOLINT(google-explicit-constructor): for to_path and the rest
};
namespace py_type {
#define MCA_SHOWN_TYPE(tag, text)                                      \
  struct tag {                                                        \
    static constexpr auto name = py::detail::const_name(text);        \
  }
MCA_SHOWN_TYPE(path, "Union[str, os.PathLike]");
MCA_SHOWN_TYPE(optional_path, "Optional[Union[str, os.PathLike]]");
MCA_SHOWN_TYPE(scene_or_path, "Union[Scene, str, os.PathLike]");
MCA_SHOWN_TYPE(integer, "int");
MCA_SHOWN_TYPE(number, "float");
MCA_SHOWN_TYPE(str, "str");
MCA_SHOWN_TYPE(boolean, "bool");
MCA_SHOWN_TYPE(optional_str, "Optional[str]");
MCA_SHOWN_TYPE(progress, "Optional[Callable[[int, int], Any]]");
MCA_SHOWN_TYPE(size, "Tuple[int, int]");
#undef MCA_SHOWN_TYPE
}  // namespace py_type

void bind_scene(py::module_& m);
void bind_simulation(py::module_& m);

}  // namespace mca::python

namespace pybind11::detail {
// Given<Shown> takes any object as it is (None too); its name is Shown::name.
template <typename Shown>
struct type_caster<mca::python::Given<Shown>> {
  PYBIND11_TYPE_CASTER(mca::python::Given<Shown>, Shown::name);
  bool load(handle src, bool) {
    value.value = src;
    return true;
  }
  static handle cast(const mca::python::Given<Shown>& g, return_value_policy, handle) { return g.value.inc_ref(); }
};
}  // namespace pybind11::detail
