// The held-out case of issue 10 (layered_fixture.hpp): one recording calibrates on its
// plunge and sweep and validates on its polish. No constant may come back as a confident
// miss: each recovers the truth (C1 2 %, μ 5 %, α 10 %, its profile interval holding it)
// or is reported not identifiable, with a [fit] section and with every default.
#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "layered_fixture.hpp"

namespace fs = std::filesystem;
namespace ds = burrbench::data_schema;
using burrbench::calibration::testing::LayeredSpec;
using burrbench::calibration::testing::make_layered_experiment;

namespace {

std::string cli() { return burrbench::calibration::testing::burrbench_cli(); }

fs::path scratch(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / fmt::format("bb_heldout_{}_{}", name, ::getpid());
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

int calibrate(const fs::path& manifest, const fs::path& out, std::string& log) {
  const fs::path lf = out.string() + ".log";
  const std::string cmd = fmt::format("'{}' calibrate '--experiment={}' --out '{}' --no-cross-validation > '{}' 2>&1",
                                      cli(), manifest.string(), out.string(), lf.string());
  const int st = std::system(cmd.c_str());
  std::ifstream f(lf);
  std::stringstream ss;
  ss << f.rdbuf();
  log = ss.str();
  return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
}

// Every free constant: a recovered truth with an interval holding it, or "not identifiable".
void expect_no_confident_miss(const ds::FitResult& fit, const LayeredSpec& s) {
  struct Truth { int label; const char* name; double value, tol; };
  const Truth truth[] = {{1, "alpha", s.alpha1, 0.10}, {1, "c1", s.c1_1, 0.02}, {1, "mu", s.mu1, 0.05},
                         {2, "alpha", s.alpha2, 0.10}, {2, "c1", s.c1_2, 0.02}, {2, "mu", s.mu2, 0.05}};
  for (const auto& t : truth) {
    const ds::FitParameter* p = fit.parameter(std::uint8_t(t.label), t.name);
    ASSERT_NE(p, nullptr) << t.name;
    std::printf("  %-10s %-5s truth %-8.4g %s: held %.6g (%+.2f %%), profile [%.6g, %.6g], covariance [%.6g, %.6g]%s%s\n",
                p->class_name.c_str(), t.name, t.value, p->verdict.c_str(), p->held,
                100 * (p->held / t.value - 1), p->profile_ci95_low, p->profile_ci95_high, p->ci95_low,
                p->ci95_high, p->reason.empty() ? "" : ": ", p->reason.c_str());
    EXPECT_FALSE(p->verdict.empty());
    EXPECT_TRUE(std::isfinite(p->held)) << "fit.json stores the held value";
    if (!p->identifiable) {
      EXPECT_FALSE(p->reason.empty());
      EXPECT_TRUE(std::isnan(p->estimate)) << "no confident number for " << t.name;
      continue;
    }
    EXPECT_NEAR(p->estimate / t.value, 1.0, t.tol) << p->class_name << "." << t.name << " is a confident miss";
    const double lo = std::isnan(p->profile_ci95_low) ? 0 : p->profile_ci95_low;
    const double hi = std::isnan(p->profile_ci95_high) ? INFINITY : p->profile_ci95_high;
    EXPECT_LE(lo, t.value) << p->class_name << "." << t.name << ": interval misses the truth";
    EXPECT_GE(hi, t.value) << p->class_name << "." << t.name << ": interval misses the truth";
  }
}

void run_case(const std::string& name, const LayeredSpec& s) {
  const fs::path dir = scratch(name);
  const fs::path m = make_layered_experiment(dir, s, cli());
  std::string log;
  ASSERT_EQ(calibrate(m, dir / "out", log), 0) << log;
  const ds::FitResult fit = ds::read_fit(dir / "out" / "fit.json");
  std::printf("%s: best optimum reached by %d of %d starts\n", name.c_str(),
              fit.settings["global_search"]["reached_best"].get<int>(), int(fit.solver.multistart));
  expect_no_confident_miss(fit, s);
  // With more than one start, the starts' local solves stop at a tenth of the profile
  // threshold relative to the cost at the optimum: 0.1·(χ²₁(0.95)/2)/(residuals/2), never
  // below Ceres's 1e-7. Residuals: 3 per sample of weight > 0, counted before any replay,
  // so buried samples (which the default policy then excludes) count too.
  ASSERT_GT(fit.solver.multistart, 1u);
  ASSERT_EQ(fit.settings["buried"].get<std::string>(), "exclude");
  const double used = 3.0 * double(fit.residuals_summary.samples_used + fit.residuals_summary.samples_buried);
  const double tol = fit.settings["global_search"]["local_function_tolerance"].get<double>();
  EXPECT_NEAR(tol, std::max(1e-7, 0.1 * 3.841458820694124 / used), 1e-3 * tol);
  // The polish validates with the recording's own fitted lag and bias.
  ASSERT_TRUE(fit.metrics.contains("validation")) << fit.metrics.dump();
  EXPECT_GT(fit.metrics["validation"]["samples"].get<int>(), 1000);
  EXPECT_LT(fit.metrics["validation"]["rmse_xyz_N"].get<double>(), 2.5 * s.noise_N);
  EXPECT_EQ(fit.multistart.size(), fit.solver.multistart) << "every end point is kept";
  // params.toml holds what the fit held, flagged where not identifiable; never a start value.
  const auto ps = ds::read_params(dir / "out" / "params.toml");
  for (const auto& p : fit.parameters) {
    const auto& c = ps.classes.at(p.class_id);
    const double v = p.name == "alpha" ? c.alpha_N_per_mm2 : p.name == "c1" ? c.c1_N_per_mm2 : c.mu;
    EXPECT_DOUBLE_EQ(v, p.held) << p.class_name << "." << p.name;
    const auto it = ps.not_identifiable.find(p.class_id);
    const bool flagged = it != ps.not_identifiable.end() &&
                         std::find(it->second.begin(), it->second.end(), p.name) != it->second.end();
    EXPECT_EQ(flagged, !p.identifiable) << p.class_name << "." << p.name;
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

}  // namespace

TEST(CalibrateHeldOut, PolishValidatesPlungeAndSweepCalibrate) {
  run_case("fit", LayeredSpec{});
}

TEST(CalibrateHeldOut, SameWithoutAFitSection) {
  LayeredSpec s;
  s.fit_section = false;
  run_case("defaults", s);
}
