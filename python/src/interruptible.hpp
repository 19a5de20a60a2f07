#pragma once
// Long work (a calibration, a replay) that Ctrl-C or a notebook's interrupt can stop.
// Python runs its signal handlers only on the main thread, and only while that thread runs
// Python: a call that spends minutes in C++ would sit out a KeyboardInterrupt until its
// end. So the work runs on a thread of its own, without the GIL, while the calling thread
// wakes every 50 ms to run the handlers; a handler that raises cancels the work, and its
// exception is raised once the work has stopped (within 64 replay samples).
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <optional>
#include <thread>

#include <pybind11/pybind11.h>

#include "burrbench/data_schema/cancel.hpp"

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

}  // namespace burrbench::python
