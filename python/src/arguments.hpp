#pragma once
// Arguments from Python, checked by type: pybind11's own casts say only "Unable to cast
// Python instance to C++ type", and convert silently ("5" to 5.0, 2.5 to 2, "no" to True).
// Each helper takes the value as given or throws InputError naming the call and the
// argument: "calibrate(): starts: expected an integer, got 2.5 (float)".
#include <string>

#include <pybind11/pybind11.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::python {
namespace py = pybind11;

// The value as a message shows it: its repr and its type, "'2' (str)".
inline std::string shown(const py::handle& v) {
  return py::str(py::repr(v)).cast<std::string>() + " (" + py::str(v.get_type().attr("__name__")).cast<std::string>() + ")";
}

inline bool is_bool(const py::handle& v) {  // bool, or a numpy bool
  return py::isinstance<py::bool_>(v) ||
         (py::hasattr(v, "dtype") && py::str(v.attr("dtype").attr("kind")).cast<std::string>() == "b");
}

// int and numpy integers (they have __index__); not bool, not float.
inline int as_int(const std::string& call, const std::string& k, const py::handle& v) {
  if (!is_bool(v) && !py::isinstance<py::float_>(v) && py::hasattr(v, "__index__")) {
    const py::int_ i(py::reinterpret_borrow<py::object>(v.attr("__index__")()));
    try {
      return i.cast<int>();
    } catch (const py::cast_error&) {
    }
  }
  throw InputError(call, k, "an integer", shown(v));
}

// True or False (numpy bools too); not 0/1, not "no" (truthy in Python).
inline bool as_bool(const std::string& call, const std::string& k, const py::handle& v) {
  if (!is_bool(v)) throw InputError(call, k, "True or False", shown(v));
  return PyObject_IsTrue(v.ptr()) == 1;
}

// A real number (int, float, numpy scalars); not bool, not a numeric string.
inline double as_float(const std::string& call, const std::string& k, const py::handle& v) {
  if (is_bool(v) || !(py::isinstance<py::float_>(v) || py::hasattr(v, "__float__")) || py::isinstance<py::str>(v))
    throw InputError(call, k, "a number", shown(v));
  return v.cast<double>();
}

}  // namespace burrbench::python
