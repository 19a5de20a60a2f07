#pragma once
// Does the measured force fit the prediction better in another sensor frame? A force
// sensor mounted at another bolt hole (30–60° steps), with its axes labelled otherwise, or
// with the force's sign the other way round (`measures`) turns or mirrors every reading.
// The fit cannot turn the frame, so it bends the constants to the turned data, and gives
// them tight intervals: on the synthetic experiment with the sensor turned by 90° about z
// it returned compact α 185 and μ 0.13 (truth 500, 0.4), "identifiable", with only a
// misfit line to show. Wahba's problem on the used samples in contact (solved as the
// registration's, model::optimal_rotation) says which frame the readings fit best (docs/calibration.md "A sensor frame that does not fit").
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::calibration {

// A turn smaller than this is left to model error: below any bolt-pattern step.
inline constexpr double kFrameAngleDeg = 10;
// The turn must lower the residual sum of squares by more than this many times the
// variance per component left after it: a likelihood-ratio statistic, χ²₃ for a frame as
// given (0.999 quantile 16.3), with room for residuals correlated in time (the AR(1) factor
// of a good fit is about 5).
inline constexpr double kFrameSignificance = 100;
inline constexpr std::size_t kMinFrameSamples = 50;

class SensorFrameCheck {
 public:
  // One recording's predicted (without bias) and measured force, sensor frame, N: its used
  // samples (weight > 0) in contact (class_mask ≠ 0), each about the recording's own means
  // (its bias is its own).
  void add(const std::vector<glm::dvec3>& predicted_N, const std::vector<glm::dvec3>& measured_N,
           const std::vector<std::uint8_t>& class_mask, const std::vector<double>& weight);

  struct Result {
    // Q, orthogonal, with measured ≈ s·Q·predicted (s ≥ 0 the best scale): the best proper
    // rotation, or the best improper one when it fits better (mirrored).
    glm::dmat3 turn{1.0};
    bool mirrored = false;
    double angle_deg = 0;     // Q's angle (mirrored: −Q's)
    glm::dvec3 axis{0, 0, 1};  // its axis, sensor frame
    // Σ|m − s·Q·p|² over the samples with the best scale: Q = 1 (the frame as given), the turn.
    double residual_as_given_N2 = 0, residual_turned_N2 = 0;
    std::size_t samples = 0;
    bool mismatch() const;
    // The warning line ("" without a mismatch); `rotation_sensor_to_rig` is the manifest's.
    std::string text(const glm::dmat3& rotation_sensor_to_rig) const;
  };
  // None with fewer than kMinFrameSamples samples.
  std::optional<Result> result() const;

 private:
  glm::dmat3 cross_{0.0};  // Σ m·pᵀ (glm: [col][row])
  double pp_ = 0, mm_ = 0;
  std::size_t n_ = 0;
};

}  // namespace burrbench::calibration
