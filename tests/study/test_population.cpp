// The population pool (study/population.hpp) against closed forms and its own promise:
// with equal standard errors DerSimonian–Laird and HKSJ reduce to the sample mean and
// variance; on simulated studies of 3 and 8 specimens its 95 % interval covers the
// population mean about 95 % of the time.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "burrbench/study/population.hpp"

namespace bs = burrbench::study;

namespace {
bs::Extracted make(const std::vector<double>& ln, const std::vector<double>& se) {
  bs::Extracted e;
  for (std::size_t i = 0; i < ln.size(); ++i) {
    bs::SpecimenEstimate s;
    s.specimen = "S" + std::to_string(i);
    s.ln_estimate = ln[i];
    s.estimate = std::exp(ln[i]);
    s.ln_se = se[i];
    e.used.push_back(s);
  }
  return e;
}
}  // namespace

TEST(Population, StudentQuantiles) {
  EXPECT_NEAR(bs::t975(1), 12.7062, 1e-4);
  EXPECT_NEAR(bs::t975(2), 4.3027, 1e-4);
  EXPECT_NEAR(bs::t975(30), 2.0423, 1e-4);
  EXPECT_NEAR(bs::t975(60), 2.0003, 2e-4);   // tables: 2.0003
  EXPECT_NEAR(bs::t975(120), 1.9799, 2e-4);  // 1.9799
  EXPECT_NEAR(bs::t975(100000), 1.95998, 1e-4);
}

TEST(Population, EqualErrorsReduceToTheSampleMeanAndVariance) {
  const std::vector<double> ln{std::log(480.0), std::log(530.0), std::log(505.0), std::log(610.0)};
  const double s = 0.01;
  const auto p = bs::pool(make(ln, std::vector<double>(4, s)), "compact", "alpha", "N/mm^2");
  double mean = 0, var = 0;
  for (double x : ln) mean += x / 4;
  for (double x : ln) var += (x - mean) * (x - mean) / 3;
  EXPECT_NEAR(p.ln_mean, mean, 1e-12);
  EXPECT_NEAR(p.tau_ln * p.tau_ln, var - s * s, 1e-12);              // DL: moment estimate
  EXPECT_NEAR(p.ln_se, std::sqrt(var / 4), 1e-12);                   // HKSJ: sample variance / k
  EXPECT_NEAR(p.ci95_low, std::exp(mean - 3.1824 * std::sqrt(var / 4)), 1e-9 * p.mean);
  EXPECT_NEAR(p.q, 3 * var / (s * s), 1e-6 * p.q);
  EXPECT_NEAR(p.i2, (p.q - 3) / p.q, 1e-12);
  EXPECT_EQ(p.k, 4u);
}

TEST(Population, AgreeingSpecimensGiveNoHeterogeneityAndTheFixedEffectInterval) {
  const auto p = bs::pool(make({1.0, 1.0 + 1e-4, 1.0 - 1e-4}, {0.05, 0.1, 0.2}), "c", "mu", "1");
  EXPECT_EQ(p.tau_ln, 0.0);
  EXPECT_EQ(p.i2, 0.0);
  const double w = 1 / 0.0025 + 1 / 0.01 + 1 / 0.04;
  EXPECT_NEAR(p.ln_se, std::sqrt(1 / w), 1e-12);  // never narrower than the DL (here fixed-effect) SE
}

TEST(Population, OneOrNoSpecimenIsNotPooled) {
  EXPECT_FALSE(bs::pool(make({2.0}, {0.1}), "c", "mu", "1").estimable());
  EXPECT_TRUE(std::isnan(bs::pool(make({}, {}), "c", "mu", "1").mean));
}

TEST(Population, IntervalsCoverThePopulationMean) {
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> se_draw(0.005, 0.05);
  for (const int k : {3, 8}) {
    int covered = 0;
    const int studies = 4000;
    for (int i = 0; i < studies; ++i) {
      std::vector<double> ln, se;
      for (int j = 0; j < k; ++j) {
        const double s = se_draw(rng);
        ln.push_back(std::log(500.0) + 0.1 * n01(rng) + s * n01(rng));  // τ = 0.1 plus each fit's error
        se.push_back(s);
      }
      const auto p = bs::pool(make(ln, se), "compact", "alpha", "N/mm^2");
      covered += p.ci95_low <= 500.0 && 500.0 <= p.ci95_high;
    }
    const double coverage = double(covered) / studies;
    EXPECT_GT(coverage, 0.93) << k << " specimens";
    EXPECT_LT(coverage, 0.985) << k << " specimens";
  }
}
