// Metrics per recording, segment, axis and role: unused samples never count, and
// calibration data stays apart from held-out data.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "analysis/analysis_fixture.hpp"
#include "burrbench/analysis/criteria.hpp"
#include "burrbench/analysis/metric_table.hpp"
#include "burrbench/data_schema/error.hpp"

using namespace burrbench::analysis;

namespace {
const MetricRow& find(const std::vector<MetricRow>& rows, const std::string& rec,
                      const std::string& role, const std::string& seg, const std::string& axis) {
  for (const auto& r : rows)
    if (r.recording_id == rec && r.role == role && r.segment == seg && r.axis == axis) return r;
  throw std::runtime_error("no row " + rec + "/" + role + "/" + seg + "/" + axis);
}
}  // namespace

TEST(MetricTable, SegmentsAxesRolesAndUnusedSamples) {
  ReportData in = burrbench::testing::small_input();
  // Recording 0 (calibrate): predicted = measured except x + 1 N in the "plunge" segment
  // [0, 1) s; an unused sample carries a 1000 N error that must not count.
  auto& r0 = in.recordings[0];
  for (std::size_t i = 0; i < r0.t_s.size(); ++i) {
    r0.predicted_N[i] = r0.measured_N[i];
    if (r0.t_s[i] < 1.0) r0.predicted_N[i].x += 1.0;
  }
  r0.used[5] = 0;
  r0.predicted_N[5].x += 1000;
  const auto rows = compute_metric_rows(in);
  EXPECT_DOUBLE_EQ(find(rows, r0.id, "calibrate", "plunge", "x").m.rmse_N, 1.0);
  EXPECT_DOUBLE_EQ(find(rows, r0.id, "calibrate", "sweep", "x").m.rmse_N, 0.0);
  EXPECT_DOUBLE_EQ(find(rows, r0.id, "calibrate", "plunge", "y").m.rmse_N, 0.0);
  const auto& all = find(rows, r0.id, "calibrate", "all", "x");
  EXPECT_EQ(all.m.n, r0.t_s.size() - 1);
  EXPECT_LT(all.m.rmse_N, 1.0);
  // Pooled calibrate rows hold only recording 0; validate rows only recording 1.
  EXPECT_EQ(find(rows, "", "calibrate", "all", "z").m.n, r0.t_s.size() - 1);
  EXPECT_EQ(find(rows, "", "validate", "all", "z").m.n, in.recordings[1].t_s.size());
  EXPECT_DOUBLE_EQ(find(rows, "", "calibrate", "all", "x").m.rmse_N, all.m.rmse_N);
}

TEST(Criteria, ParseEvaluateAndReject) {
  const auto dir = burrbench::testing::temp_dir("criteria");
  const auto write = [&](const std::string& text) {
    std::ofstream(dir / "c.toml") << text;
    return dir / "c.toml";
  };
  ReportData in = burrbench::testing::small_input();
  const auto rows = compute_metric_rows(in);
  const double rmse = find(rows, "", "validate", "all", "magnitude").m.rmse_N;
  ASSERT_GT(rmse, 0);

  const auto c = read_criteria(write(fmt::format(R"(format = "burrbench.criteria"
format_version = "1.0"
[[criterion]]
name = "held-out RMSE"
metric = "rmse_N"
axis = "magnitude"
max = {}
[[criterion]]
metric = "r2"
axis = ["x", "y", "z"]
data = "calibrate"
segment = "plunge"
min = -1e9
)", rmse * 1.01)));
  auto res = evaluate_criteria(c, rows, "c.toml");
  ASSERT_EQ(res.size(), 4u);
  EXPECT_TRUE(all_pass(res));
  EXPECT_DOUBLE_EQ(res[0].value, rmse);

  const auto tight = read_criteria(write(fmt::format(R"(format = "burrbench.criteria"
format_version = "1.0"
[[criterion]]
metric = "rmse_N"
axis = "magnitude"
recording = "{}"
max = {}
)", in.recordings[1].id, rmse * 0.99)));
  res = evaluate_criteria(tight, rows, "c.toml");
  ASSERT_EQ(res.size(), 1u);
  EXPECT_FALSE(res[0].pass);
  EXPECT_FALSE(all_pass(res));

  const std::string head = "format = \"burrbench.criteria\"\nformat_version = \"1.0\"\n[[criterion]]\n";
  for (const std::string& bad : {
           head + "metric = \"rmse_N\"\naxis = \"x\"\nmax = 1\ncolour = \"red\"\n",   // unknown key
           head + "metric = \"rmsee\"\naxis = \"x\"\nmax = 1\n",                       // unknown metric
           head + "metric = \"rmse_N\"\naxis = \"w\"\nmax = 1\n",                      // unknown axis
           head + "metric = \"rmse_N\"\naxis = \"x\"\n",                               // no threshold
           head + "metric = \"rmse_N\"\naxis = \"x\"\nmin = 2\nmax = 1\n",             // min > max
           head + "metric = \"rmse_N\"\naxis = \"x\"\nmax = \"1\"\n",                  // not a number
           std::string("format = \"burrbench.criteria\"\nformat_version = \"2.0\"\n"),  // version
           std::string("format = \"burrbench.criteria\"\nformat_version = \"1.0\"\nextra = 1\n"),
           std::string("this is [ not toml"),
       }) {
    EXPECT_THROW(read_criteria(write(bad)), burrbench::InputError) << bad;
  }
  // A criterion selecting data that does not exist is bad input, not a pass.
  const auto missing = read_criteria(write(head + "metric = \"rmse_N\"\naxis = \"x\"\nsegment = \"nope\"\nmax = 1\n"));
  EXPECT_THROW(evaluate_criteria(missing, rows, "c.toml"), burrbench::InputError);
}

TEST(Criteria, UndefinedMetricFails) {
  ReportData in = burrbench::testing::small_input();
  for (auto& m : in.recordings[1].measured_N) m = glm::dvec3(1.0);  // flat: R² undefined
  const auto rows = compute_metric_rows(in);
  Criteria c;
  c.criteria.push_back({"r2", "r2", {"x"}, "all", "validate", "", -1e300, std::nullopt});
  const auto res = evaluate_criteria(c, rows, "c.toml");
  ASSERT_EQ(res.size(), 1u);
  EXPECT_TRUE(std::isnan(res[0].value));
  EXPECT_FALSE(res[0].pass);
}
