// The Python module `mca`: its C++ half, imported by python/mca/__init__.py as mca._mca.
#include <pybind11/pybind11.h>

#include "mca/error.hpp"
#include "bindings.hpp"

PYBIND11_MODULE(_mca, m) {
  m.doc() = "mca: fracture of heterogeneous materials with movable cellular automata (the C++ half of the "
            "Python module; import mca)";
  // Every mca::Error (a bad scene, a bad checkpoint, an unstable run) arrives as mca.Error with the message
  // the command prints: the file, the key, the bad value and the fix.
  pybind11::register_exception<mca::Error>(m, "Error");
  mca::python::bind_scene(m);
  mca::python::bind_simulation(m);
}
