// A constant that moves with one at its bound (uncertainty.hpp shift_along_bound): the
// shift against a second way to the same number — minimising the quadratic cost with the
// partner moved by its own 95 % half-width, from the information matrix instead of the
// covariance — and the reason that names the partner, its bound and the entry to widen.
#include <cmath>

#include <glm/glm.hpp>
#include <gtest/gtest.h>

#include "burrbench/calibration/uncertainty.hpp"

namespace bc = burrbench::calibration;
namespace ds = burrbench::data_schema;

namespace {

constexpr double kZ95 = 1.959963984540054;

// A covariance over x entries {0, 1, 2} from an information matrix H (the covariance is H⁻¹).
bc::CovarianceOutcome outcome(const glm::dmat3& H) {
  bc::CovarianceOutcome c;
  c.ok = true;
  c.indices = {0, 1, 2};
  const glm::dmat3 S = glm::inverse(H);
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) c.cov.push_back(S[b][a]);
  return c;
}

// min over the others of ½ ΔᵀHΔ with Δ_j = δ: H_oo Δ_o = −H_oj δ; returns Δ_i.
double moved_by(const glm::dmat3& H, int i, int j, double delta) {
  int o[2], n = 0;
  for (int k = 0; k < 3; ++k)
    if (k != j) o[n++] = k;
  glm::dmat2 Hoo;
  glm::dvec2 Hoj;
  for (int a = 0; a < 2; ++a) {
    Hoj[a] = H[j][o[a]];
    for (int b = 0; b < 2; ++b) Hoo[b][a] = H[o[b]][o[a]];
  }
  const glm::dvec2 d = glm::inverse(Hoo) * (-Hoj * delta);
  return d[o[0] == i ? 0 : 1];
}

glm::dmat3 information() {
  const glm::dmat3 A(3.0, 1.2, -0.4, 0.7, 2.0, 0.9, -1.1, 0.3, 1.5);
  return glm::transpose(A) * A;  // positive definite, every pair correlated
}

}  // namespace

TEST(BoundPartners, TheShiftIsTheQuadraticCostsMoveOfTheOthers) {
  const glm::dmat3 H = information();
  const bc::CovarianceOutcome c = outcome(H);
  const glm::dmat3 S = glm::inverse(H);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) {
      if (i == j) continue;
      const double half_j = kZ95 * std::sqrt(S[j][j]);  // the partner's own 95 % half-width
      EXPECT_NEAR(bc::shift_along_bound(c, std::size_t(i), std::size_t(j)), std::abs(moved_by(H, i, j, half_j)),
                  1e-12)
          << i << " along " << j;
    }
}

TEST(BoundPartners, NoShiftWithoutBothEntriesOrACovariance) {
  bc::CovarianceOutcome c = outcome(information());
  EXPECT_TRUE(std::isnan(bc::shift_along_bound(c, 0, 0)));
  EXPECT_TRUE(std::isnan(bc::shift_along_bound(c, 0, 7)));  // not in the covariance
  EXPECT_TRUE(std::isnan(bc::shift_along_bound(c, 7, 0)));
  c.ok = false;
  EXPECT_TRUE(std::isnan(bc::shift_along_bound(c, 0, 1)));
}

TEST(BoundPartners, AnUncorrelatedPartnerMovesNothing) {
  glm::dmat3 H(0.0);
  H[0][0] = 4.0, H[1][1] = 1.0, H[2][2] = 9.0;
  EXPECT_EQ(bc::shift_along_bound(outcome(H), 0, 1), 0.0);
}

TEST(BoundPartners, TheReasonNamesThePartnerItsBoundAndWhatToWiden) {
  ds::ClassFitSpec spec;
  spec.alpha = {500, 1.0, 300, false};
  spec.c1 = {16, 1e-2, 1e4, false};
  spec.mu = {0.4, 1e-2, 3.0, false};
  const bc::Layout L({{1, {"compact", spec}}}, {}, ds::NuisanceSpec{}, 0.5);
  std::vector<double> x = L.initial();
  std::size_t alpha = 0;
  for (const auto& p : L.physics())
    if (p.kind == bc::PhysKind::kAlpha) alpha = std::size_t(p.index);
  x[alpha] = L.upper(alpha);
  const std::string why = bc::bound_partner_reason(L, x, alpha, std::log(1.031), std::log(1.00643));
  EXPECT_NE(why.find("moves with compact.alpha, which ended at its upper bound (300 N/mm^2)"), std::string::npos) << why;
  EXPECT_NE(why.find("about 3.1 %"), std::string::npos) << why;
  EXPECT_NE(why.find("±0.643 %"), std::string::npos) << why;
  EXPECT_NE(why.find("widen [fit.classes.compact] alpha"), std::string::npos) << why;
}
