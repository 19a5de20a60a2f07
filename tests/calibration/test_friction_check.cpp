// The check of friction against its predicted direction (friction_check.hpp): the scale of
// the measured friction against a closed form for readings made with it set by hand, the
// residuals against a brute-force sum, and silence for friction as predicted, friction
// weaker or stronger than predicted, none at all or less than half reversed, and too few
// samples.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "burrbench/calibration/friction_check.hpp"

namespace bc = burrbench::calibration;

namespace {

struct Recording {
  std::vector<glm::dvec3> predicted, friction, measured;
  std::vector<std::uint8_t> mask;
  std::vector<double> weight;
};

// A drilling's forces: an elastic part (about 1 N, mostly z) and a friction part (about
// 0.3 N, sideways), predicted; measured with the friction `scale` times the predicted, the
// recording's own bias and noise of σ = 0.02 N. Every fifth sample is out of contact with a
// wild reading the check must not use, every seventh unused.
Recording recording(double scale, glm::dvec3 bias, unsigned seed, std::size_t n = 2000) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0, 1), noise(0, 0.02);
  Recording r;
  for (std::size_t j = 0; j < n; ++j) {
    const glm::dvec3 e(0.1 * unit(rng), 0.1 * unit(rng), -0.8 + 0.2 * unit(rng));
    const glm::dvec3 f(0.3 * unit(rng), 0.3 * unit(rng), 0.05 * unit(rng));
    const bool contact = j % 5 != 0;
    r.predicted.push_back(contact ? e + f : glm::dvec3(0));
    r.friction.push_back(contact ? f : glm::dvec3(0));
    r.measured.push_back(contact ? e + scale * f + bias + glm::dvec3(noise(rng), noise(rng), noise(rng))
                                 : glm::dvec3(50, -50, 50));
    r.mask.push_back(contact ? 1 : 0);
    r.weight.push_back(j % 7 == 0 ? 0.0 : 1.0);
  }
  return r;
}

bc::FrictionDirectionCheck::Result check(double scale, std::size_t n = 2000) {
  bc::FrictionDirectionCheck c;
  for (unsigned s = 0; s < 2; ++s) {  // two recordings with biases of their own
    const Recording r = recording(scale, glm::dvec3(0.1, -0.2 * s, 0.3 * s), 7 + s, n);
    c.add(r.predicted, r.friction, r.measured, r.mask, r.weight);
  }
  const auto res = c.result();
  EXPECT_TRUE(res);
  return res ? *res : bc::FrictionDirectionCheck::Result{};
}

}  // namespace

TEST(FrictionCheck, FrictionAsPredictedIsNotNamed) {
  const auto res = check(1.0);
  EXPECT_NEAR(res.scale, 1.0, 0.01);
  EXPECT_FALSE(res.reversed());
  EXPECT_EQ(res.text(1), "");
}

TEST(FrictionCheck, ASpinTheOtherWayRoundIsNamed) {
  // The true constants with the spin reversed (validate): the measured friction is minus
  // the predicted one.
  const auto res = check(-1.0);
  EXPECT_NEAR(res.scale, -1.0, 0.01);
  EXPECT_TRUE(res.reversed());
  const std::string t = res.text(1);
  EXPECT_NE(t.find("-1 times"), std::string::npos) << t;
  EXPECT_NE(t.find("spin_sign = +1"), std::string::npos) << t;
  // A fit that drove μ to its lower bound (0.01 against 0.4): −40 times.
  EXPECT_NEAR(check(-40.0).scale, -40.0, 0.1);
  EXPECT_TRUE(check(-40.0).reversed());
}

TEST(FrictionCheck, FrictionWeakerOrStrongerThanPredictedIsNotNamed) {
  // μ off (or at its upper bound) scales the friction; only a reversal is named.
  for (const double s : {0.0, -0.3, 0.5, 2.0, 10.0}) {
    const auto res = check(s);
    EXPECT_NEAR(res.scale, s, 0.01) << s;
    EXPECT_FALSE(res.reversed()) << s;
  }
}

