// calibrate(experiment, progress=None, **options): the CLI's calibration, returning the
// fit (fit.json's content), the parameter set and the summary. Progress lines reach a
// Python callable (the whole run's fraction done, line) — the lines `burrbench calibrate` prints.
// Ctrl-C (KeyboardInterrupt) or an exception from that callable stops it within a moment.
#include <algorithm>
#include <filesystem>
#include <string>

#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.hpp"
#include "burrbench/calibration/calibrate.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "arguments.hpp"
#include "convert.hpp"
#include "interruptible.hpp"
#include "overlap_warnings.hpp"

namespace burrbench::python {
namespace fs = std::filesystem;

namespace {

constexpr const char* kCall = "calibrate()";

void set_option(calibration::CalibrateOptions& o, const std::string& k, const py::handle& v) {
  if (k == "threads") o.threads = as_int(kCall, k, v);
  else if (k == "max_iterations") o.max_iterations = as_int(kCall, k, v);
  else if (k == "starts") o.starts = as_int(kCall, k, v);
  else if (k == "solve_starts") o.solve_starts = as_int(kCall, k, v);
  else if (k == "start_iterations") o.start_iterations = as_int(kCall, k, v);
  else if (k == "profiles") o.profiles = as_bool(kCall, k, v);
  else if (k == "profile_points") o.profile_points = as_int(kCall, k, v);
  else if (k == "noise_inflation") o.noise_inflation = as_bool(kCall, k, v);
  else if (k == "discretization_check") o.discretization_check = as_bool(kCall, k, v);
  else if (k == "depth_check") o.depth_check = as_bool(kCall, k, v);
  else if (k == "coarse_to_fine") o.coarse_to_fine = as_bool(kCall, k, v);
  else if (k == "cross_validate") o.cross_validate = as_bool(kCall, k, v);
  else if (k == "bootstrap") o.bootstrap = as_int(kCall, k, v);
  else if (k == "bootstrap_block_s") o.bootstrap_block_s = as_float(kCall, k, v);
  else if (k == "derivatives") {
    if (!py::isinstance<py::str>(v)) throw InputError(kCall, k, "\"sensitivities\" or \"fd\"", shown(v));
    const std::string d = v.cast<std::string>();
    if (d != "sensitivities" && d != "fd") throw InputError(kCall, "derivatives", "\"sensitivities\" or \"fd\"", d);
    o.derivatives = d == "fd" ? calibration::Derivatives::kFiniteDifferences : calibration::Derivatives::kSensitivities;
  } else
    throw InputError(kCall, k,
                     "an option of: threads, max_iterations, starts, solve_starts, start_iterations, profiles, "
                     "profile_points, noise_inflation, discretization_check, depth_check, coarse_to_fine, cross_validate, "
                     "bootstrap, bootstrap_block_s, derivatives",
                     "unknown");
}

}  // namespace

void bind_calibration(py::module_& m) {
  m.def(
      "calibrate",
      [](const fs::path& experiment, const py::object& progress, const py::kwargs& options) {
        calibration::CalibrateOptions o;
        for (const auto& [k, v] : options) set_option(o, py::str(k), v);
        try {
          calibration::validate(o);
        } catch (const InputError& e) {  // it names the CLI's option: "--max-iterations"
          std::string name = e.field().rfind("--", 0) == 0 ? e.field().substr(2) : e.field();
          std::replace(name.begin(), name.end(), '-', '_');
          throw InputError(kCall, name, e.expected(), e.got());
        }
        CancelToken cancel;
        o.cancel = &cancel;
        const auto pp = PyProgress::from(kCall, progress, cancel);
        o.progress = pp.get();
        calibration::CalibrationOutput res;
        run_interruptible(cancel, pp.get(), [&] { res = calibration::calibrate(experiment, o); });
        // Every line the CLI's summary prints as "warning:" (fit.json's warnings: the data's,
        // such as two recordings that removed the same bone, and the fit's own).
        for (const auto& w : res.fit.settings.value("warnings", nlohmann::json::array())) warn(w.get<std::string>());
        py::dict out;
        out["fit"] = json_to_python(data_schema::fit_to_json(res.fit));
        out["params"] = parameter_set_dict(res.params);
        out["summary"] = res.summary;
        return out;
      },
      py::arg("experiment"), py::arg("progress") = py::none(),
      "Calibrates alpha, C1 and mu per bone class on an experiment manifest, as `burrbench calibrate`: "
      "{fit: fit.json's content, params: {class: {...}}, summary: str}. Options as keywords (threads, "
      "starts, profiles, cross_validate, discretization_check, derivatives, ...); progress(fraction, "
      "line) receives the progress lines with the whole run's fraction done (0..1, 1.0 on the last). Each of fit.json's warnings (two recordings of one sample that "
      "removed the same bone, a lag at its bound, ...) gives a UserWarning, the line the CLI prints.");
}

}  // namespace burrbench::python
