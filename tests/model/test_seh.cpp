// Sample–estimate–hold: its held values reproduce the force–time integral of a ramp
// exactly, where a zero-order hold lags by half a sample per interval.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "burrbench/model/sample_estimate_hold.hpp"

namespace bm = burrbench::model;

namespace {
// Integral of the held signal over [t_0, t_end] vs the true integral.
double hold_integral(const std::vector<double>& t, const std::vector<glm::dvec3>& h, int axis) {
  double s = 0;
  for (std::size_t k = 0; k + 1 < t.size(); ++k) s += h[k][axis] * (t[k + 1] - t[k]);
  return s;
}
}  // namespace

TEST(SampleEstimateHold, BeatsZeroOrderHoldOnARamp) {
  std::vector<double> t;
  std::vector<glm::dvec3> f;
  const double T = 1e-3, slope = 40.0;  // N/s
  for (int k = 0; k <= 1000; ++k) {
    t.push_back(k * T);
    f.push_back({slope * k * T, 2.0 - 3.0 * k * T, 0.5});
  }
  const auto seh = bm::SampleEstimateHold::filter(t, f);
  const double exact = 0.5 * slope * t.back() * t.back();
  const double zoh_err = std::abs(hold_integral(t, f, 0) - exact);
  const double seh_err = std::abs(hold_integral(t, seh, 0) - exact);
  EXPECT_NEAR(zoh_err, 0.5 * slope * T * t.back(), 1e-9);  // lags by T/2 throughout
  // only the first interval (no slope yet) is held at zero order
  EXPECT_NEAR(seh_err, 0.5 * slope * T * T, 1e-9);
  EXPECT_LT(seh_err, 0.01 * zoh_err);
  // interval by interval: exact after the first sample
  for (std::size_t k = 1; k + 1 < t.size(); ++k)
    EXPECT_NEAR(seh[k].x, slope * 0.5 * (t[k] + t[k + 1]), 1e-9);
  EXPECT_EQ(seh[5].z, 0.5);  // constant forces pass unchanged
}

TEST(SampleEstimateHold, BetterThanZeroOrderHoldOnASmoothForce) {
  std::vector<double> t;
  std::vector<glm::dvec3> f;
  const double T = 1e-3;
  for (int k = 0; k <= 2000; ++k) {
    t.push_back(k * T);
    f.push_back({std::sin(2 * M_PI * 5 * k * T), 0, 0});
  }
  const auto seh = bm::SampleEstimateHold::filter(t, f);
  double e_zoh = 0, e_seh = 0;
  for (std::size_t k = 1; k + 1 < t.size(); ++k) {  // k = 0: no slope yet, both hold F_0
    const double w = 2 * M_PI * 5;
    const double exact = (std::cos(w * t[k]) - std::cos(w * t[k + 1])) / w;
    e_zoh = std::max(e_zoh, std::abs(f[k].x * T - exact));
    e_seh = std::max(e_seh, std::abs(seh[k].x * T - exact));
  }
  EXPECT_LT(e_seh, 0.1 * e_zoh);
}

TEST(SampleEstimateHold, StreamingMatchesBatchAndChecksTime) {
  bm::SampleEstimateHold s;
  EXPECT_EQ(s.push(0.0, {1, 2, 3}), glm::dvec3(1, 2, 3));
  const glm::dvec3 h = s.push(0.002, {3, 2, 1}, 0.001);  // hold half the last interval
  EXPECT_NEAR(h.x, 3 + 2 * 0.25, 1e-12);
  EXPECT_THROW(s.push(0.002, {0, 0, 0}), std::exception);
}
