#pragma once
// A running acquisition: one poller thread per TCP device or per RS-485 bus, and one
// writer thread that appends to the journal and fsyncs it at least every 50 ms.
#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "burrbench/rig/journal.hpp"
#include "burrbench/rig/register_map.hpp"

namespace burrbench::rig {

struct DeviceStatus {
  std::string name;
  double rate_hz = 0;              // requested polls per second
  std::uint64_t polls = 0, samples = 0, timeouts = 0, errors = 0, reconnects = 0;
  std::uint64_t missed_polls = 0;  // deadlines skipped (overrun or disconnected)
  std::uint64_t lost = 0;          // FIFO records lost to an overrun (fifo mode only)
  std::uint64_t overruns = 0;      // the overruns (gap events) those were lost in
  bool fifo = false;               // latest mode has no "lost": its gaps are events
  std::uint64_t invalid = 0;       // samples with a NaN/out-of-range value
  double jitter_p99_us = 0;        // |interval - period| of consecutive polls
  double jitter_max_us = 0;
  double achieved_hz = 0;          // successful polls / elapsed
  // Latest mode with a counter: seconds since its counter last advanced, at the last good
  // poll (0 while it advances); ≥ kFrozenAfterS: the device has stopped measuring.
  double frozen_s = 0;
  std::vector<double> last;        // last decoded values of the first channel
  std::string first_channel;
};

struct SessionStatus {
  double elapsed_s = 0;
  std::vector<DeviceStatus> devices;
  std::uint64_t journal_blocks = 0;
  // Acquisition threads (pollers and the journal writer) and how many of them the system
  // refused SCHED_FIFO (with its reason); also `realtime` events in the recording.
  int threads = 0, realtime_denied = 0;
  std::string realtime_reason;
};

class Session {
 public:
  // Creates the journal (header_json = session metadata) and starts every thread.
  Session(RigMap map, const std::filesystem::path& journal, const std::string& header_json);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;

  SessionStatus status() const;
  // A fatal journal error (write/fsync) — acquisition has stopped; never retried.
  std::optional<std::string> fatal() const;
  // Stops the pollers, writes what is queued, marks the journal finished.
  void stop();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace burrbench::rig
