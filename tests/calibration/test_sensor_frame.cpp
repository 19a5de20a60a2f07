// The sensor-frame check (sensor_frame.hpp): Wahba's problem on predicted and measured
// forces, against turns and mirrors put in by hand, its residuals against a brute-force
// sum, and silence for a frame as given or a turn below kFrameAngleDeg.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

#include "burrbench/calibration/sensor_frame.hpp"

namespace bc = burrbench::calibration;

namespace {

struct Recording {
  std::vector<glm::dvec3> predicted, measured;
  std::vector<std::uint8_t> mask;
  std::vector<double> weight;
};

// Forces of a drilling (about 1 N, every direction, a larger z) read through `turn`, with
// the recording's own bias and noise of σ = 0.02 N; every fifth sample out of contact with
// a wild reading the check must not use, every seventh unused.
Recording recording(const glm::dmat3& turn, glm::dvec3 bias, unsigned seed, std::size_t n = 2000) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0, 1), noise(0, 0.02);
  Recording r;
  for (std::size_t j = 0; j < n; ++j) {
    const glm::dvec3 p(0.3 * unit(rng), 0.3 * unit(rng), -0.8 + 0.3 * unit(rng));
    const bool contact = j % 5 != 0;
    r.predicted.push_back(contact ? p : glm::dvec3(0));
    r.measured.push_back(contact ? turn * p + bias + glm::dvec3(noise(rng), noise(rng), noise(rng))
                                 : glm::dvec3(50, -50, 50));
    r.mask.push_back(contact ? 1 : 0);
    r.weight.push_back(j % 7 == 0 ? 0.0 : 1.0);
  }
  return r;
}

bc::SensorFrameCheck::Result check(const glm::dmat3& turn) {
  bc::SensorFrameCheck c;
  for (unsigned s = 0; s < 2; ++s) {  // two recordings with biases of their own
    const Recording r = recording(turn, glm::dvec3(0.1, -0.2 * s, 0.3 * s), 7 + s);
    c.add(r.predicted, r.measured, r.mask, r.weight);
  }
  const auto res = c.result();
  EXPECT_TRUE(res);
  return res ? *res : bc::SensorFrameCheck::Result{};
}

glm::dmat3 about_z(double deg) {
  return glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(deg), glm::dvec3(0, 0, 1)));
}

}  // namespace

TEST(SensorFrame, AFrameAsGivenIsNotNamed) {
  const auto res = check(glm::dmat3(1.0));
  EXPECT_LT(res.angle_deg, 1.0);
  EXPECT_FALSE(res.mirrored);
  EXPECT_FALSE(res.mismatch());
  EXPECT_EQ(res.text(glm::dmat3(1.0)), "");
  // Only the used samples in contact count: 2 × (2000 − 400 out of contact − 228 unused in
  // contact: 286 multiples of 7, less the 58 of 35).
  EXPECT_EQ(res.samples, 2u * (1600 - 228));
}

TEST(SensorFrame, ATurnIsFoundWithTheRotationTheReadingsFit) {
  const auto res = check(about_z(30));
  EXPECT_NEAR(res.angle_deg, 30, 0.5);
  EXPECT_NEAR(std::abs(res.axis.z), 1, 1e-3);
  EXPECT_TRUE(res.mismatch());
  // The manifest says the sensor is turned by 30° about z in the rig; the readings were
  // taken 30° further on, so they fit the sensor turned by 0° (R·Qᵀ = Rz(30)·Rz(30)ᵀ).
  const std::string w = res.text(about_z(30));
  EXPECT_NE(w.find("turned by a further 30."), std::string::npos) << w;
  EXPECT_NE(w.find("the readings fit [[1.000, "), std::string::npos) << w;
  // The residuals against a brute-force sum with the best scale.
  bc::SensorFrameCheck c;
  const Recording r = recording(about_z(30), glm::dvec3(0.1, 0, 0), 7);
  c.add(r.predicted, r.measured, r.mask, r.weight);
  const auto one = *c.result();
  glm::dvec3 pm(0), mm(0);
  std::size_t n = 0;
  for (std::size_t j = 0; j < r.predicted.size(); ++j)
    if (r.mask[j] && r.weight[j] > 0) pm += r.predicted[j], mm += r.measured[j], ++n;
  pm /= double(n);
  mm /= double(n);
  for (const glm::dmat3& Q : {glm::dmat3(1.0), one.turn}) {
    double num = 0, den = 0, sum = 0;
    for (std::size_t j = 0; j < r.predicted.size(); ++j)
      if (r.mask[j] && r.weight[j] > 0) {
        num += glm::dot(r.measured[j] - mm, Q * (r.predicted[j] - pm));
        den += glm::dot(r.predicted[j] - pm, r.predicted[j] - pm);
      }
    const double s = std::max(0.0, num / den);
    for (std::size_t j = 0; j < r.predicted.size(); ++j)
      if (r.mask[j] && r.weight[j] > 0) {
        const glm::dvec3 e = r.measured[j] - mm - s * (Q * (r.predicted[j] - pm));
        sum += glm::dot(e, e);
      }
    const double got = Q == glm::dmat3(1.0) ? one.residual_as_given_N2 : one.residual_turned_N2;
    EXPECT_NEAR(got, sum, 1e-9 * sum);
  }
  // After the turn only the noise is left: 3 components of σ² = 4e-4 N² per sample.
  EXPECT_NEAR(one.residual_turned_N2 / (3.0 * double(one.samples)), 4e-4, 0.4e-4);
}

TEST(SensorFrame, ASmallTurnIsLeftToModelError) {
  const auto res = check(about_z(5));
  EXPECT_NEAR(res.angle_deg, 5, 0.5);
  EXPECT_FALSE(res.mismatch());
}

TEST(SensorFrame, AForceSignTheOtherWayRoundIsMirrored) {
  const auto res = check(glm::dmat3(-1.0));
  EXPECT_TRUE(res.mirrored);
  EXPECT_LT(res.angle_deg, 1.0);
  EXPECT_TRUE(res.mismatch());
  const std::string w = res.text(glm::dmat3(1.0));
  EXPECT_NE(w.find("with the force's sign the other way round"), std::string::npos) << w;
  EXPECT_NE(w.find("Check [sensor] measures"), std::string::npos) << w;
  // One axis's sign flipped: mirrored, −Q a half turn about that axis.
  const auto y = check(glm::dmat3(glm::dvec3(1, 0, 0), glm::dvec3(0, -1, 0), glm::dvec3(0, 0, 1)));
  EXPECT_TRUE(y.mirrored && y.mismatch());
  EXPECT_NEAR(y.angle_deg, 180, 0.5);
  EXPECT_NEAR(std::abs(y.axis.y), 1, 1e-3);
}

TEST(SensorFrame, TooFewSamplesSayNothing) {
  bc::SensorFrameCheck c;
  const Recording r = recording(about_z(90), glm::dvec3(0), 3, 60);  // 48 in contact, 41 used
  c.add(r.predicted, r.measured, r.mask, r.weight);
  EXPECT_FALSE(c.result());
}