TEST(FrictionCheck, ResidualsAgainstABruteForceSum) {
  const Recording a = recording(-0.7, glm::dvec3(0.1, 0, 0), 3), b = recording(-0.7, glm::dvec3(0, 0.2, -0.1), 4);
  bc::FrictionDirectionCheck c;
  c.add(a.predicted, a.friction, a.measured, a.mask, a.weight);
  c.add(b.predicted, b.friction, b.measured, b.mask, b.weight);
  const auto res = c.result();
  ASSERT_TRUE(res);
  // Brute force: each recording's used samples about its own means; β by a scan of
  // Σ|r − β f|², then the residual sums at β = 0 and at the best β.
  auto centred = [](const Recording& r, std::vector<glm::dvec3>& rs, std::vector<glm::dvec3>& fs) {
    glm::dvec3 rm(0), fm(0);
    std::size_t n = 0;
    for (std::size_t j = 0; j < r.measured.size(); ++j)
      if (r.weight[j] > 0 && r.mask[j]) {
        rm += r.measured[j] - r.predicted[j];
        fm += r.friction[j];
        ++n;
      }
    for (std::size_t j = 0; j < r.measured.size(); ++j)
      if (r.weight[j] > 0 && r.mask[j]) {
        rs.push_back(r.measured[j] - r.predicted[j] - rm / double(n));
        fs.push_back(r.friction[j] - fm / double(n));
      }
  };
  std::vector<glm::dvec3> rs, fs;
  centred(a, rs, fs);
  centred(b, rs, fs);
  auto rss = [&](double beta) {
    double s = 0;
    for (std::size_t j = 0; j < rs.size(); ++j) {
      const glm::dvec3 d = rs[j] - beta * fs[j];
      s += glm::dot(d, d);
    }
    return s;
  };
  double best = 0, best_rss = rss(0);
  for (double beta = -3; beta <= 1; beta += 1e-4)
    if (const double v = rss(beta); v < best_rss) best = beta, best_rss = v;
  EXPECT_EQ(res->samples, rs.size());
  EXPECT_NEAR(res->scale, 1 + best, 1e-4);
  EXPECT_NEAR(res->residual_as_predicted_N2, rss(0), 1e-9 * rss(0));
  EXPECT_NEAR(res->residual_scaled_N2, best_rss, 1e-6 * best_rss);
  EXPECT_NEAR(res->residual_without_friction_N2, rss(-1), 1e-9 * rss(-1));
  EXPECT_NEAR(res->scale, -0.7, 0.01);
}

TEST(FrictionCheck, TooFewSamplesOrNoFrictionSayNothing) {
  bc::FrictionDirectionCheck few;
  const Recording r = recording(-1.0, glm::dvec3(0), 5, 40);  // 40 samples, 27 used in contact
  few.add(r.predicted, r.friction, r.measured, r.mask, r.weight);
  EXPECT_FALSE(few.result());
  bc::FrictionDirectionCheck none;
  Recording z = recording(1.0, glm::dvec3(0), 6);
  for (auto& f : z.friction) f = glm::dvec3(0);
  none.add(z.predicted, z.friction, z.measured, z.mask, z.weight);
  EXPECT_FALSE(none.result());
}

TEST(FrictionCheck, OfTwoChecksThatNameAMismatchTheBetterFitIsSaid) {
  // A reversed spin also reads as a mirror in the friction's plane, a mirrored sensor as
  // reversed friction: where both name one, the smaller residual decides.
  bc::SensorFrameCheck::Result frame;
  frame.mirrored = true;
  frame.angle_deg = 180;
  frame.samples = 1000;
  frame.residual_as_given_N2 = 30;
  const auto friction = check(-1.0);
  ASSERT_TRUE(friction.reversed());
  ASSERT_GT(friction.residual_scaled_N2, 0.5);
  const glm::dmat3 I(1.0);
  auto said = [&](double frame_after) {
    frame.residual_turned_N2 = frame_after;
    EXPECT_TRUE(frame.mismatch());
    const auto lines = bc::frame_and_friction_lines(frame, friction, I, -1);
    EXPECT_EQ(lines.size(), 1u);
    return lines.empty() ? std::string() : lines[0];
  };
  EXPECT_NE(said(friction.residual_scaled_N2 * 1.2).find("predicted friction"), std::string::npos);
  EXPECT_NE(said(friction.residual_scaled_N2 * 0.8).find("fits the prediction best mirrored"), std::string::npos);
  // Either alone is said; neither, nothing.
  EXPECT_EQ(bc::frame_and_friction_lines(std::nullopt, friction, I, 1).size(), 1u);
  EXPECT_EQ(bc::frame_and_friction_lines(frame, std::nullopt, I, 1).size(), 1u);
  EXPECT_TRUE(bc::frame_and_friction_lines(std::nullopt, check(1.0), I, 1).empty());
}
