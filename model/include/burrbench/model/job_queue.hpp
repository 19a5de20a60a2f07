#pragma once
// Independent jobs on a few worker threads, reporting a failure as one thread would.
// Used by predict_experiment (one job per recording), verify_convergence (one per
// recording and level) and the calibration's multistart (one per start) and profiles (one
// per parameter).
#include <algorithm>
#include <condition_variable>
#include <cstdint>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::model {

// Runs job(worker, i) for every i in `queue` (indices below `count`, taken in queue order)
// on min(threads, queue size) workers; worker 0 is the calling thread. At most one job with
// exclusive(i) runs at a time (null: none is). A job that throws does not stop the others,
// but after it only jobs with a lower index still start; once all have ended, the lowest
// failing index's exception is rethrown — the error one thread going through 0, 1, … would
// have met first, whatever the order and number of workers.
inline void run_job_queue(std::size_t count, const std::vector<std::size_t>& queue, int threads,
                          const std::function<void(std::size_t worker, std::size_t i)>& job,
                          const std::function<bool(std::size_t i)>& exclusive = nullptr) {
  for (const std::size_t i : queue) BURRBENCH_CHECK(i < count, "run_job_queue: a job index beyond count");
  std::mutex mu;
  std::condition_variable cv;
  std::vector<std::uint8_t> taken(queue.size(), 0);
  std::vector<std::exception_ptr> errors(count);
  std::size_t first_failed = count;
  bool exclusive_busy = false;
  auto work = [&](std::size_t w) {
    std::unique_lock<std::mutex> lock(mu);
    for (;;) {
      std::size_t q = queue.size(), left = 0;
      for (std::size_t j = 0; j < queue.size(); ++j) {
        if (taken[j]) continue;
        if (queue[j] > first_failed) {  // after the first failure: would not have run
          taken[j] = 1;
          continue;
        }
        ++left;
        if (exclusive_busy && exclusive && exclusive(queue[j])) continue;
        q = j;
        break;
      }
      if (left == 0) return;
      if (q == queue.size()) {  // only exclusive jobs left, and one is running
        cv.wait(lock);
        continue;
      }
      taken[q] = 1;
      const std::size_t i = queue[q];
      const bool ex = exclusive && exclusive(i);
      exclusive_busy |= ex;
      lock.unlock();
      std::exception_ptr error;
      try {
        job(w, i);
      } catch (...) {
        error = std::current_exception();
      }
      lock.lock();
      if (error) {
        errors[i] = error;
        first_failed = std::min(first_failed, i);
      }
      if (ex) exclusive_busy = false;
      cv.notify_all();
    }
  };
  const std::size_t workers = std::max<std::size_t>(
      1, std::min<std::size_t>(std::size_t(std::max(threads, 1)), queue.size()));
  std::vector<std::thread> pool;
  for (std::size_t w = 1; w < workers; ++w) pool.emplace_back(work, w);
  work(0);
  for (auto& t : pool) t.join();
  if (first_failed < count) std::rethrow_exception(errors[first_failed]);
}

}  // namespace burrbench::model
