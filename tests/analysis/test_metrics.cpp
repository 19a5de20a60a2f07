// Metrics against hand-computed values (docs/report.md has the formulas).
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/analysis_fixture.hpp"
#include "burrbench/analysis/metrics.hpp"
#include "burrbench/analysis/residual_diagnostics.hpp"
#include "burrbench/data_schema/error.hpp"

using burrbench::analysis::compute_axis_metrics;

namespace {
const std::vector<double> kNoTime;
}

TEST(Metrics, OneOffSampleByHand) {
  const std::vector<double> m = {1, 2, 3, 4}, p = {1, 2, 3, 5};  // e = 0,0,0,−1
  const auto r = compute_axis_metrics(kNoTime, m, p);
  EXPECT_EQ(r.n, 4u);
  EXPECT_DOUBLE_EQ(r.rmse_N, 0.5);                // √(1/4)
  EXPECT_DOUBLE_EQ(r.measured_range_N, 3.0);
  EXPECT_DOUBLE_EQ(r.nrmse, 0.5 / 3.0);           // by the measured range
  EXPECT_DOUBLE_EQ(r.r2, 0.8);                    // 1 − 1/5
  EXPECT_DOUBLE_EQ(r.theil_u2, std::sqrt(1.0 / 30.0));
  EXPECT_DOUBLE_EQ(r.peak_measured_N, 4.0);
  EXPECT_DOUBLE_EQ(r.peak_predicted_N, 5.0);
  EXPECT_DOUBLE_EQ(r.peak_error_N, 1.0);
  EXPECT_DOUBLE_EQ(r.peak_error_rel, 0.25);
  EXPECT_DOUBLE_EQ(r.durbin_watson, 1.0);         // Σ(Δe)² = 1, Σe² = 1
  EXPECT_DOUBLE_EQ(r.resid_lag1_autocorr, -1.0 / 12.0);
  // ψmm = 30, ψcc = 39, ψmc = 34 (equal weights)
  EXPECT_DOUBLE_EQ(r.sg_magnitude, std::sqrt(39.0 / 30.0) - 1.0);
  EXPECT_DOUBLE_EQ(r.sg_phase, std::acos(34.0 / std::sqrt(30.0 * 39.0)) / std::numbers::pi);
  EXPECT_DOUBLE_EQ(r.sg_combined, std::hypot(r.sg_magnitude, r.sg_phase));
}

