// The lag check (lag_check.hpp): a force series shifted by hand is found at its shift, its
// residuals match a brute-force sum of the shifted samples, and a series at its lag, or
// shifted by no more than 2 ms, is not named.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "burrbench/analysis/lag_check.hpp"

namespace ba = burrbench::analysis;

namespace {

// A drilling-like force at 1 kHz over 3 s: strokes of 0.4 s period and a slower swell.
glm::dvec3 force(double t) {
  return {0.2 * std::sin(2 * M_PI * t / 0.4), 0.1 * std::cos(2 * M_PI * t / 0.7), -0.5 - 0.3 * std::sin(t)};
}

struct Series {
  std::vector<double> t_s, weight;
  std::vector<glm::dvec3> predicted, measured;
};

// Measured = the force `lag_ms` later (the sensor's channel late by it) + a bias + σ 0.02 N,
// over 3 s at `rate_hz`.
Series series(double lag_ms, double rate_hz = 1000) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.02);
  Series s;
  for (int j = 0; j < int(3 * rate_hz); ++j) {
    const double t = j / rate_hz;
    s.t_s.push_back(t);
    s.predicted.push_back(force(t));
    s.measured.push_back(force(t - lag_ms * 1e-3) + glm::dvec3(0.05, -0.03, 0.1) +
                         glm::dvec3(noise(rng), noise(rng), noise(rng)));
    s.weight.push_back(j % 11 == 0 ? 0.0 : 1.0);
  }
  return s;
}

}  // namespace

TEST(LagCheck, AForceLaterThanReplayedIsFoundAtItsShift) {
  const Series s = series(35);
  const auto m = ba::lag_mismatch(s.t_s, s.predicted, s.measured, s.weight);
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->shift_ms, 35, 1e-9);
  EXPECT_NEAR(m->period_ms, 1, 1e-9);
  EXPECT_TRUE(m->named());
  // Brute force: at a whole number of periods, predicted(t − δ) is the sample δ earlier.
  // The samples: used, and 100 ms from either end.
  for (int k : {0, 35}) {
    std::vector<glm::dvec3> e;
    for (std::size_t j = 100; j + 100 < s.t_s.size(); ++j)
      if (s.weight[j] > 0) e.push_back(s.measured[j] - s.predicted[j - std::size_t(k)]);
    glm::dvec3 mean(0);
    for (const auto& v : e) mean += v;
    mean /= double(e.size());
    double sse = 0;
    for (const auto& v : e) sse += glm::dot(v - mean, v - mean);
    EXPECT_EQ(m->samples, e.size());
    EXPECT_NEAR(k == 0 ? m->residual_as_replayed_N2 : m->residual_shifted_N2, sse, 1e-9 * sse) << k;
  }
  const std::string w = m->text("polish", 0);
  EXPECT_EQ(w.rfind("Recording polish: its measured force follows the prediction best at a lag of 35 ms, +35 ms from "
                    "the 0 ms it was replayed at", 0), 0u) << w;
  // An earlier force the other way; the lag it names is the one replayed plus the shift.
  const auto early = ba::lag_mismatch(s.t_s, s.predicted, series(-12).measured, s.weight);
  ASSERT_TRUE(early);
  EXPECT_NEAR(early->shift_ms, -12, 1e-9);
  EXPECT_NE(early->text("plunge", 4).find("a lag of -8 ms, -12 ms from the 4 ms"), std::string::npos);
}

TEST(LagCheck, AFastSensorIsShiftedInWholeMillisecondSteps) {
  // 4 kHz: shifts 4 periods apart, 201 of them rather than 801; 35 ms is one of them.
  const Series s = series(35, 4000);
  const auto m = ba::lag_mismatch(s.t_s, s.predicted, s.measured, s.weight);
  ASSERT_TRUE(m);
  EXPECT_NEAR(m->period_ms, 0.25, 1e-9);
  EXPECT_NEAR(m->shift_ms, 35, 1e-9);
  EXPECT_TRUE(m->named());
}

TEST(LagCheck, AForceAtItsLagOrTwoMillisecondsOffIsNotNamed) {
  for (double lag : {0.0, 2.0}) {
    const Series s = series(lag);
    const auto m = ba::lag_mismatch(s.t_s, s.predicted, s.measured, s.weight);
    ASSERT_TRUE(m);
    EXPECT_NEAR(m->shift_ms, lag, 1e-9) << lag;  // found all the same
    EXPECT_FALSE(m->named()) << lag;
    EXPECT_EQ(m->text("plunge", 0), "");
  }
  // Too short a series (under 50 samples 100 ms from its ends) says nothing.
  Series s = series(35);
  s.t_s.resize(240), s.predicted.resize(240), s.measured.resize(240), s.weight.resize(240);
  EXPECT_FALSE(ba::lag_mismatch(s.t_s, s.predicted, s.measured, s.weight));
}
