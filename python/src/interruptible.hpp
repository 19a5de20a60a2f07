#pragma once
// Long work (a calibration, a replay) that Ctrl-C, a notebook's interrupt or the
// caller's progress callback can stop.
// Python runs its signal handlers only on the main thread, and only while that thread runs
// Python: a call that spends minutes in C++ would sit out a KeyboardInterrupt until its
// end. So the work runs on a thread of its own, without the GIL, while the calling thread
// wakes every 50 ms to run the handlers; a handler that raises cancels the work, and its
// exception is raised once the work has stopped (within 64 replay samples).
#include <chrono>
#include <condition_variable>
#include <exception>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include <pybind11/pybind11.h>

#include "arguments.hpp"
#include "burrbench/data_schema/cancel.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/progress.hpp"

namespace burrbench::python {

// Calls work() and returns when it has ended. Rethrows the work's exception, or the
// handlers' (KeyboardInterrupt) if they raised: then `token` was requested, and the
// work's own Cancelled is dropped. Called with the GIL held.
template <class Work>
void run_interruptible(CancelToken& token, Work&& work) {
  namespace py = pybind11;
  std::exception_ptr error;
  std::optional<py::error_already_set> interrupt;  // fetched and released under the GIL
  {
    py::gil_scoped_release nogil;
    std::mutex mu;
    std::condition_variable cv;
    bool done = false;
    std::thread worker([&] {
      try {
        work();
      } catch (...) {
        error = std::current_exception();
      }
      std::lock_guard lk(mu);
      done = true;
      cv.notify_all();
    });
    std::unique_lock lk(mu);
    while (!cv.wait_for(lk, std::chrono::milliseconds(50), [&] { return done; })) {
      if (interrupt) continue;
      lk.unlock();
      {
        py::gil_scoped_acquire gil;
        if (PyErr_CheckSignals() != 0) {
          interrupt.emplace();  // takes the raised exception out of the interpreter
          token.request();
        }
      }
      lk.lock();
    }
    lk.unlock();
    worker.join();
  }
  if (interrupt) throw *interrupt;
  if (error) std::rethrow_exception(error);
}

// Progress lines to a Python callable progress(fraction or None, line), called under the
// GIL. The first exception it raises cancels the work (`cancel`) and is raised once the
// work has stopped: C++ worker threads cannot carry it.
class PyProgress final : public Progress {
 public:
  PyProgress(pybind11::function f, CancelToken& cancel) : f_(std::move(f)), cancel_(cancel) {}
  // None gives none; anything else must be callable (InputError naming `call`).
  static std::unique_ptr<PyProgress> from(const std::string& call, const pybind11::object& progress,
                                          CancelToken& cancel) {
    if (progress.is_none()) return nullptr;
    if (!PyCallable_Check(progress.ptr()))
      throw InputError(call, "progress", "a callable progress(fraction, line), or None", shown(progress));
    return std::make_unique<PyProgress>(progress.cast<pybind11::function>(), cancel);
  }
  void update(double fraction, const std::string& line) override { call(fraction, line); }
  void stage_at(double fraction, const std::string& name, const std::string& detail) override {
    call(fraction, stage_line(name, detail));
  }
  void finish(const std::string& summary_line) override { call(1.0, summary_line); }
  void rethrow() {
    if (error_) std::rethrow_exception(error_);
  }

 private:
  void call(double fraction, const std::string& line) {
    namespace py = pybind11;
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
  pybind11::function f_;
  CancelToken& cancel_;
  std::mutex mu_;
  std::exception_ptr error_;
};

// As above, with the progress callback's exception (if it raised one) raised in place of
// the work's Cancelled or result.
template <class Work>
void run_interruptible(CancelToken& token, PyProgress* progress, Work&& work) {
  try {
    run_interruptible(token, std::forward<Work>(work));
  } catch (const Cancelled&) {
    if (progress) progress->rethrow();
    throw;
  }
  if (progress) progress->rethrow();
}

}  // namespace burrbench::python
