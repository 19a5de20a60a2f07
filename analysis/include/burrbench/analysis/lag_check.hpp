#pragma once
// Was a recording replayed at the wrong lag? `validate` and `report` replay each recording
// at the manifest's lag (or the fit's), and a rig whose force channel is later than that
// (a sensor's filter, a slow poll) pairs each force with the burr where it was earlier:
// on the synthetic experiment a polish 35 ms late failed the release gate's R² with the
// true constants, the model blamed. The replay of a path shifted in time is the replay
// shifted in time, so the measured force against the prediction shifted by δ tells which
// lag the data follow (docs/report.md "A lag the data do not follow").
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::analysis {

inline constexpr double kLagSearchMs = 100;    // shifts tried: ±this,
inline constexpr double kLagStepMs = 1;        // this far apart at least (whole force periods)
inline constexpr double kLagMinimumMs = 2;     // a shift no larger (or of 2 periods) is not named
// The shift must lower the residual sum of squares by more than this many times the
// variance per component left after it (as calibration's SensorFrameCheck: χ²₁ at 0.999
// is 10.8; the rest is room for residuals correlated in time).
inline constexpr double kLagSignificance = 100;

struct LagMismatch {
  double shift_ms = 0;  // the data follow the prediction at the lag it was replayed at + this
  double period_ms = 0;
  double residual_as_replayed_N2 = 0, residual_shifted_N2 = 0;  // each about its own mean per axis
  std::size_t samples = 0;
  bool named() const;
  // The warning line ("" unless named); `lag_ms` is the lag it was replayed at.
  std::string text(const std::string& recording, double lag_ms) const;
};

// The predicted and measured force (sensor frame, N) at the force times t_s (s, strictly
// increasing) over the samples with weight > 0, more than kLagSearchMs from either end:
// the shift δ (whole median force periods, ≥ kLagStepMs apart, within ±kLagSearchMs) for which
// measured(t) fits predicted(t − δ), linearly interpolated, best after each one's mean is
// taken off per axis (the bias). None with fewer than 50 such samples.
std::optional<LagMismatch> lag_mismatch(const std::vector<double>& t_s, const std::vector<glm::dvec3>& predicted_N,
                                        const std::vector<glm::dvec3>& measured_N, const std::vector<double>& weight);

}  // namespace burrbench::analysis
