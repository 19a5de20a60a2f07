// Host wakeup probe for bench/rig.sh: how late does this machine wake a real-time thread?
//
// One SCHED_FIFO thread per CPU (pinned) sleeps to absolute 1 ms deadlines on
// CLOCK_MONOTONIC — the pollers' own schedule — for SECONDS and prints every wakeup later
// than THRESHOLD_US as `late CPU DEADLINE_NS LATE_NS`, then `done CPU WAKEUPS WORST_NS`.
// On a virtual machine whose vCPUs the hypervisor deschedules, these stalls are outside
// anything acquisition code can do; rig.sh lines them up with the poll gaps it saw.
// Usage: bench_host_wakeup SECONDS [THRESHOLD_US=1000]
#include <pthread.h>
#include <sched.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "burrbench/rig/modbus_link.hpp"

namespace {

std::mutex out_mutex;

void probe(int cpu, double seconds, std::int64_t threshold_ns) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  pthread_setaffinity_np(pthread_self(), sizeof set, &set);
  sched_param sp{};
  sp.sched_priority = 20;  // the pollers' priority (rig/src/session.cpp)
  const bool rt = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp) == 0;
  constexpr std::int64_t period_ns = 1'000'000;
  const auto n = static_cast<std::int64_t>(seconds * 1000.0);
  std::int64_t next = burrbench::rig::monotonic_ns(), worst = 0;
  std::vector<std::pair<std::int64_t, std::int64_t>> late;  // printed at the end: no I/O while probing
  for (std::int64_t i = 0; i < n; ++i) {
    next += period_ns;
    const timespec ts{static_cast<time_t>(next / 1'000'000'000), static_cast<long>(next % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
    const auto l = burrbench::rig::monotonic_ns() - next;
    worst = std::max(worst, l);
    if (l > threshold_ns) late.emplace_back(next, l);
  }
  std::lock_guard lk(out_mutex);
  for (const auto& [t, l] : late) std::printf("late %d %lld %lld\n", cpu, static_cast<long long>(t), static_cast<long long>(l));
  std::printf("done %d %lld %lld %s\n", cpu, static_cast<long long>(n), static_cast<long long>(worst), rt ? "fifo" : "normal");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::atof(argv[1]) <= 0) {
    std::fprintf(stderr, "usage: bench_host_wakeup SECONDS [THRESHOLD_US=1000]\n");
    return 2;
  }
  const double seconds = std::atof(argv[1]);
  const auto threshold_ns = static_cast<std::int64_t>((argc > 2 ? std::atof(argv[2]) : 1000.0) * 1000.0);
  std::vector<std::thread> threads;
  const int cpus = static_cast<int>(std::thread::hardware_concurrency());
  for (int c = 0; c < cpus; ++c) threads.emplace_back(probe, c, seconds, threshold_ns);
  for (auto& t : threads) t.join();
  return 0;
}
