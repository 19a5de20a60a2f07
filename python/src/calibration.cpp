// calibrate(experiment, progress=None, **options): the CLI's calibration, returning the
// fit (fit.json's content), the parameter set and the summary. Progress lines reach a
// Python callable (fraction or None, line) — the lines `burrbench calibrate` prints.
// Ctrl-C (KeyboardInterrupt) or an exception from that callable stops it within a moment.
#include <exception>
#include <filesystem>
#include <mutex>
#include <string>

#include <pybind11/functional.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "bindings.hpp"
#include "burrbench/calibration/calibrate.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "convert.hpp"
#include "interruptible.hpp"

namespace burrbench::python {
namespace fs = std::filesystem;

namespace {

// Calls the Python callable under the GIL; the first exception it raises stops the
// calibration (`cancel`) and is re-raised once it has stopped (C++ worker threads cannot
// carry it).
class PyProgress final : public Progress {
 public:
  PyProgress(py::function f, CancelToken& cancel) : f_(std::move(f)), cancel_(cancel) {}
  void update(double fraction, const std::string& line) override { call(fraction, line); }
  void finish(const std::string& summary_line) override { call(1.0, summary_line); }
  void rethrow() {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void call(double fraction, const std::string& line) {
    std::lock_guard lk(mu_);
    if (error_) return;
    py::gil_scoped_acquire gil;
    try {
      // A negative fraction means "not known" in the C++ interface: None for Python.
      f_(fraction >= 0 ? py::object(py::float_(fraction)) : py::object(py::none()), line);
    } catch (py::error_already_set&) {
      error_ = std::current_exception();
      cancel_.request();
    }
  }
  py::function f_;
  CancelToken& cancel_;
  std::mutex mu_;
  std::exception_ptr error_;
};

void set_option(calibration::CalibrateOptions& o, const std::string& k, const py::handle& v) {
  if (k == "threads") o.threads = v.cast<int>();
  else if (k == "max_iterations") o.max_iterations = v.cast<int>();
  else if (k == "starts") o.starts = v.cast<int>();
  else if (k == "solve_starts") o.solve_starts = v.cast<int>();
  else if (k == "start_iterations") o.start_iterations = v.cast<int>();
  else if (k == "profiles") o.profiles = v.cast<bool>();
  else if (k == "profile_points") o.profile_points = v.cast<int>();
  else if (k == "noise_inflation") o.noise_inflation = v.cast<bool>();
  else if (k == "discretization_check") o.discretization_check = v.cast<bool>();
  else if (k == "coarse_to_fine") o.coarse_to_fine = v.cast<bool>();
  else if (k == "cross_validate") o.cross_validate = v.cast<bool>();
  else if (k == "bootstrap") o.bootstrap = v.cast<int>();
  else if (k == "bootstrap_block_s") o.bootstrap_block_s = v.cast<double>();
  else if (k == "derivatives") {
    const std::string d = v.cast<std::string>();
    if (d != "sensitivities" && d != "fd") throw InputError("calibrate", "derivatives", "\"sensitivities\" or \"fd\"", d);
    o.derivatives = d == "fd" ? calibration::Derivatives::kFiniteDifferences : calibration::Derivatives::kSensitivities;
  } else
    throw InputError("calibrate", k,
                     "an option of: threads, max_iterations, starts, solve_starts, start_iterations, profiles, "
                     "profile_points, noise_inflation, discretization_check, coarse_to_fine, cross_validate, "
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
        calibration::validate(o);
        CancelToken cancel;
        o.cancel = &cancel;
        std::unique_ptr<PyProgress> pp;
        if (!progress.is_none()) {
          pp = std::make_unique<PyProgress>(progress.cast<py::function>(), cancel);
          o.progress = pp.get();
        }
        calibration::CalibrationOutput res;
        try {
          run_interruptible(cancel, [&] { res = calibration::calibrate(experiment, o); });
        } catch (const Cancelled&) {
          if (pp) pp->rethrow();  // the callback's exception stopped it
          throw;
        }
        if (pp) pp->rethrow();
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
      "line) receives the progress lines.");
}

}  // namespace burrbench::python
