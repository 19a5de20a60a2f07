#pragma once
// Cooperative cancellation of long work (replay, calibrate) run inside a process that
// must live on: the Python module stops a calibration when the user interrupts (Ctrl-C,
// a notebook's stop button) or its progress callback raises. The CLI needs none: a signal
// ends the process (atomic_file.hpp removes its temporaries).
//
// The work polls the token at points where stopping is cheap (every few replay samples,
// between stages) and throws Cancelled, which unwinds like any error: a replay rolls its
// volume back, nothing is written.
#include <atomic>
#include <stdexcept>

namespace burrbench {

class Cancelled final : public std::runtime_error {
 public:
  Cancelled() : std::runtime_error("cancelled") {}
};

class CancelToken {
 public:
  void request() { requested_.store(true, std::memory_order_relaxed); }
  bool requested() const { return requested_.load(std::memory_order_relaxed); }
  void check() const {
    if (requested()) throw Cancelled();
  }

 private:
  std::atomic<bool> requested_{false};
};

}  // namespace burrbench
