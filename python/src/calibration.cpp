// calibrate(experiment, progress=None, **options): the CLI's calibration, returning the
// fit (fit.json's content), the parameter set and the summary. Progress lines reach a
// Python callable (fraction or None, line) — the lines `burrbench calibrate` prints.
// Ctrl-C (KeyboardInterrupt) or an exception from that callable stops it within a moment.
#include <algorithm>
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

// An option's value, or InputError naming it: pybind11's own cast error says only "Unable
// to cast Python instance to C++ type". No silent conversions: 2.5 is not a count of
// starts, and "no" (truthy in Python) is not False.
std::string shown(const py::handle& v) {
  return py::str(py::repr(v)).cast<std::string>() + " (" + py::str(v.get_type().attr("__name__")).cast<std::string>() + ")";
}
bool is_bool(const py::handle& v) {  // bool, or a numpy bool
  return py::isinstance<py::bool_>(v) ||
         (py::hasattr(v, "dtype") && py::str(v.attr("dtype").attr("kind")).cast<std::string>() == "b");
}
int as_int(const std::string& k, const py::handle& v) {
  // int and numpy integers (they have __index__); not bool, not float.
  if (!is_bool(v) && !py::isinstance<py::float_>(v) && py::hasattr(v, "__index__")) {
    const py::int_ i(py::reinterpret_borrow<py::object>(v.attr("__index__")()));
    try {
      return i.cast<int>();
    } catch (const py::cast_error&) {
    }
  }
  throw InputError("calibrate()", k, "an integer", shown(v));
}
bool as_bool(const std::string& k, const py::handle& v) {
  if (!is_bool(v)) throw InputError("calibrate()", k, "True or False", shown(v));
  return PyObject_IsTrue(v.ptr()) == 1;
}
double as_float(const std::string& k, const py::handle& v) {
  if (is_bool(v) || !(py::isinstance<py::float_>(v) || py::hasattr(v, "__float__")) || py::isinstance<py::str>(v))
    throw InputError("calibrate()", k, "a number", shown(v));
  return v.cast<double>();
}

void set_option(calibration::CalibrateOptions& o, const std::string& k, const py::handle& v) {
  if (k == "threads") o.threads = as_int(k, v);
  else if (k == "max_iterations") o.max_iterations = as_int(k, v);
  else if (k == "starts") o.starts = as_int(k, v);
  else if (k == "solve_starts") o.solve_starts = as_int(k, v);
  else if (k == "start_iterations") o.start_iterations = as_int(k, v);
  else if (k == "profiles") o.profiles = as_bool(k, v);
  else if (k == "profile_points") o.profile_points = as_int(k, v);
  else if (k == "noise_inflation") o.noise_inflation = as_bool(k, v);
  else if (k == "discretization_check") o.discretization_check = as_bool(k, v);
  else if (k == "coarse_to_fine") o.coarse_to_fine = as_bool(k, v);
  else if (k == "cross_validate") o.cross_validate = as_bool(k, v);
  else if (k == "bootstrap") o.bootstrap = as_int(k, v);
  else if (k == "bootstrap_block_s") o.bootstrap_block_s = as_float(k, v);
  else if (k == "derivatives") {
    if (!py::isinstance<py::str>(v)) throw InputError("calibrate()", k, "\"sensitivities\" or \"fd\"", shown(v));
    const std::string d = v.cast<std::string>();
    if (d != "sensitivities" && d != "fd") throw InputError("calibrate()", "derivatives", "\"sensitivities\" or \"fd\"", d);
    o.derivatives = d == "fd" ? calibration::Derivatives::kFiniteDifferences : calibration::Derivatives::kSensitivities;
  } else
    throw InputError("calibrate()", k,
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
        try {
          calibration::validate(o);
        } catch (const InputError& e) {  // it names the CLI's option: "--max-iterations"
          std::string name = e.field().rfind("--", 0) == 0 ? e.field().substr(2) : e.field();
          std::replace(name.begin(), name.end(), '-', '_');
          throw InputError("calibrate()", name, e.expected(), e.got());
        }
        if (!progress.is_none() && !PyCallable_Check(progress.ptr()))
          throw InputError("calibrate()", "progress", "a callable progress(fraction, line), or None", shown(progress));
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
