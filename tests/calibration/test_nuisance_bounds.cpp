// Nuisances that ended at a bound (parameters.hpp nuisances_at_bounds): which, which side,
// and the line that names them; one inside its bounds is not named.
#include <gtest/gtest.h>

#include "burrbench/calibration/parameters.hpp"

namespace bc = burrbench::calibration;
namespace ds = burrbench::data_schema;

namespace {

ds::ClassFitSpec compact() {
  ds::ClassFitSpec spec;
  spec.alpha = {500, 1.0, 1e5, false};
  spec.c1 = {16, 1e-2, 1e4, false};
  spec.mu = {0.4, 1e-2, 3.0, false};
  return spec;
}

bc::Layout layout() {
  ds::NuisanceSpec nz;
  nz.lag = true;
  nz.depth_offset = true;
  bc::Layout L({{1, {"compact", compact()}}}, {{"plunge", 0.0}, {"sweep", 2.0}}, nz, 0.5);
  bc::Mounting m;
  m.name = "S1";
  L.add_mounting(m, {0, 1});
  return L;
}

}  // namespace

TEST(NuisanceBounds, InsideTheBoundsNothingIsNamed) {
  const bc::Layout L = layout();
  EXPECT_TRUE(bc::nuisances_at_bounds(L, L.initial()).empty());
}

TEST(NuisanceBounds, ALagADepthAndAPoseAtTheirBoundsAreEachNamed) {
  const bc::Layout L = layout();
  std::vector<double> x = L.initial();
  const auto& sweep = L.recordings()[1];
  const auto& plunge = L.recordings()[0];
  x[std::size_t(sweep.lag)] = 20 - 1e-5;           // the solver stops a hair inside
  x[std::size_t(plunge.depth)] = -0.5;             // −R/2
  x[std::size_t(L.mountings()[0].offset + 3)] = 1;  // pose_tx at +1 mm
  x[std::size_t(plunge.lag)] = 19.9;               // 0.25 % of the range inside: not at it
  const auto at = bc::nuisances_at_bounds(L, x);
  ASSERT_EQ(at.size(), 3u);
  EXPECT_EQ(at[0].index, std::size_t(plunge.depth));
  EXPECT_FALSE(at[0].upper);
  EXPECT_EQ(at[0].text.rfind("Recording plunge: the fitted depth offset ended at its bound (-0.5 mm; |offset| ≤ R/2 = "
                             "0.5 mm)", 0), 0u) << at[0].text;
  EXPECT_EQ(at[1].index, std::size_t(sweep.lag));
  EXPECT_TRUE(at[1].upper);
  EXPECT_EQ(at[1].text.rfind("Recording sweep: the fitted lag ended at its upper bound (20 ms; [fit.nuisance] "
                             "lag_bounds_ms = [-20, 20])", 0), 0u) << at[1].text;
  EXPECT_TRUE(at[2].upper);
  EXPECT_EQ(at[2].text.rfind("Sample mounting S1: its pose correction ended at a bound (pose_tx = +1 mm, bound ±1)",
                             0), 0u) << at[2].text;
  for (const auto& a : at) EXPECT_NE(a.text.find("can miss the truth by more than their intervals say"), std::string::npos);
}

// The depth check frees a fixed depth offset after the fit (Layout::add_depth_offset): it
// becomes x's last entry, the others keep their places, and at its bound it is named too.
TEST(NuisanceBounds, ADepthOffsetFreedAfterTheFitIsTheLastEntry) {
  ds::NuisanceSpec nz;
  nz.lag = true;
  const bc::Layout L({{1, {"compact", compact()}}}, {{"plunge", 0.0}, {"sweep", 2.0}}, nz, 0.5);
  ASSERT_LT(L.recordings()[1].depth, 0);
  bc::Layout freed = L;
  freed.add_depth_offset(1);
  ASSERT_EQ(freed.size(), L.size() + 1);
  const std::size_t d = L.size();
  EXPECT_EQ(freed.recordings()[1].depth, int(d));
  EXPECT_LT(freed.recordings()[0].depth, 0);
  EXPECT_EQ(freed.name(d), "sweep.depth_offset");
  EXPECT_EQ(freed.lower(d), -0.5);
  EXPECT_EQ(freed.upper(d), 0.5);
  EXPECT_FALSE(freed.is_log(d));
  EXPECT_EQ(freed.initial()[d], 0.0);
  for (std::size_t i = 0; i < L.size(); ++i) {
    EXPECT_EQ(freed.name(i), L.name(i));
    EXPECT_EQ(freed.initial()[i], L.initial()[i]);
  }
  EXPECT_EQ(freed.blocks().back().offset, d);
  EXPECT_EQ(freed.blocks().back().size, 1u);
  std::vector<double> x = freed.initial();
  x[d] = 0.5;
  const auto at = bc::nuisances_at_bounds(freed, x);
  ASSERT_EQ(at.size(), 1u);
  EXPECT_EQ(at[0].index, d);
  EXPECT_THROW(freed.add_depth_offset(1), std::exception);  // already free
}
