#pragma once
// Validation metrics on one measured/predicted series (one axis of one recording, or a
// segment of it). Pure functions; definitions and formulas are in docs/report.md.
// Residual convention: e_i = measured_i − predicted_i.
#include <cstddef>
#include <span>

namespace burrbench::analysis {

struct AxisMetrics {
  std::size_t n = 0;              // samples compared
  double rmse_N = 0;              // sqrt(mean e²)
  double measured_range_N = 0;    // max(m) − min(m)
  double nrmse = 0;               // RMSE / measured range (NaN when the range is 0)
  double r2 = 0;                  // 1 − SSE/SST (NaN when SST = 0)
  double theil_u2 = 0;            // sqrt(Σe²)/sqrt(Σm²) (Theil 1966; NaN when Σm² = 0)
  double sg_magnitude = 0;        // Sprague–Geers M
  double sg_phase = 0;            // Sprague–Geers P ∈ [0,1]
  double sg_combined = 0;         // sqrt(M² + P²)
  double peak_measured_N = 0;     // max |m|
  double peak_predicted_N = 0;    // max |p|
  double peak_error_N = 0;        // peak_predicted − peak_measured
  double peak_error_rel = 0;      // peak_error / peak_measured (NaN when 0)
  double resid_lag1_autocorr = 0; // Σ(e_i−ē)(e_{i−1}−ē) / Σ(e_i−ē)²
  double durbin_watson = 0;       // Σ(e_i − e_{i−1})² / Σe_i²
};

// t_s gives the time weights of the Sprague–Geers integrals (trapezoid rule; may be
// empty → equal weights). measured, predicted (and t_s when given) have equal lengths
// (BURRBENCH_CHECK); n = 0 gives all-NaN metrics with n = 0.
AxisMetrics compute_axis_metrics(std::span<const double> t_s, std::span<const double> measured,
                                 std::span<const double> predicted);

}  // namespace burrbench::analysis
