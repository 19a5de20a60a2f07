// validate(kind, path): the C++ reader of each format checks a file (InputError on any
// defect); the Python package then reads the checked file (burrbench/readers.py).
#include <cmath>
#include <filesystem>
#include <string>

#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.hpp"
#include "burrbench/analysis/criteria.hpp"
#include "burrbench/analysis/inspect.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/data_schema/sensor_loads.hpp"
#include "convert.hpp"

namespace burrbench::python {
namespace fs = std::filesystem;

void bind_files(py::module_& m) {
  m.def(
      "validate",
      [](const std::string& kind, const fs::path& path) {
        py::gil_scoped_release nogil;
        if (kind == "recording") (void)data_schema::read_recording(path);
        else if (kind == "sample") (void)data_schema::read_sample(path);
        else if (kind == "prediction") (void)data_schema::read_prediction(path);
        else if (kind == "fit") (void)data_schema::read_fit(path);
        else if (kind == "params") (void)data_schema::read_params(path);
        else if (kind == "experiment") (void)data_schema::read_manifest(path);
        else if (kind == "criteria") (void)analysis::read_criteria(path);
        else if (kind == "metrics") (void)analysis::describe_file(path, "burrbench.metrics");
        else if (kind == "sensor_loads") (void)data_schema::read_sensor_loads(path);
        else
          throw InputError("validate", "kind",
                           "recording, sample, prediction, fit, params, experiment, criteria, metrics or sensor_loads",
                           kind);
      },
      py::arg("kind"), py::arg("path"),
      "Checks a burrbench file with the C++ reader of its format; raises InputError (file, field, "
      "expectation) on any defect.");
  m.def(
      "prediction_units",
      [] {
        py::dict d;
        for (const auto& [name, unit] : data_schema::prediction_units()) d[py::str(name)] = unit;
        return d;
      },
      "The prediction format's unit of every per-recording dataset and numeric attribute, by name.");
}

data_schema::ParameterSet to_parameter_set(const py::object& o) {
  if (py::isinstance<py::str>(o) || py::hasattr(o, "__fspath__"))
    return data_schema::read_params(py::str(py::module_::import("os").attr("fspath")(o)).cast<std::string>());
  if (!py::isinstance<py::dict>(o))
    throw InputError("params (Python)", "params", "a params.toml path or a dict {class: {id, alpha_N_per_mm2, c1_N_per_mm2, mu}}");
  data_schema::ParameterSet p;
  for (const auto& [k, v] : o.cast<py::dict>()) {
    const std::string name = py::str(k);
    if (!py::isinstance<py::dict>(v)) throw InputError("params (Python)", name, "a dict {id, alpha_N_per_mm2, c1_N_per_mm2, mu}");
    const auto d = v.cast<py::dict>();
    auto num = [&](const char* key) {
      if (!d.contains(key)) throw InputError("params (Python)", name + "." + key, "a number", "missing");
      return d[key].cast<double>();
    };
    const double id = num("id");
    if (!(id >= 1 && id <= 255 && id == std::floor(id))) throw InputError("params (Python)", name + ".id", "an integer label 1..255");
    data_schema::ClassParams c;
    c.name = name;
    c.alpha_N_per_mm2 = num("alpha_N_per_mm2");
    c.c1_N_per_mm2 = num("c1_N_per_mm2");
    c.mu = num("mu");
    p.classes[std::uint8_t(id)] = c;
  }
  data_schema::validate(p, "params (Python)");
  return p;
}

py::dict parameter_set_dict(const data_schema::ParameterSet& p) {
  py::dict out;
  for (const auto& [label, c] : p.classes) {
    py::dict d;
    d["id"] = int(label);
    d["alpha_N_per_mm2"] = c.alpha_N_per_mm2;
    d["c1_N_per_mm2"] = c.c1_N_per_mm2;
    d["mu"] = c.mu;
    if (auto it = p.not_identifiable.find(label); it != p.not_identifiable.end()) d["not_identifiable"] = it->second;
    out[py::str(c.name)] = d;
  }
  return out;
}

}  // namespace burrbench::python
