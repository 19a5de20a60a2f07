#pragma once
// The live view beside an acquisition in the same process (`acquire --watch`): run_watch on
// a thread of its own at a lower priority (nice +10; the pollers and the journal writer
// ask for SCHED_FIFO, above every normal thread anyway), reading the journal the session
// writes. The acquisition never waits for it: it only reads the journal file, and a
// failure of the watch after it started is printed, never thrown into the acquisition.
#include <exception>
#include <future>
#include <string>
#include <thread>

#include "burrbench/watch/session.hpp"

namespace burrbench::watch {

class BackgroundWatch {
 public:
  // Returns once the model is loaded and the page served (InputError for bad watch
  // inputs is thrown here, before the acquisition starts). `options.journal` must be set.
  explicit BackgroundWatch(WatchOptions options);
  ~BackgroundWatch();
  BackgroundWatch(const BackgroundWatch&) = delete;
  BackgroundWatch& operator=(const BackgroundWatch&) = delete;
  // After the session: waits up to `timeout_s` for the watch to replay the rest, then
  // stops it. The summary, or "" with the reason in `error` when it failed.
  WatchSummary finish(double timeout_s, std::string* error);

 private:
  WatchOptions options_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::promise<WatchSummary> done_;
  std::future<WatchSummary> result_;
};

}  // namespace burrbench::watch
