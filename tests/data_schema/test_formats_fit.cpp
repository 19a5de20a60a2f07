// Fit result (JSON): round trip with NaN (null) and ∞, strict keys and versions.
#include <cmath>
#include <cstring>

#include "burrbench/data_schema/fit_result.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::test::expect_input_error;
using burrbench::test::TempDir;

namespace {

bb::FitResult make_fit() {
  bb::FitResult f;
  f.parameters = {{1, "compact", "c1", "N/mm^2", 12.000000000000002, 0.5, 11.0, 13.0, 10.9, 13.2, false, true, ""},
                  {1, "compact", "alpha", "N/mm^2", INFINITY, bb::kNaN, bb::kNaN, bb::kNaN, bb::kNaN, bb::kNaN, true,
                   true, ""},
                  {2, "trabecular", "mu", "1", bb::kNaN, bb::kNaN, bb::kNaN, bb::kNaN, bb::kNaN, bb::kNaN, false,
                   false, "no trabecular contact in any segment"}};
  // 1.2: the discretization check of the first parameter (limited, widened interval).
  f.parameters[0].coarse_estimate = 15.5;
  f.parameters[0].discretization_error_log = 0.2578;
  f.parameters[0].limited_by_discretization = true;
  f.parameters[0].ci95_with_discretization_low = 8.48;
  f.parameters[0].ci95_with_discretization_high = bb::kNaN;
  f.nuisance = {{"plunge", "bias_x", "N", -0.0123, 0.001, -0.014, -0.010, false},
                {"plunge", "lag", "ms", 2.0, bb::kNaN, bb::kNaN, bb::kNaN, true}};
  f.covariance = {{"c1", "mu"}, {0.25, -1e-310, -1e-310, 1e-4}};
  f.correlation = {{"c1", "mu"}, {1.0, bb::kNaN, bb::kNaN, 1.0}};
  f.residuals_summary = {1000, 20, 5, 0.02, 1.05};
  f.solver = {12, 100.0, 1.0 / 3.0, 0.5, 40, "CONVERGENCE: relative decrease", 4};
  f.cross_validation = {{"sweep", {{"rmse_N", 0.05}, {"bias_N", {0.1, 0.2, 0.3}}}}};
  f.metrics = {{"r2", 0.98}, {"nested", {{"a", "b"}}}};
  f.settings = {{"loss", "huber"}, {"buried", "exclude"}};
  f.experiment_path = "/x/E.toml";
  f.experiment_sha256 = std::string(64, 'f');
  f.provenance = burrbench::make_provenance({});
  return f;
}

bool same(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0 || (std::isnan(a) && std::isnan(b)); }

}  // namespace

