#pragma once
// Does the measured friction act against the predicted one? Friction on the burr lies along
// v × ω (MODEL.md "Forces"): a burr that spins the other way round than the manifest says
// (`[burr] spin_sign`, or a shaft axis given the other way) reverses every friction force
// and leaves the elastic force as it is. `acquire` does not know the spin (the manifest's
// default is +1), so nothing else catches it. A fit cannot reverse the spin: on the synthetic
// experiment it drove compact μ to its lower bound and α with it (erosion goes with μ/α) to
// 12.2 N/mm² (truth 500) with a profile interval of 12.1–12.7 — a confident miss whose only
// other sign was a misfit line pointing elsewhere. At given constants (`validate`) the reversed
// friction counts as model error against the release gate.
//
// The check regresses what the prediction leaves, measured − predicted, on the predicted
// friction force over the used samples in contact, each recording about its own means (its
// bias is its own): measured ≈ predicted + β·friction. The measured friction is then
// s = 1 + β times the predicted one; s < 0 is friction that acts the other way
// (docs/calibration.md "Friction against its predicted direction").
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/calibration/sensor_frame.hpp"

namespace burrbench::calibration {

// The fit of β must lower the residual sum of squares by more than this many times the
// variance per component left after it (a likelihood ratio, χ²₁ for friction as predicted;
// room for residuals correlated in time), as the sensor-frame check's.
inline constexpr double kFrictionSignificance = 100;
inline constexpr std::size_t kMinFrictionSamples = 50;
// Named only below this scale: at least half reversed. Friction the data do not hold at all
// (s ≈ 0, a μ too large) is a matter for the fit, not a reversed spin.
inline constexpr double kReversedScale = -0.5;

class FrictionDirectionCheck {
 public:
  // One recording, sensor frame, N: the predicted force (without bias), its friction part,
  // and the measured force, at its used samples (weight > 0) in contact (class_mask ≠ 0).
  void add(const std::vector<glm::dvec3>& predicted_N, const std::vector<glm::dvec3>& friction_N,
           const std::vector<glm::dvec3>& measured_N, const std::vector<std::uint8_t>& class_mask,
           const std::vector<double>& weight);

  struct Result {
    double scale = 1;  // s = 1 + β: the measured friction over the predicted one
    // Σ|r|² over the samples (each recording about its means), with the friction as
    // predicted (β = 0), with no friction (β = −1) and with the best β.
    double residual_as_predicted_N2 = 0, residual_without_friction_N2 = 0, residual_scaled_N2 = 0;
    std::size_t samples = 0;
    // s < kReversedScale, with both the friction as predicted and no friction rejected.
    bool reversed() const;
    // The warning line ("" when not reversed); spin_sign is the manifest's [burr] spin_sign.
    std::string text(int spin_sign) const;
  };
  // None with fewer than kMinFrictionSamples samples or no predicted friction.
  std::optional<Result> result() const;

 private:
  double rf_ = 0, ff_ = 0, rr_ = 0;  // Σ r·f, Σ f·f, Σ r·r about each recording's means
  std::size_t n_ = 0;
};

// The warning lines of the sensor-frame check and this one, over the same samples. Each
// reads the other's cause in part: reversed friction (mostly sideways) fits a mirror in its
// plane, and a mirrored sensor reverses the friction with the rest. So where both name a
// mismatch, only the one that leaves the smaller residual sum of squares is said.
std::vector<std::string> frame_and_friction_lines(const std::optional<SensorFrameCheck::Result>& frame,
                                                  const std::optional<FrictionDirectionCheck::Result>& friction,
                                                  const glm::dmat3& rotation_sensor_to_rig, int spin_sign);

}  // namespace burrbench::calibration
