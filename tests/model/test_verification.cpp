// Richardson extrapolation of the convergence study against a closed form.
#include <gtest/gtest.h>

#include <cmath>

#include "burrbench/model/verification.hpp"

namespace {

using burrbench::model::richardson;

TEST(Verification, RichardsonRecoversOrderAndErrorOfAPowerLaw) {
  // f(h) = f0 + C·h^p at h = 0.2, 0.1, 0.05: the error at h = 0.1 is C·0.1^p.
  for (double p : {1.0, 1.5, 2.0, 3.0}) {
    const double C = -3.7, f0 = 2.0;
    auto f = [&](double h) { return f0 + C * std::pow(h, p); };
    const auto r = richardson(f(0.2) - f(0.1), f(0.1) - f(0.05));
    EXPECT_NEAR(r.order, p, 1e-12) << p;
    EXPECT_NEAR(r.error, std::abs(f(0.1) - f0), 1e-12) << p;
  }
}

TEST(Verification, RichardsonWithoutConvergenceTakesTheLargerChange) {
  // Growing or sign-changing changes: no order, the larger change is the error.
  auto r = richardson(0.01, 0.03);
  EXPECT_TRUE(std::isnan(r.order));
  EXPECT_DOUBLE_EQ(r.error, 0.03);
  r = richardson(-0.05, 0.02);
  EXPECT_TRUE(std::isnan(r.order));
  EXPECT_DOUBLE_EQ(r.error, 0.05);
  // A very fast observed order is used at most 4: factor 16/15 on the last change.
  r = richardson(1.0, 1e-3);
  EXPECT_NEAR(r.error, 1e-3 * 16 / 15, 1e-15);
}

}  // namespace
