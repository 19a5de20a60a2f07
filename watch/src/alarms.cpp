#include "burrbench/watch/alarms.hpp"

#include <fmt/format.h>

#include <cmath>

namespace burrbench::watch {

std::string AlarmSettings::invalid() const {
  const auto positive = [](double v) { return v > 0 && std::isfinite(v); };
  const auto non_negative = [](double v) { return v >= 0 && std::isfinite(v); };
  if (!positive(residual_k))
    return fmt::format("residual_k: expected a number > 0, got {}", residual_k);
  if (!positive(contact_k))
    return fmt::format("contact_k: expected a number > 0, got {}", contact_k);
  if (!non_negative(residual_hold_ms))
    return fmt::format("residual_hold_ms: expected a number >= 0, got {}", residual_hold_ms);
  if (!non_negative(contact_hold_ms))
    return fmt::format("contact_hold_ms: expected a number >= 0, got {}", contact_hold_ms);
  return "";
}

bool beyond_band(const glm::dvec3& r, double sigma_N, double k) {
  const double band = k * sigma_N;
  return std::abs(r.x) > band || std::abs(r.y) > band || std::abs(r.z) > band;
}

ContactMismatch contact_mismatch(const glm::dvec3& measured, const glm::dvec3& predicted,
                                 double sigma_N, double k) {
  const double floor_N = k * sigma_N;
  const bool reads = glm::length(measured) > floor_N, predicts = glm::length(predicted) > floor_N;
  if (predicts && !reads) return ContactMismatch::kPredictedOnly;
  if (reads && !predicts) return ContactMismatch::kMeasuredOnly;
  return ContactMismatch::kNone;
}

bool Sustained::update(double t_s, bool condition) {
  if (!condition) {
    since_s_.reset();
    fired_ = false;
    return false;
  }
  if (!since_s_) since_s_ = t_s;
  if (fired_ || !(t_s - *since_s_ > hold_s_)) return false;
  fired_ = true;
  return true;
}

AlarmMonitor::AlarmMonitor(const AlarmSettings& s)
    : s_(s),
      residual_(s.residual_hold_ms * 1e-3),
      predicted_only_(s.contact_hold_ms * 1e-3),
      measured_only_(s.contact_hold_ms * 1e-3) {}

std::optional<Alarm> AlarmMonitor::update(double t_s, const glm::dvec3& measured,
                                          const glm::dvec3& predicted, double sigma_N) {
  const bool known = sigma_N > 0 && std::isfinite(sigma_N);
  const bool beyond = known && beyond_band(measured - predicted, sigma_N, s_.residual_k);
  const ContactMismatch mm =
      known ? contact_mismatch(measured, predicted, sigma_N, s_.contact_k) : ContactMismatch::kNone;
  // Each condition's start, for the message (Sustained keeps its own).
  auto track = [t_s](bool cond, bool was, double& since) {
    if (cond && !was) since = t_s;
  };
  track(beyond, residual_.holding(), residual_since_);
  track(mm == ContactMismatch::kPredictedOnly, predicted_only_.holding(), predicted_since_);
  track(mm == ContactMismatch::kMeasuredOnly, measured_only_.holding(), measured_since_);
  const bool fire_residual = residual_.update(t_s, beyond);
  const bool fire_predicted = predicted_only_.update(t_s, mm == ContactMismatch::kPredictedOnly);
  const bool fire_measured = measured_only_.update(t_s, mm == ContactMismatch::kMeasuredOnly);
  // A contact mismatch says more than the residual it implies: it is reported first.
  if (fire_predicted)
    return Alarm{
        t_s, predicted_since_, "predicted_contact_only",
        fmt::format(
            "the burr is predicted in bone (|F| > {:.3g} N) while the sensor reads nothing, "
            "since t = {:.3f} s: {}",
            s_.contact_k * sigma_N, predicted_since_, kStopAndCheck)};
  if (fire_measured)
    return Alarm{
        t_s, measured_since_, "measured_contact_only",
        fmt::format("the sensor reads a force (|F| > {:.3g} N) while the burr is predicted in air, "
                    "since t = {:.3f} s: {}",
                    s_.contact_k * sigma_N, measured_since_, kStopAndCheck)};
  if (fire_residual)
    return Alarm{t_s, residual_since_, "residual",
                 fmt::format("the residual is beyond {:g} sigma ({:.3g} N) for more than {:g} ms, "
                             "since t = {:.3f} s: {}",
                             s_.residual_k, s_.residual_k * sigma_N, s_.residual_hold_ms,
                             residual_since_, kStopAndCheck)};
  return std::nullopt;
}

}  // namespace burrbench::watch