TEST(FormatsFit, RoundTripKeepsEveryValue) {
  TempDir dir;
  const auto a = make_fit();
  bb::write_fit(dir / "f.json", a);
  const std::string text = burrbench::test::file_bytes(dir / "f.json");
  EXPECT_NE(text.find("\"estimate\": null"), std::string::npos);  // NaN → null
  EXPECT_NE(text.find("\"estimate\": \"inf\""), std::string::npos);
  const auto b = bb::read_fit(dir / "f.json");
  ASSERT_EQ(b.parameters.size(), a.parameters.size());
  for (std::size_t i = 0; i < a.parameters.size(); ++i) {
    const auto &p = a.parameters[i], &q = b.parameters[i];
    EXPECT_EQ(q.class_id, p.class_id);
    EXPECT_EQ(q.class_name, p.class_name);
    EXPECT_EQ(q.name, p.name);
    EXPECT_EQ(q.unit, p.unit);
    for (auto [x, y] : {std::pair{p.estimate, q.estimate}, {p.std_error, q.std_error}, {p.ci95_low, q.ci95_low},
                        {p.ci95_high, q.ci95_high}, {p.bootstrap_ci95_low, q.bootstrap_ci95_low},
                        {p.bootstrap_ci95_high, q.bootstrap_ci95_high}})
      EXPECT_TRUE(same(x, y)) << p.name << " " << x << " vs " << y;
    EXPECT_EQ(q.fixed, p.fixed);
    EXPECT_EQ(q.identifiable, p.identifiable);
    EXPECT_EQ(q.reason, p.reason);
    for (auto [x, y] : {std::pair{p.coarse_estimate, q.coarse_estimate},
                        {p.discretization_error_log, q.discretization_error_log},
                        {p.ci95_with_discretization_low, q.ci95_with_discretization_low},
                        {p.ci95_with_discretization_high, q.ci95_with_discretization_high}})
      EXPECT_TRUE(same(x, y)) << p.name << " " << x << " vs " << y;
    EXPECT_EQ(q.limited_by_discretization, p.limited_by_discretization);
  }
  // Parameters without a check carry no "discretization" object.
  EXPECT_EQ(text.find("\"discretization\""), text.rfind("\"discretization\""));
  ASSERT_EQ(b.nuisance.size(), 2u);
  EXPECT_EQ(b.nuisance[0].estimate, -0.0123);
  EXPECT_TRUE(b.nuisance[1].fixed);
  EXPECT_EQ(b.covariance.names, a.covariance.names);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_TRUE(same(b.covariance.matrix[i], a.covariance.matrix[i]));
    EXPECT_TRUE(same(b.correlation.matrix[i], a.correlation.matrix[i]));
  }
  EXPECT_EQ(b.residuals_summary.samples_buried, 20u);
  EXPECT_EQ(b.residuals_summary.rms_normalised, 1.05);
  EXPECT_EQ(b.solver.final_cost, 1.0 / 3.0);
  EXPECT_EQ(b.solver.termination, a.solver.termination);
  EXPECT_EQ(b.solver.multistart, 4u);
  ASSERT_EQ(b.cross_validation.size(), 1u);
  EXPECT_EQ(b.cross_validation[0].metrics, a.cross_validation[0].metrics);
  EXPECT_EQ(b.metrics, a.metrics);
  EXPECT_EQ(b.settings, a.settings);
  EXPECT_EQ(b.experiment_sha256, a.experiment_sha256);
  EXPECT_EQ(b.provenance.software_version, a.provenance.software_version);
  // A parameter set from the estimates.
  auto ok = a;
  ok.parameters[2] = {2, "trabecular", "mu", "1", 0.2, 0.01, 0.18, 0.22, bb::kNaN, bb::kNaN, false, true, ""};
  ok.parameters.push_back({2, "trabecular", "c1", "N/mm^2", 3.0, 0.1, 2.8, 3.2, bb::kNaN, bb::kNaN, false, true, ""});
  ok.parameters.push_back({1, "compact", "mu", "1", 0.3, 0.01, 0.28, 0.32, bb::kNaN, bb::kNaN, false, true, ""});
  const auto ps = bb::parameter_set_from(ok, "f.json");
  EXPECT_EQ(ps.classes.at(1).c1_N_per_mm2, 12.000000000000002);
  EXPECT_TRUE(std::isinf(ps.classes.at(1).alpha_N_per_mm2));
  EXPECT_EQ(ps.classes.at(2).mu, 0.2);
}

TEST(FormatsFit, BadFilesAreRejected) {
  TempDir dir;
  bb::write_fit(dir / "f.json", make_fit());
  const std::string good = burrbench::test::file_bytes(dir / "f.json");
  auto bad = [&](const std::string& from, const std::string& to, std::initializer_list<std::string> frags) {
    std::string text = good;
    const auto pos = text.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    text.replace(pos, from.size(), to);
    burrbench::test::write_text(dir / "F.json", text);
    burrbench::test::expect_rejected_unchanged(dir / "F.json", [&] { bb::read_fit(dir / "F.json"); }, frags);
  };
  bad("\"format_version\": \"1.3\"", "\"format_version\": \"2.0\"", {"F.json: format_version", "unknown major version"});
  bad("\"format_version\": \"1.3\"", "\"format_version\": \"1.3\", \"extra\": 1", {"F.json: extra: expected a known key"});
  bad("\"limited\": true", "\"limited\": 1", {"F.json: parameters[0].discretization.limited"});
  bad("\"coarse_estimate\": 15.5", "\"coarse_estimate\": 15.5, \"typo\": 0", {"F.json: parameters[0].discretization.typo"});
  bad("\"samples_used\": 1000", "\"samples_used\": 1000, \"x\": 2", {"residuals_summary.x", "known key"});
  bad("\"samples_used\": 1000", "\"samples_used\": -5", {"residuals_summary.samples_used", "non-negative integer"});
  bad("\"name\": \"c1\"", "\"name\": \"c2\"", {"parameters[0].name: expected alpha | c1 | mu"});
  bad("\"estimate\": 12.000000000000002", "\"estimate\": null", {"parameters[0].estimate", "identifiable"});
  bad("\"estimate\": 12.000000000000002", "\"estimate\": \"twelve\"", {"parameters[0].estimate"});
  bad("\"format\": \"burrbench.fit\"", "\"format\": \"burrbench.fitt\"", {"F.json: format: expected \"burrbench.fit\""});
  bad("\"termination\"", "\"termination\" \"", {"F.json", "valid JSON"});
  bad("\"matrix\": [", "\"matrix\": [1.0, ", {"correlation.matrix", "2×2 values"});
  // Beyond double's range: nlohmann throws out_of_range, not parse_error (found by fuzz_fit_json).
  bad("\"samples_used\": 1000", "\"samples_used\": 1e956349715",
      {"F.json: <file>: expected valid JSON with numbers in double's range", "number overflow"});
}