TEST(Metrics, ConstantPredictionOfTheMeanHasZeroR2) {
  const std::vector<double> m = {1, 2, 3, 4}, p(4, 2.5);  // e = −1.5, −.5, .5, 1.5
  const auto r = compute_axis_metrics(kNoTime, m, p);
  EXPECT_NEAR(r.r2, 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(r.rmse_N, std::sqrt(5.0 / 4.0));
  EXPECT_DOUBLE_EQ(r.theil_u2, std::sqrt(5.0 / 30.0));
  EXPECT_DOUBLE_EQ(r.sg_magnitude, std::sqrt(25.0 / 30.0) - 1.0);
  EXPECT_DOUBLE_EQ(r.sg_phase, std::acos(25.0 / std::sqrt(750.0)) / std::numbers::pi);
  EXPECT_DOUBLE_EQ(r.peak_error_N, -1.5);
  // residual is a ramp: strongly positively correlated, DW = 3·1 / 5
  EXPECT_DOUBLE_EQ(r.durbin_watson, 3.0 / 5.0);
  EXPECT_DOUBLE_EQ(r.resid_lag1_autocorr, (-1.5 * -0.5 + -0.5 * 0.5 + 0.5 * 1.5) / 5.0);
}

TEST(Metrics, ConstantPredictionWorseThanMeanHasNegativeR2) {
  const std::vector<double> m = {1, 2, 3, 4}, p(4, 0.0);
  const auto r = compute_axis_metrics(kNoTime, m, p);
  EXPECT_DOUBLE_EQ(r.r2, 1.0 - 30.0 / 5.0);
  EXPECT_DOUBLE_EQ(r.theil_u2, 1.0);   // as bad as predicting zero: by definition
  EXPECT_DOUBLE_EQ(r.sg_magnitude, -1.0);
  EXPECT_TRUE(std::isnan(r.sg_phase));  // phase of a zero signal is undefined
}

// A sine shifted by 1/8 of its period over whole periods: M = 0, P = acos(cos 45°)/π = 1/4,
// RMSE = 2·sin(π/8)/√2 (amplitude of the difference of two unit sines, as RMS).
TEST(Metrics, ShiftedSignalHasPhaseErrorOnly) {
  const int n = 2001;
  std::vector<double> t(n), m(n), p(n);
  for (int i = 0; i < n; ++i) {
    t[i] = 2.0 * i / (n - 1);  // two periods of 1 s
    m[i] = std::sin(2 * std::numbers::pi * t[i]);
    p[i] = std::sin(2 * std::numbers::pi * (t[i] - 0.125));
  }
  const auto r = compute_axis_metrics(t, m, p);
  EXPECT_NEAR(r.sg_magnitude, 0.0, 1e-9);
  EXPECT_NEAR(r.sg_phase, 0.25, 1e-9);
  EXPECT_NEAR(r.sg_combined, 0.25, 1e-9);
  EXPECT_NEAR(r.rmse_N, 2 * std::sin(std::numbers::pi / 8) / std::sqrt(2.0), 1e-3);
  EXPECT_NEAR(r.r2, 1.0 - 2 * std::pow(2 * std::sin(std::numbers::pi / 8), 2) / 2, 2e-3);
  EXPECT_NEAR(r.peak_error_N, 0.0, 1e-4);
  EXPECT_GT(r.resid_lag1_autocorr, 0.99);  // a smooth, unmodelled residual
  EXPECT_LT(r.durbin_watson, 0.01);
}

TEST(Metrics, ScaledSignalHasMagnitudeErrorOnly) {
  std::vector<double> t(101), m(101), p(101);
  for (int i = 0; i < 101; ++i) {
    t[i] = 0.01 * i;
    m[i] = std::cos(2 * std::numbers::pi * t[i]) + 0.3;
    p[i] = 2 * m[i];
  }
  const auto r = compute_axis_metrics(t, m, p);
  EXPECT_NEAR(r.sg_magnitude, 1.0, 1e-12);
  EXPECT_NEAR(r.sg_phase, 0.0, 1e-6);
  EXPECT_DOUBLE_EQ(r.peak_error_rel, 1.0);
}

TEST(Metrics, PerfectPrediction) {
  const std::vector<double> m = {0.5, -1, 2}, p = m;
  const auto r = compute_axis_metrics(kNoTime, m, p);
  EXPECT_EQ(r.rmse_N, 0.0);
  EXPECT_EQ(r.r2, 1.0);
  EXPECT_EQ(r.theil_u2, 0.0);
  EXPECT_NEAR(r.sg_combined, 0.0, 1e-7);
  EXPECT_TRUE(std::isnan(r.durbin_watson));  // 0/0: undefined, reported as n/a
}

TEST(Metrics, WhiteResidualHasDurbinWatsonNearTwo) {
  // Alternating ±1 residual: DW = Σ(2)²/Σ1 = 4(n−1)/n, autocorrelation −1·(n−1)/n.
  std::vector<double> m(10), p(10);
  for (int i = 0; i < 10; ++i) {
    m[i] = i;
    p[i] = i + (i % 2 ? 1.0 : -1.0);
  }
  const auto r = compute_axis_metrics(kNoTime, m, p);
  EXPECT_DOUBLE_EQ(r.durbin_watson, 4.0 * 9 / 10);
  EXPECT_DOUBLE_EQ(r.resid_lag1_autocorr, -9.0 / 10);
}

TEST(Metrics, UndefinedCasesAreNaNNotNumbers) {
  const std::vector<double> flat = {2, 2, 2}, p = {1, 2, 3};
  const auto r = compute_axis_metrics(kNoTime, flat, p);
  EXPECT_TRUE(std::isnan(r.nrmse));  // range 0
  EXPECT_TRUE(std::isnan(r.r2));     // SST 0
  const auto e = compute_axis_metrics(kNoTime, {}, {});
  EXPECT_EQ(e.n, 0u);
  EXPECT_TRUE(std::isnan(e.rmse_N));
  const std::vector<double> two = {1, 2};
  EXPECT_THROW(compute_axis_metrics(kNoTime, two, p), burrbench::InvariantError);
}

// The QQ plot's quantiles and the autocorrelation plot, against closed forms.
TEST(ResidualDiagnostics, NormalQuantileMatchesTables) {
  using burrbench::analysis::normal_quantile;
  EXPECT_NEAR(normal_quantile(0.5), 0.0, 1e-14);
  EXPECT_NEAR(normal_quantile(0.975), 1.959963984540054, 1e-12);
  EXPECT_NEAR(normal_quantile(0.025), -1.959963984540054, 1e-12);
  EXPECT_NEAR(normal_quantile(0.8413447460685429), 1.0, 1e-12);
  EXPECT_NEAR(normal_quantile(1e-10), -6.361340902404056, 1e-9);
}

TEST(ResidualDiagnostics, AutocorrelationOfAnAr1ResidualAndQqOfGaussianNoise) {
  auto in = burrbench::testing::small_input();
  in.recordings.pop_back();  // R1 alone
  auto& r = in.recordings[0];
  // Residuals e_i = 0.8·e_{i−1} + w_i on x (AR(1), r(k) = 0.8^k), white on y, 0 on z.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> w(0.0, 0.05);
  const std::size_t n = 40000;
  r.t_s.clear();
  r.measured_N.clear();
  r.predicted_N.clear();
  r.used.assign(n, 1);
  double ex = 0;
  for (std::size_t i = 0; i < n; ++i) {
    ex = 0.8 * ex + w(rng);
    r.t_s.push_back(0.001 * double(i));
    r.predicted_N.emplace_back(1.0, 2.0, 3.0);
    r.measured_N.push_back(r.predicted_N.back() + glm::dvec3(ex, w(rng), 0.0));
  }
  const auto d = burrbench::analysis::residual_diagnostics(in, r.role);
  ASSERT_TRUE(d.is_object());
  const auto& acf = d["acf"]["r"];
  EXPECT_NEAR(acf[0][0].get<double>(), 1.0, 1e-12);
  EXPECT_NEAR(acf[0][1].get<double>(), 0.8, 0.02);
  EXPECT_NEAR(acf[0][3].get<double>(), 0.512, 0.03);
  EXPECT_NEAR(acf[1][1].get<double>(), 0.0, 0.02);
  EXPECT_EQ(acf[2][1].get<double>(), 0.0);  // no variance: 0, not NaN
  // Pooled over the axes the residuals are not one normal (z is all 0), but the QQ
  // points are sorted, standardised and at most 2000 plus the largest.
  const auto& th = d["qq"]["theory"];
  const auto& sa = d["qq"]["sample"];
  ASSERT_EQ(th.size(), sa.size());
  EXPECT_LE(th.size(), 2001u);
  for (std::size_t i = 1; i < th.size(); ++i) {
    EXPECT_LT(th[i - 1].get<double>(), th[i].get<double>());
    EXPECT_LE(sa[i - 1].get<double>(), sa[i].get<double>());
  }
  EXPECT_EQ(d["n"].get<std::size_t>(), n);
  // Another role has no used sample: null.
  EXPECT_TRUE(burrbench::analysis::residual_diagnostics(in, "no such role").is_null());
}
