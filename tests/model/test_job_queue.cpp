// model::run_job_queue: the workers of predict_experiment and verify_convergence.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <numeric>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "burrbench/model/job_queue.hpp"

using burrbench::model::run_job_queue;

namespace {
std::vector<std::size_t> iota(std::size_t n) {
  std::vector<std::size_t> v(n);
  std::iota(v.begin(), v.end(), 0);
  return v;
}
void nap() { std::this_thread::sleep_for(std::chrono::milliseconds(5)); }
}  // namespace

TEST(JobQueue, EveryJobRunsOnceOnAtMostTheAskedWorkersInQueueOrder) {
  for (int threads : {1, 2, 3, 8}) {
    const std::vector<std::size_t> queue{4, 0, 3, 1, 2};
    std::vector<int> runs(5, 0);
    std::vector<std::size_t> started;
    std::mutex mu;
    std::atomic<int> running{0}, peak{0};
    std::vector<std::size_t> workers;
    run_job_queue(5, queue, threads, [&](std::size_t w, std::size_t i) {
      const int now = ++running;
      for (int p = peak; now > p && !peak.compare_exchange_weak(p, now);) {
      }
      {
        const std::lock_guard<std::mutex> lock(mu);
        ++runs[i];
        started.push_back(i);
        workers.push_back(w);
      }
      nap();
      --running;
    });
    EXPECT_EQ(runs, std::vector<int>(5, 1)) << threads << " threads";
    EXPECT_LE(peak.load(), std::min(threads, 5));
    for (std::size_t w : workers) EXPECT_LT(w, std::size_t(std::min(threads, 5)));
    // (With more workers the jobs are taken in order too, but may record their start in
    // another: nothing to assert there.)
    if (threads == 1) {
      EXPECT_EQ(started, queue) << "one worker takes the queue in order";
    }
  }
}

TEST(JobQueue, AtMostOneExclusiveJobAtATime) {
  std::atomic<int> exclusive_running{0}, exclusive_peak{0}, running{0}, peak{0};
  const auto is_exclusive = [](std::size_t i) { return i % 3 == 0; };  // 0, 3, 6, 9
  std::vector<std::size_t> queue{0, 3, 6, 9, 1, 2, 4, 5, 7, 8};        // exclusive ones first
  run_job_queue(
      10, queue, 3,
      [&](std::size_t, std::size_t i) {
        const int now = ++running;
        for (int p = peak; now > p && !peak.compare_exchange_weak(p, now);) {
        }
        if (is_exclusive(i)) {
          const int e = ++exclusive_running;
          for (int p = exclusive_peak; e > p && !exclusive_peak.compare_exchange_weak(p, e);) {
          }
        }
        nap();
        if (is_exclusive(i)) --exclusive_running;
        --running;
      },
      is_exclusive);
  EXPECT_EQ(exclusive_peak.load(), 1);
  EXPECT_GE(peak.load(), 2) << "the other workers take the plain jobs beside the exclusive one";
}

// The error reported is the one of the lowest failing index, whatever the number of
// workers and the order they take the jobs in; jobs after it in index order do not start.
TEST(JobQueue, TheLowestFailingIndexIsReportedAsOneThreadWouldMeetIt) {
  for (int threads : {1, 2, 4}) {
    std::vector<std::size_t> queue = iota(12);
    std::reverse(queue.begin(), queue.end());  // the failing 9 is taken before the failing 5
    std::vector<std::atomic<int>> ran(12);
    try {
      run_job_queue(12, queue, threads, [&](std::size_t, std::size_t i) {
        ++ran[i];
        nap();
        if (i == 5 || i == 9) throw std::runtime_error("job " + std::to_string(i));
      });
      ADD_FAILURE() << "no error with " << threads << " threads";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "job 5") << threads << " threads";
    }
    for (std::size_t i = 0; i <= 5; ++i) EXPECT_EQ(ran[i].load(), 1) << "job " << i << " must run";
    if (threads == 1) {  // reversed queue: 11 … 9 ran before 9 failed; 8 … 6 still run (below 9)
      for (std::size_t i = 6; i < 12; ++i) EXPECT_EQ(ran[i].load(), 1) << i;
    }
  }
  // One worker in index order stops at the first failure: nothing after it starts.
  std::vector<int> ran(6, 0);
  EXPECT_THROW(run_job_queue(6, iota(6), 1,
                             [&](std::size_t, std::size_t i) {
                               ++ran[i];
                               if (i == 2) throw std::runtime_error("x");
                             }),
               std::runtime_error);
  EXPECT_EQ(ran, (std::vector<int>{1, 1, 1, 0, 0, 0}));
}

TEST(JobQueue, NoJobsNoWork) {
  int calls = 0;
  run_job_queue(0, {}, 4, [&](std::size_t, std::size_t) { ++calls; });
  EXPECT_EQ(calls, 0);
}
