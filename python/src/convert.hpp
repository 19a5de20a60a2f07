#pragma once
// Conversions between the C++ types and Python objects shared by the binding files.
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/parameter_set.hpp"

namespace burrbench::python {
namespace py = pybind11;

// n×3 float64 array of vectors (a copy).
inline py::array_t<double> vec3_array(const std::vector<glm::dvec3>& v) {
  py::array_t<double> a({py::ssize_t(v.size()), py::ssize_t(3)});
  auto r = a.mutable_unchecked<2>();
  for (std::size_t i = 0; i < v.size(); ++i)
    for (int k = 0; k < 3; ++k) r(py::ssize_t(i), k) = v[i][k];
  return a;
}

template <class T>
py::array_t<T> array(const std::vector<T>& v) {
  py::array_t<T> a(py::ssize_t(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

// Three finite numbers (a list, tuple or numpy array of ints or floats); InputError naming
// the call and the argument otherwise: numpy would turn ["1", "2", "3"] into numbers.
inline glm::dvec3 to_vec3(const py::object& o, const std::string& call, const char* what) {
  const std::string got = py::str(py::repr(o)).cast<std::string>();
  py::array raw;
  try {
    raw = py::module_::import("numpy").attr("asarray")(o);
  } catch (const py::error_already_set&) {  // ragged lists and the like
    throw InputError(call, what, "3 finite numbers", got);
  }
  const char kind = raw.dtype().kind();
  if (raw.size() == 3 && (kind == 'i' || kind == 'u' || kind == 'f')) {
    const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(raw);
    const glm::dvec3 v{a.data()[0], a.data()[1], a.data()[2]};
    if (std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z)) return v;
  }
  throw InputError(call, what, "3 finite numbers", got);
}

// A JSON document as Python objects (via the json module: dicts, lists, str, float).
inline py::object json_to_python(const nlohmann::json& j) {
  return py::module_::import("json").attr("loads")(j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace));
}

// A parameter set from a params.toml path or from a dict shaped like its [classes]
// table: {"compact": {"id": 1, "alpha_N_per_mm2": ..., "c1_N_per_mm2": ..., "mu": ...}}.
data_schema::ParameterSet to_parameter_set(const py::object& o);
// The parameter set as that dict (plus "not_identifiable" lists where the fit set them).
py::dict parameter_set_dict(const data_schema::ParameterSet& p);

}  // namespace burrbench::python
