#pragma once
// The live view's alarms (docs/watch.md "Alarms"): pure functions of a sample plus a
// small state machine for "longer than t ms", so each is tested with closed-form cases.
#include <glm/glm.hpp>
#include <optional>
#include <string>

namespace burrbench::watch {

struct AlarmSettings {
  double residual_k = 5;          // the band: k σ on any axis of the residual
  double residual_hold_ms = 200;  // beyond it for longer than this → alarm
  double contact_k = 5;           // a force "reads something" when |F| > k σ
  double contact_hold_ms = 200;   // a contact mismatch for longer than this → alarm
  // One line naming the bad field and what was expected, or "" when valid.
  std::string invalid() const;
};

// Any axis of the residual (N) beyond k σ.
bool beyond_band(const glm::dvec3& residual_N, double sigma_N, double k);

enum class ContactMismatch { kNone, kPredictedOnly, kMeasuredOnly };
// The burr predicted in bone (|predicted| > k σ) while the sensor, bias removed, reads
// nothing (|measured| ≤ k σ), or the reverse.
ContactMismatch contact_mismatch(const glm::dvec3& measured_minus_bias_N,
                                 const glm::dvec3& predicted_N, double sigma_N, double k);

// A condition that must hold, sample after sample, for longer than `hold_s`.
class Sustained {
 public:
  explicit Sustained(double hold_s) : hold_s_(hold_s) {}
  // True once per run: at the first sample at which the condition has held for longer
  // than hold_s (measured from the first sample of the run).
  bool update(double t_s, bool condition);
  bool holding() const { return since_s_.has_value(); }

 private:
  double hold_s_;
  std::optional<double> since_s_;
  bool fired_ = false;
};

struct Alarm {
  double t_s = 0;      // recording clock: the sample at which it fired
  double since_s = 0;  // when the condition began
  std::string kind;    // "residual", "predicted_contact_only", "measured_contact_only"
  std::string message;
};

// Both alarms over the stream of samples (in time order).
class AlarmMonitor {
 public:
  explicit AlarmMonitor(const AlarmSettings& s);
  // σ ≤ 0 or NaN: the band is not known yet, nothing fires.
  std::optional<Alarm> update(double t_s, const glm::dvec3& measured_minus_bias_N,
                              const glm::dvec3& predicted_N, double sigma_N);

 private:
  AlarmSettings s_;
  Sustained residual_, predicted_only_, measured_only_;
  double residual_since_ = 0, predicted_since_ = 0, measured_since_ = 0;
};

// What the operator is told with every alarm.
inline constexpr const char* kStopAndCheck =
    "registration, burr radius or model off — stop and check";

}  // namespace burrbench::watch