// Seeded corruption of a valid file: every outcome is a result or an InputError.
TEST(FormatsFit, CorruptedFilesOnlyEverRaiseInputError) {
  TempDir dir;
  bb::write_fit(dir / "f.json", make_fit());
  const std::string base = burrbench::test::file_bytes(dir / "f.json");
  const int rejected = burrbench::test::count_rejected_corruptions(
      base, dir / "c.json", 300, 777, 3, true, [](const auto& p) { bb::read_fit(p); });
  EXPECT_GT(rejected, 150);
}

// `calibrate`'s summary and `inspect fit.json` print each constant through one function:
// the value held and why, the profile interval (an open side reads "open"), the covariance
// interval with its SE, and the discretization limit.
TEST(FormatsFit, AParameterReadsAsTheCalibrationLeftIt) {
  bb::FitParameter p;
  p.class_name = "compact";
  p.name = "alpha";
  p.unit = "N/mm^2";
  p.estimate = p.held = 503.1;
  p.std_error = 4.17;
  p.ci95_low = 495.0;
  p.ci95_high = 511.3;
  p.profile = nlohmann::json::array({{{"value", 500.0}}});
  p.profile_ci95_low = 494.9;
  p.profile_ci95_high = 511.2;
  p.verdict = "identifiable";
  EXPECT_EQ(bb::describe_fit_parameter(p),
            "  compact      alpha = 503.1 N/mm^2 profile 95 % [494.9, 511.2]; covariance [495, 511.3] (SE 4.17)\n");

  p.limited_by_discretization = true;
  p.coarse_estimate = 450.0;
  p.ci95_with_discretization_low = 440.0;
  p.ci95_with_discretization_high = 560.0;
  EXPECT_NE(bb::describe_fit_parameter(p, 0.2).find(
                "  compact      alpha   LIMITED by discretization error: 450 at voxel 0.2 mm; with that error [440, 560]\n"),
            std::string::npos);
  EXPECT_NE(bb::describe_fit_parameter(p).find("450 at twice the voxel;"), std::string::npos);
  p.ci95_with_discretization_low = p.ci95_with_discretization_high = bb::kNaN;  // the refit ran into its bound
  EXPECT_NE(bb::describe_fit_parameter(p, 0.2).find("the refit at voxel 0.2 mm ran into its bound"), std::string::npos);

  bb::FitParameter m;
  m.class_name = "trabecular";
  m.name = "mu";
  m.unit = "1";
  m.held = 0.3;
  m.identifiable = false;
  m.verdict = "practically_non_identifiable";
  m.reason = "the profile stays flat towards the lower bound";
  m.profile = nlohmann::json::array({{{"value", 0.3}}});
  m.profile_ci95_high = 0.52;  // open below
  EXPECT_EQ(bb::describe_fit_parameter(m),
            "  trabecular   mu      NOT identifiable (practically) (held 0.3): the profile stays flat towards the lower bound\n"
            "  trabecular   mu      profile 95 % [open, 0.52]\n");
  m.verdict = "conditional_on_bound";
  m.reason = "moves with trabecular.alpha (at its upper bound, 300 N/mm^2), which the data pull beyond its bound";
  m.profile_ci95_low = 0.28;
  EXPECT_EQ(bb::describe_fit_parameter(m),
            "  trabecular   mu      CONDITIONAL on a bound (held 0.3): moves with trabecular.alpha (at its upper bound, "
            "300 N/mm^2), which the data pull beyond its bound\n"
            "  trabecular   mu      profile 95 % [0.28, 0.52]\n");
  m.fixed = true;
  m.estimate = 0.3;
  EXPECT_EQ(bb::describe_fit_parameter(m), "  trabecular   mu    = 0.3 (fixed)\n");
}
