#include "burrbench/analysis/residual_diagnostics.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace burrbench::analysis {
using nlohmann::json;

double normal_quantile(double p) {
  if (!(p > 0 && p < 1)) return p <= 0 ? -INFINITY : INFINITY;
  // Start from a logistic approximation, then Newton on Φ(x) = ½·erfc(−x/√2).
  double x = std::log(p / (1 - p)) / 1.702;
  for (int it = 0; it < 60; ++it) {
    const double cdf = 0.5 * std::erfc(-x / std::sqrt(2.0));
    const double pdf = std::exp(-0.5 * x * x) / std::sqrt(2 * M_PI);
    if (pdf < 1e-300) break;
    const double step = (cdf - p) / pdf;
    x -= std::clamp(step, -1.0, 1.0);
    if (std::abs(step) < 1e-13) break;
  }
  return x;
}

json residual_diagnostics(const ReportData& in, const std::string& role) {
  constexpr std::size_t kMaxQQ = 2000;
  constexpr std::size_t kMaxLag = 50;
  std::vector<double> e;
  std::array<std::vector<double>, 3> num;
  for (auto& v : num) v.assign(kMaxLag + 1, 0.0);
  std::array<double, 3> sum_sq{0, 0, 0};
  for (const auto& r : in.recordings) {
    if (r.role != role) continue;
    const std::size_t n = r.t_s.size();
    glm::dvec3 mean(0);
    std::size_t used = 0;
    for (std::size_t i = 0; i < n; ++i)
      if (r.used[i]) {
        mean += r.measured_N[i] - r.predicted_N[i];
        ++used;
      }
    if (used == 0) continue;
    mean /= double(used);
    for (std::size_t i = 0; i < n; ++i) {
      if (!r.used[i]) continue;
      const glm::dvec3 ei = r.measured_N[i] - r.predicted_N[i];
      for (int a = 0; a < 3; ++a) {
        e.push_back(ei[a]);
        sum_sq[std::size_t(a)] += (ei[a] - mean[a]) * (ei[a] - mean[a]);
        for (std::size_t k = 0; k <= kMaxLag && i + k < n; ++k)
          if (r.used[i + k]) {
            const glm::dvec3 ek = r.measured_N[i + k] - r.predicted_N[i + k];
            num[std::size_t(a)][k] += (ei[a] - mean[a]) * (ek[a] - mean[a]);
          }
      }
    }
  }
  if (e.empty()) return nullptr;
  // Standardised by the pooled mean and SD (the QQ plot asks about the shape, not the scale).
  double m = 0, s2 = 0;
  for (double v : e) m += v / double(e.size());
  for (double v : e) s2 += (v - m) * (v - m) / double(std::max<std::size_t>(1, e.size() - 1));
  const double sd = std::sqrt(s2) > 0 ? std::sqrt(s2) : 1.0;
  std::sort(e.begin(), e.end());
  json theory = json::array(), sample = json::array();
  const std::size_t n = e.size(), step = std::max<std::size_t>(1, (n + kMaxQQ - 1) / kMaxQQ);
  for (std::size_t i = 0; i < n; i += step) {
    theory.push_back(normal_quantile((double(i) + 0.5) / double(n)));
    sample.push_back((e[i] - m) / sd);
  }
  if ((n - 1) % step != 0) {  // always show the largest residual
    theory.push_back(normal_quantile((double(n) - 0.5) / double(n)));
    sample.push_back((e.back() - m) / sd);
  }
  json lags = json::array(), r = json::array({json::array(), json::array(), json::array()});
  for (std::size_t k = 0; k <= kMaxLag; ++k) {
    lags.push_back(k);
    for (std::size_t a = 0; a < 3; ++a) r[a].push_back(sum_sq[a] > 0 ? num[a][k] / sum_sq[a] : 0.0);
  }
  return {{"role", role}, {"qq", {{"theory", theory}, {"sample", sample}}}, {"acf", {{"lag", lags}, {"r", r}}},
          {"n", e.size() / 3}};
}

}  // namespace burrbench::analysis
