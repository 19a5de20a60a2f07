#include "burrbench/calibration/sensor_frame.hpp"

#include <algorithm>
#include <cmath>

#include <array>

#include <fmt/format.h>
#include <glm/gtc/quaternion.hpp>

#include "burrbench/model/registration.hpp"

namespace burrbench::calibration {

void SensorFrameCheck::add(const std::vector<glm::dvec3>& predicted_N, const std::vector<glm::dvec3>& measured_N,
                           const std::vector<std::uint8_t>& class_mask, const std::vector<double>& weight) {
  glm::dvec3 p_mean(0), m_mean(0);
  std::size_t n = 0;
  for (std::size_t j = 0; j < predicted_N.size(); ++j)
    if (weight[j] > 0 && class_mask[j] != 0) {
      p_mean += predicted_N[j];
      m_mean += measured_N[j];
      ++n;
    }
  if (n == 0) return;
  p_mean /= double(n);
  m_mean /= double(n);
  for (std::size_t j = 0; j < predicted_N.size(); ++j)
    if (weight[j] > 0 && class_mask[j] != 0) {
      const glm::dvec3 p = predicted_N[j] - p_mean, m = measured_N[j] - m_mean;
      cross_ += glm::outerProduct(m, p);
      pp_ += glm::dot(p, p);
      mm_ += glm::dot(m, m);
    }
  n_ += n;
}

std::optional<SensorFrameCheck::Result> SensorFrameCheck::result() const {
  if (n_ < kMinFrameSamples || !(pp_ > 0)) return std::nullopt;
  // Wahba's problem, as the registration solves it (model::optimal_rotation, Horn's
  // quaternion): the proper R with R·p ≈ m from S[r][c] = Σ p[r]·m[c] (= cross_[r][c]), and
  // the improper −R' with R' the proper rotation for −S (tr((−R')ᵀS) = tr(R'ᵀ(−S))).
  std::array<std::array<double, 3>, 3> S{}, minus{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      S[std::size_t(r)][std::size_t(c)] = cross_[r][c];
      minus[std::size_t(r)][std::size_t(c)] = -cross_[r][c];
    }
  const glm::dmat3 proper = model::optimal_rotation(S), improper = -model::optimal_rotation(minus);
  // Least squares with the best scale s = max(0, Σ m·Qp)/Σ|p|²: Σ|m|² − s²·Σ|p|².
  auto residual = [&](const glm::dmat3& Q) {
    double t = 0;
    for (int c = 0; c < 3; ++c) t += glm::dot(Q[c], cross_[c]);  // Σ_ij Q_ij Σ m_i p_j
    t = std::max(0.0, t);
    return mm_ - t * t / pp_;
  };
  Result res;
  res.samples = n_;
  res.residual_as_given_N2 = residual(glm::dmat3(1.0));
  const double r_proper = residual(proper), r_improper = residual(improper);
  res.mirrored = r_improper < r_proper;
  res.turn = res.mirrored ? improper : proper;
  res.residual_turned_N2 = res.mirrored ? r_improper : r_proper;
  glm::dquat q = glm::quat_cast(res.mirrored ? -res.turn : res.turn);
  if (q.w < 0) q = -q;  // the same turn, its angle in [0°, 180°]
  res.angle_deg = glm::degrees(glm::angle(q));
  res.axis = glm::axis(q);
  return res;
}

bool SensorFrameCheck::Result::mismatch() const {
  // Variance per component after the turn (3 per sample; 3 angles and a scale fitted).
  const double variance = residual_turned_N2 / std::max(1.0, 3.0 * double(samples) - 4);
  if (!(residual_as_given_N2 - residual_turned_N2 > kFrameSignificance * variance)) return false;
  return mirrored || angle_deg > kFrameAngleDeg;
}

std::string SensorFrameCheck::Result::text(const glm::dmat3& rotation_sensor_to_rig) const {
  if (!mismatch()) return "";
  const std::string how =
      mirrored ? (angle_deg < kFrameAngleDeg
                      ? std::string("with the force's sign the other way round")
                      : fmt::format("mirrored: the other way round and turned by a further {:.1f}° about ({:.3f}, "
                                    "{:.3f}, {:.3f})", angle_deg, axis.x, axis.y, axis.z))
               : fmt::format("in the sensor frame turned by a further {:.1f}° about ({:.3f}, {:.3f}, {:.3f})",
                             angle_deg, axis.x, axis.y, axis.z);
  // measured = Q·predicted, predicted ∝ Rᵀ·F_rig: the readings fit R·Qᵀ.
  std::string fix;
  if (mirrored) {
    fix = "Check [sensor] measures (force_on_sample or force_on_burr) and the sign of each force axis in the rig "
          "configuration";
  } else {
    const glm::dmat3 R = rotation_sensor_to_rig * glm::transpose(turn);
    auto row = [&](int r) { return fmt::format("[{:.3f}, {:.3f}, {:.3f}]", R[0][r], R[1][r], R[2][r]); };
    fix = fmt::format("Check [sensor] rotation_sensor_to_rig (the readings fit [{}, {}, {}]; `burrbench rig "
                      "sensor-pose` measures it from static loads)", row(0), row(1), row(2));
  }
  return fmt::format(
      "the measured force fits the prediction best {}: over {} used samples in contact the residual sum of squares "
      "falls from {:.4g} to {:.4g} N² ({:.0f} %). Neither the fit nor the metrics can turn the sensor's frame: a fit "
      "bends the constants to the turned readings, with intervals that do not show it, and the metrics count the "
      "turn as model error. {}.",
      how, samples, residual_as_given_N2, residual_turned_N2, 100 * residual_turned_N2 / residual_as_given_N2, fix);
}

}  // namespace burrbench::calibration
