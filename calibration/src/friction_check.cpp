#include "burrbench/calibration/friction_check.hpp"

#include <algorithm>

#include <fmt/format.h>

namespace burrbench::calibration {

void FrictionDirectionCheck::add(const std::vector<glm::dvec3>& predicted_N, const std::vector<glm::dvec3>& friction_N,
                                 const std::vector<glm::dvec3>& measured_N, const std::vector<std::uint8_t>& class_mask,
                                 const std::vector<double>& weight) {
  auto used = [&](std::size_t j) { return weight[j] > 0 && class_mask[j] != 0; };
  glm::dvec3 r_mean(0), f_mean(0);
  std::size_t n = 0;
  for (std::size_t j = 0; j < predicted_N.size(); ++j)
    if (used(j)) {
      r_mean += measured_N[j] - predicted_N[j];
      f_mean += friction_N[j];
      ++n;
    }
  if (n == 0) return;
  r_mean /= double(n);
  f_mean /= double(n);
  for (std::size_t j = 0; j < predicted_N.size(); ++j)
    if (used(j)) {
      const glm::dvec3 r = measured_N[j] - predicted_N[j] - r_mean, f = friction_N[j] - f_mean;
      rf_ += glm::dot(r, f);
      ff_ += glm::dot(f, f);
      rr_ += glm::dot(r, r);
    }
  n_ += n;
}

std::optional<FrictionDirectionCheck::Result> FrictionDirectionCheck::result() const {
  if (n_ < kMinFrictionSamples || !(ff_ > 0)) return std::nullopt;
  Result res;
  res.samples = n_;
  const double beta = rf_ / ff_;
  res.scale = 1 + beta;
  res.residual_as_predicted_N2 = rr_;
  res.residual_scaled_N2 = std::max(0.0, rr_ - beta * beta * ff_);
  res.residual_without_friction_N2 = rr_ + 2 * rf_ + ff_;  // Σ|r + f|²
  return res;
}

bool FrictionDirectionCheck::Result::reversed() const {
  // Variance per component after β (3 per sample; one β fitted).
  const double variance = residual_scaled_N2 / std::max(1.0, 3.0 * double(samples) - 1);
  const double limit = residual_scaled_N2 + kFrictionSignificance * variance;
  return scale < kReversedScale && residual_as_predicted_N2 > limit && residual_without_friction_N2 > limit;
}

std::string FrictionDirectionCheck::Result::text(int spin_sign) const {
  if (!reversed()) return "";
  return fmt::format(
      "the measured force holds the predicted friction {:.3g} times: it acts against the direction the model gives it "
      "(over {} used samples in contact the residual sum of squares falls from {:.4g} to {:.4g} N² ({:.0f} %) with the "
      "friction so scaled). Friction lies along v × ω, so it turns round with the spin: the burr spins the other way "
      "round than [burr] spin_sign = {:+d} says (ω = spin_sign · shaft_axis_rig, right-hand rule: a burr turning "
      "clockwise seen from the handpiece has ω pointing from the handpiece to the burr), or shaft_axis_rig is given "
      "the other way. A fit cannot reverse the spin: it drives μ to its lower bound and bends α and C1 with it, with "
      "intervals that do not show it, and the metrics count the reversed friction as model error. Check the spindle's "
      "direction and [burr] spin_sign.",
      scale, samples, residual_as_predicted_N2, residual_scaled_N2, 100 * residual_scaled_N2 / residual_as_predicted_N2,
      spin_sign);
}

std::vector<std::string> frame_and_friction_lines(const std::optional<SensorFrameCheck::Result>& frame,
                                                  const std::optional<FrictionDirectionCheck::Result>& friction,
                                                  const glm::dmat3& rotation_sensor_to_rig, int spin_sign) {
  const bool turned = frame && frame->mismatch(), reversed = friction && friction->reversed();
  std::vector<std::string> lines;
  if (turned && (!reversed || frame->residual_turned_N2 <= friction->residual_scaled_N2))
    lines.push_back(frame->text(rotation_sensor_to_rig));
  else if (reversed)
    lines.push_back(friction->text(spin_sign));
  return lines;
}

}  // namespace burrbench::calibration
