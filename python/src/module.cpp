// The extension `burrbench._burrbench`: file validation, the model (volume, contact,
// replay) and the calibration, for the Python package around it (python/burrbench).
// Long C++ work runs without the GIL; InputError becomes burrbench.InputError with the
// CLI's one-line message (file, field, expectation).
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/version.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_burrbench, m) {
  m.doc() = "burrbench: the voxel burr-bone drilling model, its replay and calibration (docs/python.md)";
  static py::exception<burrbench::InputError> input_error(m, "InputError", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const burrbench::InputError& e) {
      // The same line the CLI prints after "burrbench: ".
      input_error(e.what());
    }
  });
  m.attr("__version__") = burrbench::software_version();
  burrbench::python::bind_files(m);
  burrbench::python::bind_model(m);
  burrbench::python::bind_calibration(m);
}
