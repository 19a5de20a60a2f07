// The linearised fit with the bounds the data push against lifted (uncertainty.hpp
// step_past_bounds): the step against the quadratic model it minimises (its gradient
// vanishes there, checked by multiplying out, not by the inverse the step uses), entries
// pulled inwards or missing from the covariance, and the reason that names the partners,
// the move and what to widen.
#include <cmath>

#include <glm/glm.hpp>
#include <gtest/gtest.h>

#include "burrbench/calibration/uncertainty.hpp"

namespace bc = burrbench::calibration;
namespace ds = burrbench::data_schema;

namespace {

constexpr double kScale = 2.0 * 1.5;  // residual variance × inflation

// The covariance over x entries {0, 1, 2} of information matrix H, and gradient g.
bc::CovarianceOutcome outcome(const glm::dmat3& H, const glm::dvec3& g) {
  bc::CovarianceOutcome c;
  c.ok = true;
  c.indices = {0, 1, 2};
  c.residual_variance = 2.0;
  c.inflation = 1.5;
  const glm::dmat3 S = glm::inverse(H) * kScale;
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) c.cov.push_back(S[b][a]);
  c.gradient = {g[0], g[1], g[2]};
  return c;
}

glm::dmat3 information() {
  const glm::dmat3 A(3.0, 1.2, -0.4, 0.7, 2.0, 0.9, -1.1, 0.3, 1.5);
  return glm::transpose(A) * A;  // positive definite, every pair correlated
}

glm::dvec3 vec(const std::vector<double>& v) { return {v.at(0), v.at(1), v.at(2)}; }

}  // namespace

TEST(BoundPartners, TheStepMinimisesTheQuadraticModelOfThePulledGradient) {
  const glm::dmat3 H = information();
  // Entry 1 at its upper bound with the cost falling upwards (pulled out); the gradient of
  // the others, stationary at an optimum, is left out of the step whatever it is.
  const glm::dvec3 g(0.3, -2.0, 0.7);
  std::vector<bc::AtBound> pulled;
  const auto step = bc::step_past_bounds(outcome(H, g), {{1, +1}}, 3, &pulled);
  ASSERT_EQ(step.size(), 3u);
  ASSERT_EQ(pulled.size(), 1u);
  EXPECT_EQ(pulled[0].entry, 1u);
  EXPECT_EQ(pulled[0].side, +1);
  // ∇(gᵀ_B Δ + ½ ΔᵀHΔ) = g_B + HΔ = 0.
  const glm::dvec3 r = glm::dvec3(0.0, g[1], 0.0) + H * vec(step);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r[k], 0.0, 1e-12) << k;
  EXPECT_GT(step[1], 0.0);  // beyond the upper bound
}

TEST(BoundPartners, TwoPulledEntriesMoveTogether) {
  const glm::dmat3 H = information();
  const glm::dvec3 g(1.5, -2.0, 0.7);  // 0 at its lower bound pulled down, 1 at its upper pulled up
  std::vector<bc::AtBound> pulled;
  const auto step = bc::step_past_bounds(outcome(H, g), {{0, -1}, {1, +1}}, 3, &pulled);
  ASSERT_EQ(pulled.size(), 2u);
  EXPECT_EQ(pulled[0].entry, 0u);
  EXPECT_EQ(pulled[0].side, -1);
  EXPECT_EQ(pulled[1].entry, 1u);
  const glm::dvec3 r = glm::dvec3(g[0], g[1], 0.0) + H * vec(step);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(r[k], 0.0, 1e-12) << k;
}

TEST(BoundPartners, AnEntryPulledInwardsOrMissingGivesNoStep) {
  const glm::dmat3 H = information();
  std::vector<bc::AtBound> pulled{{9, +1}};
  // At its upper bound with the cost rising upwards: the optimum lies inside, not held.
  EXPECT_TRUE(bc::step_past_bounds(outcome(H, {0, 2.0, 0}), {{1, +1}}, 3, &pulled).empty());
  EXPECT_TRUE(pulled.empty());
  EXPECT_TRUE(bc::step_past_bounds(outcome(H, {0, 2.0, 0}), {{7, +1}}, 3).empty());  // not covered
  bc::CovarianceOutcome failed = outcome(H, {0, -2.0, 0});
  failed.ok = false;
  EXPECT_TRUE(bc::step_past_bounds(failed, {{1, +1}}, 3).empty());
}

