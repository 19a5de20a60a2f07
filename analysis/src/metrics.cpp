#include "burrbench/analysis/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::analysis {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio_or_nan(double num, double den) { return den > 0 ? num / den : kNaN; }

// Trapezoid weights: a non-uniform or gappy time base weights each sample by the time
// it stands for, so the Sprague–Geers integrals do not depend on the sampling pattern.
std::vector<double> trapezoid_weights(std::span<const double> t, std::size_t n) {
  std::vector<double> w(n, 1.0);
  if (t.empty() || n < 2) return w;
  w[0] = 0.5 * (t[1] - t[0]);
  w[n - 1] = 0.5 * (t[n - 1] - t[n - 2]);
  for (std::size_t i = 1; i + 1 < n; ++i) w[i] = 0.5 * (t[i + 1] - t[i - 1]);
  return w;
}

}  // namespace

AxisMetrics compute_axis_metrics(std::span<const double> t_s, std::span<const double> measured,
                                 std::span<const double> predicted) {
  BURRBENCH_CHECK(measured.size() == predicted.size(), "measured/predicted lengths differ");
  BURRBENCH_CHECK(t_s.empty() || t_s.size() == measured.size(), "time/measured lengths differ");
  AxisMetrics r;
  const std::size_t n = measured.size();
  r.n = n;
  if (n == 0) {
    for (double* v : {&r.rmse_N, &r.measured_range_N, &r.nrmse, &r.r2, &r.theil_u2,
                      &r.sg_magnitude, &r.sg_phase, &r.sg_combined, &r.peak_measured_N,
                      &r.peak_predicted_N, &r.peak_error_N, &r.peak_error_rel,
                      &r.resid_lag1_autocorr, &r.durbin_watson})
      *v = kNaN;
    return r;
  }

  double mean_m = 0, mean_e = 0;
  for (std::size_t i = 0; i < n; ++i) {
    mean_m += measured[i];
    mean_e += measured[i] - predicted[i];
  }
  mean_m /= double(n);
  mean_e /= double(n);

  double sse = 0, sst = 0, sum_m2 = 0, dw_num = 0, ac_num = 0, ac_den = 0;
  double lo = measured[0], hi = measured[0], peak_m = 0, peak_p = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const double e = measured[i] - predicted[i];
    sse += e * e;
    sst += (measured[i] - mean_m) * (measured[i] - mean_m);
    sum_m2 += measured[i] * measured[i];
    lo = std::min(lo, measured[i]);
    hi = std::max(hi, measured[i]);
    peak_m = std::max(peak_m, std::abs(measured[i]));
    peak_p = std::max(peak_p, std::abs(predicted[i]));
    ac_den += (e - mean_e) * (e - mean_e);
    if (i > 0) {
      const double e_prev = measured[i - 1] - predicted[i - 1];
      dw_num += (e - e_prev) * (e - e_prev);
      ac_num += (e - mean_e) * (e_prev - mean_e);
    }
  }
  r.rmse_N = std::sqrt(sse / double(n));
  r.measured_range_N = hi - lo;
  r.nrmse = ratio_or_nan(r.rmse_N, r.measured_range_N);
  r.r2 = sst > 0 ? 1.0 - sse / sst : kNaN;
  r.theil_u2 = sum_m2 > 0 ? std::sqrt(sse / sum_m2) : kNaN;
  r.peak_measured_N = peak_m;
  r.peak_predicted_N = peak_p;
  r.peak_error_N = peak_p - peak_m;
  r.peak_error_rel = ratio_or_nan(r.peak_error_N, peak_m);
  r.resid_lag1_autocorr = n > 1 ? ratio_or_nan(ac_num, ac_den) : kNaN;
  r.durbin_watson = n > 1 ? ratio_or_nan(dw_num, sse) : kNaN;

  // Sprague & Geers (2004): ψ integrals over time.
  const auto w = trapezoid_weights(t_s, n);
  double psi_mm = 0, psi_cc = 0, psi_mc = 0;
  for (std::size_t i = 0; i < n; ++i) {
    psi_mm += w[i] * measured[i] * measured[i];
    psi_cc += w[i] * predicted[i] * predicted[i];
    psi_mc += w[i] * measured[i] * predicted[i];
  }
  if (psi_mm > 0 && psi_cc > 0) {
    r.sg_magnitude = std::sqrt(psi_cc / psi_mm) - 1.0;
    const double c = std::clamp(psi_mc / std::sqrt(psi_mm * psi_cc), -1.0, 1.0);
    r.sg_phase = std::acos(c) / std::numbers::pi;
    r.sg_combined = std::hypot(r.sg_magnitude, r.sg_phase);
  } else {
    // A zero prediction of a non-zero signal has M = −1 and an undefined phase.
    r.sg_magnitude = psi_mm > 0 ? -1.0 : kNaN;
    r.sg_phase = kNaN;
    r.sg_combined = kNaN;
  }
  return r;
}

}  // namespace burrbench::analysis
