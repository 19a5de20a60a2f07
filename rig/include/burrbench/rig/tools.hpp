#pragma once
// One-shot rig tools behind `burrbench rig check` and `burrbench rig tare`.
#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "burrbench/rig/register_map.hpp"

namespace burrbench::rig {

struct CheckedChannel {
  std::string name, unit;
  std::vector<double> values;
  bool valid = true;
};
struct CheckResult {
  std::string device, link;
  bool ok = false;
  std::string error;
  double round_trip_ms = 0;
  std::int64_t counter = -1;
  std::vector<CheckedChannel> channels;  // fifo: the newest record
};
// Reads every device once (read-only). Device faults are reported, never thrown.
std::vector<CheckResult> check_rig(const RigMap& map);

// Sensor bias: the mean of N force/torque samples taken with the burr spinning in air.
struct Tare {
  std::string device;
  std::vector<double> bias;  // Fx,Fy,Fz N, Tx,Ty,Tz N·mm
  std::vector<double> stddev;
  // Not stored: the second half's mean minus the first half's (6 values), and the force's
  // drift in standard errors of that difference (largest axis). A sensor at rest does not
  // drift: a large figure means the burr touched, or the sensor was still settling.
  std::vector<double> drift;
  double drift_sigmas = 0;  // `rig tare` warns above kTareDriftSigmas
  std::size_t samples = 0;
  std::int64_t t_ns = 0;          // CLOCK_MONOTONIC at the middle of the averaging window
  std::int64_t wall_ns = 0;       // Unix time of the same instant
  std::string rig_sha256;
};
inline constexpr double kTareDriftSigmas = 5;

// The running sums of a tare, and from them its statistics (mean, stddev, the drift
// between its halves): one pass, nothing stored per sample. The first ceil(planned/2)
// samples added are the first half.
class TareSums {
 public:
  explicit TareSums(std::size_t planned) : planned_(planned) {}
  void add(const std::array<double, 6>& w);
  std::size_t count() const { return n_; }
  // Fills t.samples, bias, stddev, drift, drift_sigmas.
  void finish(Tare& t) const;

 private:
  std::size_t planned_, n_ = 0;
  std::array<double, 6> sum_{}, sq_{}, second_{};  // `second_`: the sum over the second half
};
// Polls the device holding force_N and torque_Nmm (directly or through its calibration
// matrix) at its rate. std::runtime_error when the device cannot deliver N samples.
Tare measure_tare(const RigMap& map, std::size_t samples);
void write_tare(const std::filesystem::path& path, const Tare& t);
Tare read_tare(const std::filesystem::path& path);  // InputError on any defect

}  // namespace burrbench::rig
