// The Python module `mca`: its C++ half, imported by python/mca/__init__.py as mca._mca.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "mca/error.hpp"
#include "bindings.hpp"

PYBIND11_MODULE(_mca, m) {
  m.doc() = "mca: fracture of heterogeneous materials with movable cellular automata (the C++ half of the "
            "Python module; import mca)";
  // Every mca::Error (a bad scene, a bad checkpoint, an unstable run) arrives as mca.Error with the message
  // the command prints: the file, the key, the bad value and the fix.
  // A message that names a file whose name is not UTF-8 holds its bytes as \xNN (decoded strictly it came
  // back empty).
  static pybind11::exception<mca::Error> error(m, "Error");
  pybind11::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const mca::Error& e) {
      const std::string what = e.what();
      const pybind11::object message = pybind11::reinterpret_steal<pybind11::object>(
          PyUnicode_DecodeUTF8(what.data(), static_cast<Py_ssize_t>(what.size()), "backslashreplace"));
      PyErr_SetObject(error.ptr(), message.ptr());
    }
  });
  // numpy's C API is set up here, while the import holds the GIL and no other thread can be in the module:
  // pybind11 sets it up at the first array, under a static's guard, and two threads reading their first
  // arrays at once deadlocked (one in the guard waiting for the GIL, the other holding it waiting for the
  // guard). Without numpy the module imports, and the arrays' functions say what is missing.
  try {
    pybind11::module_::import("numpy");
    (void)pybind11::dtype::of<double>();
  } catch (pybind11::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
  }
  mca::python::bind_scene(m);
  mca::python::bind_simulation(m);
}
