// The sensor-zero check (zero_drift.hpp): the shift between the free stretches against a
// brute-force difference of means, its standard error against the closed form for white
// and AR(1) noise, and the cases it must stay silent on.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "burrbench/calibration/zero_drift.hpp"

namespace bc = burrbench::calibration;

namespace {

// 1000 samples at 1 kHz, in contact for samples [300, 700): noise of σ = 0.02 N per axis,
// AR(1) with lag-1 correlation rho, plus `step_N` on every sample after the contact.
struct Series {
  std::vector<double> t_s, weight;
  std::vector<glm::dvec3> force_N;
  std::vector<std::uint8_t> mask;
};

Series series(double rho, glm::dvec3 step_N, unsigned seed = 7) {
  Series s;
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> z(0.0, 0.02 * std::sqrt(1 - rho * rho));
  glm::dvec3 e(z(rng) / std::sqrt(1 - rho * rho), z(rng) / std::sqrt(1 - rho * rho), z(rng) / std::sqrt(1 - rho * rho));
  for (std::size_t j = 0; j < 1000; ++j) {
    e = rho * e + glm::dvec3(z(rng), z(rng), z(rng));
    const bool contact = j >= 300 && j < 700;
    s.t_s.push_back(1e-3 * double(j));
    s.force_N.push_back(glm::dvec3(0.1, -0.2, 0.3) + e + (contact ? glm::dvec3(1.0, 0, -2.0) : glm::dvec3(0)) +
                        (j >= 700 ? step_N : glm::dvec3(0)));
    s.mask.push_back(contact ? 2 : 0);
    s.weight.push_back(1.0);
  }
  return s;
}

glm::dvec3 mean(const Series& s, std::size_t from, std::size_t to) {
  glm::dvec3 m(0);
  for (std::size_t j = from; j < to; ++j) m += s.force_N[j];
  return m / double(to - from);
}

}  // namespace

TEST(ZeroDrift, AShiftBetweenTheFreeStretchesIsMeasuredAndNamed) {
  const auto still = series(0, glm::dvec3(0));
  const auto d0 = bc::zero_drift(still.t_s, still.force_N, still.mask, still.weight);
  ASSERT_TRUE(d0);
  EXPECT_EQ(d0->before, 300u);
  EXPECT_EQ(d0->after, 300u);
  EXPECT_DOUBLE_EQ(d0->before_to_s, 0.299);
  EXPECT_DOUBLE_EQ(d0->after_from_s, 0.7);
  const glm::dvec3 brute = mean(still, 700, 1000) - mean(still, 0, 300);
  EXPECT_NEAR(glm::length(d0->shift - brute), 0, 1e-12);
  // White noise: σ √(1/300 + 1/300) = 1.63 mN, within the scatter of the estimate of σ.
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(d0->standard_error[a], 0.02 * std::sqrt(2.0 / 300), 0.15e-3) << a;
  EXPECT_LT(d0->sigmas, bc::kZeroDriftSigmas);
  EXPECT_EQ(d0->text("plunge"), "");
  // 15 mN in y (9 standard errors) after the contact: said, with the figures.
  const auto moved = series(0, glm::dvec3(0, 0.015, 0));
  const auto d1 = bc::zero_drift(moved.t_s, moved.force_N, moved.mask, moved.weight);
  ASSERT_TRUE(d1);
  EXPECT_NEAR(d1->shift.y - d0->shift.y, 0.015, 1e-12);
  EXPECT_GT(d1->sigmas, bc::kZeroDriftSigmas);
  const std::string w = d1->text("plunge");
  EXPECT_EQ(w.rfind("Recording plunge: the force without contact moved by (", 0), 0u) << w;
  EXPECT_NE(w.find("between the stretch before the first contact (t = 0 … 0.299 s, 300 samples) and the one after "
                   "the last (t = 0.7 … 0.999 s, 300 samples)"),
            std::string::npos)
      << w;
  // The moment's check is the same statistic; its line names the channel and its unit.
  const std::string m = d1->text("plunge", bc::kMomentChannel);
  EXPECT_EQ(m.rfind("Recording plunge: the moment without contact moved by (", 0), 0u) << m;
  EXPECT_NE(m.find(") N·mm ("), std::string::npos) << m;
  EXPECT_NE(m.find("is taken for moment the burr made"), std::string::npos) << m;
}

TEST(ZeroDrift, CorrelatedNoiseWidensTheStandardError) {
  // AR(1), ρ = 0.9: the variance of a mean grows by (1 + ρ)/(1 − ρ) = 19.
  const auto s = series(0.9, glm::dvec3(0), 11);
  const auto d = bc::zero_drift(s.t_s, s.force_N, s.mask, s.weight);
  ASSERT_TRUE(d);
  const double closed = 0.02 * std::sqrt(19.0 * 2.0 / 300);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(d->standard_error[a], closed, 0.25 * closed) << a;
}

TEST(ZeroDrift, NothingToCompareIsNoFigure) {
  auto s = series(0, glm::dvec3(0, 1, 0));
  // Samples left out of the fit do not count: 19 used samples before the contact.
  auto w = s;
  for (std::size_t j = 0; j < 281; ++j) w.weight[j] = 0;
  EXPECT_FALSE(bc::zero_drift(w.t_s, w.force_N, w.mask, w.weight));
  w.weight[280] = 1;  // 20
  EXPECT_TRUE(bc::zero_drift(w.t_s, w.force_N, w.mask, w.weight));
  // A recording that starts in contact, or never touches bone.
  auto c = s;
  c.mask[0] = 1;
  EXPECT_FALSE(bc::zero_drift(c.t_s, c.force_N, c.mask, c.weight));
  auto none = s;
  std::fill(none.mask.begin(), none.mask.end(), 0);
  EXPECT_FALSE(bc::zero_drift(none.t_s, none.force_N, none.mask, none.weight));
}
