// FIFO device time (docs/rig.md, "FIFO mode"): records polled in bursts get the device's
// own times back — counter × period pinned by the polls' send/receive bounds — and a map
// whose device_rate_hz does not match the device says so in the recording.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <random>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "burrbench/rig/finalise.hpp"
#include "burrbench/rig/journal.hpp"

using namespace burrbench::rig;
namespace fs = std::filesystem;

namespace {

std::string fifo_map(double device_rate_hz) {
  return fmt::format(R"(format = "burrbench.rig"
format_version = "1.0"
rig_id = "fifo-test"
[[devices]]
name = "ft_sensor"
transport = "tcp"
host = "127.0.0.1"
port = 5020
slave = 9
rate_hz = 400
mode = "fifo"
start = 300
count = 98
fifo = {{ counter = {{ register = 300, type = "uint32" }}, first_register = 302, depth = 8, record_registers = 12, device_rate_hz = {} }}
  [[devices.channels]]
  name = "force_N"
  unit = "N"
  type = "float32"
  registers = [0, 2, 4]
)", device_rate_hz);
}

constexpr std::int64_t kT0 = 5'000'000'000;  // device record 0, ns
constexpr std::int64_t kPeriod = 1'000'000;  // the device samples at 1 kHz

// A journal as the poller writes it: polls every 2.5 ms (jittered), the device sees each
// request 60–140 µs after it was sent and the reply arrives 120–280 µs after sending;
// each poll stores the records newer than the last one taken, all with that poll's times.
// On a loaded host (the second second of `loaded`), requests and replies are late by up
// to 1.5 ms and 3 ms more: delays only ever add, so they are one-sided.
fs::path simulated_journal(const std::string& name, double map_rate_hz, bool loaded = false) {
  const auto p = fs::temp_directory_path() / fmt::format("bb_fifo_{}_{}.journal", ::getpid(), name);
  fs::remove(p);
  SessionHeader h;
  h.rig_toml = fifo_map(map_rate_hz);
  h.session_monotonic_ns = kT0;
  JournalWriter w(p, to_json(h).dump());
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::int64_t> jitter(-300'000, 300'000), arrive(60'000, 140'000),
      reply(120'000, 280'000), late_request(0, 1'500'000), late_reply(0, 3'000'000);
  std::int64_t last = -1;
  for (std::int64_t send = kT0 + 3'000'000; send < kT0 + 2'000'000'000; send += 2'500'000 + jitter(rng)) {
    const bool busy = loaded && send > kT0 + 1'000'000'000;
    const std::int64_t late = busy ? late_request(rng) : 0;
    const std::int64_t newest = (send + late + arrive(rng) - kT0) / kPeriod;
    const std::int64_t recv = send + late + reply(rng) + (busy ? late_reply(rng) : 0);
    for (std::int64_t c = last < 0 ? newest : last + 1; c <= newest; ++c) {
      JournalSample s;
      s.t_send_ns = send;
      s.t_recv_ns = recv;
      s.counter = c;
      s.regs.assign(12, 0);
      w.append(s);
    }
    last = newest;
  }
  w.finish();
  return p;
}

std::vector<std::string> events_of(const burrbench::data_schema::Recording& r, const std::string& kind) {
  std::vector<std::string> out;
  for (const auto& e : r.events)
    if (e.kind == kind) out.push_back(e.detail);
  return out;
}

}  // namespace

TEST(FifoTime, RecordsGetTheDeviceTimes) {
  const auto p = simulated_journal("ok", 1000);
  FinaliseReport rep;
  const auto rec = recording_from_journal(read_journal(p), p.string(), &rep);
  const auto& s = rec.streams.at(0);
  ASSERT_GT(s.samples(), 1900u);
  double worst_ns = 0;
  for (std::size_t k = 0; k < s.samples(); ++k) {
    const double truth = double(kT0 + s.device_counter[k] * kPeriod);
    worst_ns = std::max(worst_ns, std::abs(double(s.t_ns[k]) - truth));
  }
  // Every record, not a median: the bounds pin the offset to within the request's trip.
  EXPECT_LT(worst_ns, 150'000) << "worst error " << worst_ns << " ns";
  EXPECT_TRUE(events_of(rec, "clock_fit").empty());
  fs::remove(p);
}

// A loaded host delays requests and replies, never hastens them. The polls' midpoints
// then drift late over the session and a least-squares slope through them tilts (the
// virtual rig under a busy neighbour: 1 ms off at the ends of 1.5 s); the bounds do not
// move, only widen, so the slope that leaves them the most room stays on the device's.
TEST(FifoTime, OneSidedDelaysDoNotTiltTheClock) {
  const auto p = simulated_journal("loaded", 1000, true);
  const auto rec = recording_from_journal(read_journal(p), p.string(), nullptr);
  const auto& s = rec.streams.at(0);
  ASSERT_GT(s.samples(), 1900u);
  double worst_ns = 0;
  for (std::size_t k = 0; k < s.samples(); ++k)
    worst_ns = std::max(worst_ns, std::abs(double(s.t_ns[k]) - double(kT0 + s.device_counter[k] * kPeriod)));
  EXPECT_LT(worst_ns, 150'000) << "worst error " << worst_ns << " ns";
  EXPECT_TRUE(events_of(rec, "clock_fit").empty());
  fs::remove(p);
}

TEST(FifoTime, AWrongDeviceRateIsReportedNotHidden) {
  const auto p = simulated_journal("wrong", 1100);  // the device really samples at 1000 Hz
  FinaliseReport rep;
  const auto rec = recording_from_journal(read_journal(p), p.string(), &rep);
  const auto notes = events_of(rec, "clock_fit");
  ASSERT_FALSE(notes.empty());
  EXPECT_NE(notes.front().find("device_rate_hz"), std::string::npos) << notes.front();
  ASSERT_FALSE(rep.problems.empty());
  EXPECT_NE(rep.problems.front().find("ft_sensor"), std::string::npos);
  fs::remove(p);
}
