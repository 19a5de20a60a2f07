#include "burrbench/analysis/lag_check.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

namespace burrbench::analysis {

namespace {

// Σ w|e − ē|² of e = measured − predicted(t − shift) over `at` (the bias taken off per axis).
double centred_sse(const std::vector<double>& t_s, const std::vector<glm::dvec3>& predicted,
                   const std::vector<glm::dvec3>& measured, const std::vector<std::size_t>& at, double shift_s) {
  std::vector<glm::dvec3> e;
  e.reserve(at.size());
  std::size_t k = 0;  // t_s[k] ≤ t − shift < t_s[k + 1]; t − shift rises with t
  for (std::size_t j : at) {
    const double t = t_s[j] - shift_s;
    while (k + 2 < t_s.size() && t_s[k + 1] <= t) ++k;
    while (k > 0 && t_s[k] > t) --k;
    const double f = std::clamp((t - t_s[k]) / (t_s[k + 1] - t_s[k]), 0.0, 1.0);
    e.push_back(measured[j] - (predicted[k] + f * (predicted[k + 1] - predicted[k])));
  }
  glm::dvec3 mean(0);
  for (const auto& v : e) mean += v / double(e.size());
  double sse = 0;
  for (const auto& v : e) sse += glm::dot(v - mean, v - mean);
  return sse;
}

}  // namespace

std::optional<LagMismatch> lag_mismatch(const std::vector<double>& t_s, const std::vector<glm::dvec3>& predicted_N,
                                        const std::vector<glm::dvec3>& measured_N, const std::vector<double>& weight) {
  if (t_s.size() < 3) return std::nullopt;
  std::vector<double> dt(t_s.size() - 1);
  for (std::size_t j = 0; j + 1 < t_s.size(); ++j) dt[j] = t_s[j + 1] - t_s[j];
  std::nth_element(dt.begin(), dt.begin() + std::ptrdiff_t(dt.size() / 2), dt.end());
  const double period_s = dt[dt.size() / 2];
  const double reach_s = kLagSearchMs * 1e-3;
  std::vector<std::size_t> at;
  for (std::size_t j = 0; j < t_s.size(); ++j)
    if (weight[j] > 0 && t_s[j] - reach_s >= t_s.front() && t_s[j] + reach_s <= t_s.back()) at.push_back(j);
  if (at.size() < 50 || !(period_s > 0)) return std::nullopt;
  LagMismatch m;
  m.period_ms = period_s * 1e3;
  m.samples = at.size();
  m.residual_as_replayed_N2 = centred_sse(t_s, predicted_N, measured_N, at, 0);
  m.residual_shifted_N2 = m.residual_as_replayed_N2;
  // Shifts a whole number of periods apart, at least kLagStepMs: a fast sensor (7 kHz)
  // over a long recording would otherwise try hundreds, each one pass over the samples.
  const double step_s = period_s * std::max(1.0, std::ceil(kLagStepMs * 1e-3 / period_s - 1e-9));
  const int steps = int(std::floor(reach_s / step_s));
  for (int k = -steps; k <= steps; ++k) {
    const double sse = centred_sse(t_s, predicted_N, measured_N, at, k * step_s);
    if (sse < m.residual_shifted_N2) {
      m.residual_shifted_N2 = sse;
      m.shift_ms = k * step_s * 1e3;
    }
  }
  return m;
}

bool LagMismatch::named() const {
  const double variance = residual_shifted_N2 / std::max(1.0, 3.0 * double(samples) - 4);
  return std::abs(shift_ms) > std::max(kLagMinimumMs, 2 * period_ms) &&
         residual_as_replayed_N2 - residual_shifted_N2 > kLagSignificance * variance;
}

std::string LagMismatch::text(const std::string& recording, double lag_ms) const {
  if (!named()) return "";
  return fmt::format(
      "Recording {}: its measured force follows the prediction best at a lag of {:.4g} ms, {:+.4g} ms from the {:.4g} "
      "ms it was replayed at: over {} samples the residual sum of squares falls from {:.4g} to {:.4g} N² ({:.0f} %). "
      "At the lag replayed each force is compared with the burr where it was not, and the metrics count that as "
      "model error. Set the recording's lag_ms (calibrate fits it as a nuisance).",
      recording, lag_ms + shift_ms, shift_ms, lag_ms, samples, residual_as_replayed_N2, residual_shifted_N2,
      100 * residual_shifted_N2 / residual_as_replayed_N2);
}

}  // namespace burrbench::analysis
