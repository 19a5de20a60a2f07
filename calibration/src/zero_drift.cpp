#include "burrbench/calibration/zero_drift.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/calibration/objective.hpp"

namespace burrbench::calibration {

std::optional<ZeroDrift> zero_drift(const std::vector<double>& t_s, const std::vector<glm::dvec3>& measured,
                                    const std::vector<std::uint8_t>& class_mask, const std::vector<double>& weight) {
  const std::size_t n = t_s.size();
  std::size_t first = n, last = 0;
  for (std::size_t j = 0; j < n; ++j)
    if (class_mask[j] != 0) {
      first = std::min(first, j);
      last = j;
    }
  if (first == n) return std::nullopt;
  // The two stretches' used free samples (consecutive runs: lag-1 pairs never span a gap).
  std::vector<std::size_t> stretch[2];
  for (std::size_t j = 0; j < n; ++j)
    if (weight[j] > 0 && class_mask[j] == 0 && (j < first || j > last)) stretch[j > last].push_back(j);
  if (stretch[0].size() < kMinZeroDriftSamples || stretch[1].size() < kMinZeroDriftSamples) return std::nullopt;
  ZeroDrift d;
  d.before = stretch[0].size();
  d.after = stretch[1].size();
  d.before_from_s = t_s[stretch[0].front()];
  d.before_to_s = t_s[stretch[0].back()];
  d.after_from_s = t_s[stretch[1].front()];
  d.after_to_s = t_s[stretch[1].back()];
  glm::dvec3 mean[2];
  for (int s = 0; s < 2; ++s) {
    mean[s] = glm::dvec3(0);
    for (std::size_t j : stretch[s]) mean[s] += measured[j];
    mean[s] /= double(stretch[s].size());
  }
  d.shift = mean[1] - mean[0];
  glm::dvec3 sq(0);
  double lag_num = 0, lag_den = 0;
  for (int s = 0; s < 2; ++s)
    for (std::size_t i = 0; i < stretch[s].size(); ++i) {
      const glm::dvec3 e = measured[stretch[s][i]] - mean[s];
      sq += e * e;
      lag_den += glm::dot(e, e);
      if (i > 0 && stretch[s][i - 1] + 1 == stretch[s][i])
        lag_num += glm::dot(e, measured[stretch[s][i - 1]] - mean[s]);
    }
  const double n1 = double(d.before), n2 = double(d.after);
  const double inflation = ar1_inflation(lag_den > 0 ? lag_num / lag_den : 0.0);
  for (int a = 0; a < 3; ++a) {
    d.standard_error[a] = std::sqrt(sq[a] / (n1 + n2 - 2) * inflation * (1 / n1 + 1 / n2));
    if (d.standard_error[a] > 0) d.sigmas = std::max(d.sigmas, std::abs(d.shift[a]) / d.standard_error[a]);
  }
  return d;
}

std::string ZeroDrift::text(const std::string& recording, DriftChannel channel) const {
  if (!(sigmas > kZeroDriftSigmas)) return "";
  return fmt::format(
      "Recording {}: the {} without contact moved by ({:.3g}, {:.3g}, {:.3g}) {} ({:.1f} standard errors) between "
      "the stretch before the first contact (t = {:.4g} … {:.4g} s, {} samples) and the one after the last (t = {:.4g} "
      "… {:.4g} s, {} samples): the fitted bias, like the tare, is one number per recording, so a sensor zero that "
      "drifted (a sensor warming, a spindle started between them) is taken for {} the burr made and biases the "
      "constants and the metrics. Tare just before drilling, record shorter, or leave the drifting part out with a "
      "segment.",
      recording, channel.name, shift.x, shift.y, shift.z, channel.unit, sigmas, before_from_s, before_to_s, before,
      after_from_s, after_to_s, after, channel.name);
}

}  // namespace burrbench::calibration