TEST(BoundPartners, AnUncorrelatedEntryDoesNotMove) {
  glm::dmat3 H(0.0);
  H[0][0] = 4.0, H[1][1] = 1.0, H[2][2] = 9.0;
  const auto step = bc::step_past_bounds(outcome(H, {0, -2.0, 0}), {{1, +1}}, 3);
  ASSERT_EQ(step.size(), 3u);
  EXPECT_EQ(step[0], 0.0);
  EXPECT_EQ(step[2], 0.0);
  EXPECT_NEAR(step[1], 2.0, 1e-12);  // −g/H
}

TEST(BoundPartners, TheReasonNamesThePartnersTheMoveAndWhatToWiden) {
  ds::ClassFitSpec spec;
  spec.alpha = {500, 1.0, 300, false};
  spec.c1 = {16, 1e-2, 1e4, false};
  spec.mu = {0.4, 1e-2, 3.0, false};
  ds::NuisanceSpec nz;
  nz.lag = true;
  const bc::Layout L({{1, {"compact", spec}}}, {{"sweep", 0.0}}, nz, 0.5);
  std::vector<double> x = L.initial();
  std::size_t alpha = 0, mu = 0;
  for (const auto& p : L.physics()) {
    if (p.kind == bc::PhysKind::kAlpha) alpha = std::size_t(p.index);
    if (p.kind == bc::PhysKind::kMu) mu = std::size_t(p.index);
  }
  const std::size_t lag = std::size_t(L.recordings().at(0).lag);
  x[alpha] = L.upper(alpha);
  x[lag] = L.upper(lag);
  const std::string why = bc::bound_partner_reason(L, x, mu, {{alpha, +1}}, std::log(1.031), std::log(1.008));
  EXPECT_EQ(why.rfind("moves with compact.alpha (at its upper bound, 300 N/mm^2), which the data pull beyond its bound", 0), 0u) << why;
  EXPECT_NE(why.find("moves this constant by +3.1 % (to about 0.4124)"), std::string::npos) << why;
  EXPECT_NE(why.find("±0.8 %"), std::string::npos) << why;
  EXPECT_NE(why.find("widen [fit.classes.compact] alpha"), std::string::npos) << why;
  const std::string both = bc::bound_partner_reason(L, x, mu, {{alpha, +1}, {lag, +1}}, std::log(2.36), std::log(1.01));
  EXPECT_NE(both.find("compact.alpha (at its upper bound, 300 N/mm^2) and sweep.lag (at its upper bound: see the "
                      "warnings), which the data pull beyond their bounds"), std::string::npos) << both;
  EXPECT_NE(both.find("up by a factor of 2.36"), std::string::npos) << both;
  EXPECT_NE(both.find("widen [fit.classes.compact] alpha, [fit.nuisance] lag_bounds_ms"), std::string::npos) << both;
  const std::string far = bc::bound_partner_reason(L, x, mu, {{lag, +1}}, -51.8, std::log(1.02));
  EXPECT_NE(far.find("down by more than a factor of 1000"), std::string::npos) << far;
  EXPECT_EQ(far.find("to about"), std::string::npos) << far;
  EXPECT_NE(far.find("widen [fit.nuisance] lag_bounds_ms"), std::string::npos) << far;
  x[alpha] = L.lower(alpha);  // the side is the one given, as held_at_bounds found it
  const std::string low = bc::bound_partner_reason(L, x, mu, {{alpha, -1}}, std::log(0.9), std::log(1.01));
  EXPECT_EQ(low.rfind("moves with compact.alpha (at its lower bound, 1 N/mm^2)", 0), 0u) << low;
  EXPECT_NE(low.find("by -10 %"), std::string::npos) << low;
}
