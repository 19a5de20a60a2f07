// End to end through the real CLI: `burrbench synth` makes recordings with known truth,
// `burrbench calibrate` fits them; fit.json / params.toml are read back with data_schema.
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "reference_fixture.hpp"
#include "report_metrics.hpp"

namespace fs = std::filesystem;
namespace ds = burrbench::data_schema;
using burrbench::calibration::testing::make_reference_experiment;
using burrbench::calibration::testing::pooled_calibrate_rmse_N;
using burrbench::calibration::testing::pooled_calibrate_r2_xyz;
using burrbench::calibration::testing::ReferenceSpec;

namespace {

std::string cli() { return burrbench::calibration::testing::burrbench_cli(); }

fs::path scratch(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / fmt::format("bb_calib_{}_{}", name, ::getpid());
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

struct Run {
  int code;
  std::string err;
  std::string out;  // stdout: the summary
};

std::string read_text(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// `burrbench ARGS` (quoted by the caller), its stderr kept in `err` and its stdout beside it.
Run run_cli(const std::string& args, const fs::path& err) {
  const fs::path out = err.string() + ".stdout";
  const int st = std::system(fmt::format("'{}' {} > '{}' 2> '{}'", cli(), args, out.string(), err.string()).c_str());
  return {WIFEXITED(st) ? WEXITSTATUS(st) : -1, read_text(err), read_text(out)};
}

Run calibrate(const fs::path& manifest, const fs::path& out, const std::string& extra = "") {
  return run_cli(fmt::format("calibrate --experiment '{}' --out '{}' {}", manifest.string(), out.string(), extra),
                   out.string() + ".stderr");
}

// `burrbench report` of a calibrate directory, loaded in headless Chromium: the rendered
// DOM (fails the test on a console error).
std::string report_dom(const fs::path& out, const fs::path& rep, const fs::path& chromium) {
  fs::create_directories(rep.parent_path());
  const std::string cmd = fmt::format("'{}' report '{}' --out '{}' > /dev/null 2>&1", cli(), out.string(), rep.string());
  if (std::system(cmd.c_str()) != 0) {
    ADD_FAILURE() << cmd;
    return {};
  }
  const fs::path bc = rep.parent_path() / "browser.json";
  const std::string check = fmt::format("/usr/bin/python3 '{}/tests/analysis/browser_check.py' '{}' '{}' > '{}' 2>/dev/null",
                                        std::string(BURRBENCH_SOURCE_DIR), rep.string(), chromium.string(), bc.string());
  if (std::system(check.c_str()) != 0) {
    ADD_FAILURE() << check;
    return {};
  }
  std::ifstream bf(bc);
  const auto browser = nlohmann::json::parse(bf);
  EXPECT_TRUE(browser["console_errors"].empty()) << browser["console_errors"].dump();
  return browser["dom"].get<std::string>();
}

// The legend labels of the rendered plot with that element id.
std::vector<std::string> plot_legend(const std::string& dom, const std::string& plot_id) {
  const std::size_t from = dom.find("id=\"" + plot_id + "\""), to = dom.find("</table>", from);
  std::vector<std::string> out;
  if (from == std::string::npos || to == std::string::npos) return out;
  const std::string tag = "<div class=\"u-label\">";
  for (std::size_t p = dom.find(tag, from); p < to; p = dom.find(tag, p)) {
    p += tag.size();
    out.push_back(dom.substr(p, dom.find('<', p) - p));
  }
  return out;
}

// The reference experiment at time scale 3, one start: its long plunge is where the
// sensitivities diverge at a coarser voxel.
fs::path long_reference(const fs::path& dir) {
  ReferenceSpec s;
  s.time_scale = 3;
  s.multistart = 1;
  return make_reference_experiment(dir, s, cli());
}

const ds::FitParameter& param(const ds::FitResult& f, int label, const char* name) {
  const auto* p = f.parameter(std::uint8_t(label), name);
  if (!p) throw std::runtime_error("missing parameter");
  return *p;
}

}  // namespace

TEST(CalibrateCli, RecoversTwoClassesFromPlungeSweepPolish) {
  const fs::path dir = scratch("recovery");
  ReferenceSpec s;  // noise 0.02 N, bias, 4 ms lag, R/l = 10
  const fs::path manifest = make_reference_experiment(dir, s, cli());
  const auto r = calibrate(manifest, dir / "out");
  ASSERT_EQ(r.code, 0) << r.err;
  // Its log (stderr, not a terminal) names every stage it went through, in order, however
  // thinly it shows the updates between them.
  std::size_t at = 0;
  for (const char* st : {"calibrate: global search: ", "calibrate: refine: ", "calibrate: profiles: ",
                         "calibrate: discretization check: ", "calibrate: cross-validation: "}) {
    at = r.err.find(st, at);
    EXPECT_NE(at, std::string::npos) << st << " in\n" << r.err;
  }
  const ds::FitResult fit = ds::read_fit(dir / "out" / "fit.json");
  const std::array<std::array<double, 3>, 3> truth{{{0, 0, 0}, {s.alpha1, s.c1_1, s.mu1}, {s.alpha2, s.c1_2, s.mu2}}};
  for (int k : {1, 2}) {
    const auto& a = param(fit, k, "alpha");
    const auto& c = param(fit, k, "c1");
    const auto& m = param(fit, k, "mu");
    ASSERT_TRUE(a.identifiable && c.identifiable && m.identifiable) << a.reason << c.reason << m.reason;
    std::printf("class %d: C1 %+.2f %%, mu %+.2f %%, alpha %+.2f %% (estimate vs truth)\n", k,
                100 * (c.estimate / truth[std::size_t(k)][1] - 1), 100 * (m.estimate / truth[std::size_t(k)][2] - 1),
                100 * (a.estimate / truth[std::size_t(k)][0] - 1));
    EXPECT_NEAR(c.estimate / truth[std::size_t(k)][1], 1.0, 0.02) << "C1 of class " << k;
    EXPECT_NEAR(m.estimate / truth[std::size_t(k)][2], 1.0, 0.05) << "mu of class " << k;
    EXPECT_NEAR(a.estimate / truth[std::size_t(k)][0], 1.0, 0.10) << "alpha of class " << k;
    EXPECT_LT(c.ci95_low, c.estimate);
    EXPECT_GT(c.ci95_high, c.estimate);
    // The summary gives each constant with its unit, and μ (dimensionless) with none.
    for (const auto* q : {&a, &c, &m}) {
      const std::string line = fmt::format("  {:<12} {:<5} = {:.6g}{} profile 95 % [", q->class_name, q->name,
                                           q->estimate, q == &m ? "" : " N/mm^2");
      EXPECT_NE(r.out.find(line), std::string::npos) << line << " in\n" << r.out;
    }
  }
  // Bias and lag: the truth inside the reported 95 % intervals. With 5 recordings × 4
  // nuisances = 20 intervals at 95 %, all 20 covering the truth happens only ~36 % of the
  // time even for exact intervals; ≥ 18 of 20 (90 %) is what a correct 95 % interval gives
  // reliably. Each estimate must also be close in absolute terms.
  int inside = 0, checked = 0;
  for (std::size_t q = 0; q < fit.nuisance.size(); ++q) {
    const auto& n = fit.nuisance[q];
    const int i = int(q / 5);  // five entries per recording, recordings in manifest order
    double t = NAN, tol = 0.01;
    if (n.name == "bias_x") t = 0.05 + 0.01 * i;
    if (n.name == "bias_y") t = -0.03;
    if (n.name == "bias_z") t = 0.1 - 0.02 * i;
    if (n.name == "lag") { t = s.lag_ms; tol = 2.0; }
    if (std::isnan(t)) continue;
    EXPECT_FALSE(n.fixed);
    ++checked;
    inside += n.ci95_low <= t && t <= n.ci95_high;
    EXPECT_NEAR(n.estimate, t, tol) << n.recording_id << "." << n.name;
  }
  EXPECT_EQ(checked, 20);
  EXPECT_GE(inside, 18) << "nuisance intervals holding the truth";
  EXPECT_GT(fit.residuals_summary.samples_used, 1000u);
  EXPECT_NEAR(fit.residuals_summary.sigma_N, s.noise_N, 0.2 * s.noise_N);  // estimated σ
  EXPECT_FALSE(fit.cross_validation.empty());
  // The summary gives each held-out figure as the fit line gives its own (4 digits), not
  // every digit of a double.
  EXPECT_NE(r.out.find("cross-validation (each recording held out, x, y, z together):\n"), std::string::npos) << r.out;
  for (const auto& cv : fit.cross_validation) {
    const auto& h = cv.metrics["held_out"];
    ASSERT_TRUE(h["rmse_xyz_N"].is_number());
    const std::string line = fmt::format("  without {}: held-out RMSE {:.4g} N, R² {:.4f}\n", cv.held_out,
                                         h["rmse_xyz_N"].get<double>(), h["r2_xyz"].get<double>());
    EXPECT_NE(r.out.find(line), std::string::npos) << line << " in\n" << r.out;
  }
  // Every start says how it ended, as its termination does. The starts above the best
  // optimum are told apart: inside its 95 % intervals (profile, else covariance; open
  // sides unbounded) it ended in the optimum's neighbourhood; elsewhere a converged one is
  // another minimum, a stopped one is not.
  const auto& gs = fit.settings["global_search"];
  int reached = 0, near = 0, above_converged = 0, above_stopped = 0;
  for (const auto& e : fit.multistart) {
    const std::string ending = e["ending"].get<std::string>(), term = e["termination"].get<std::string>();
    if (term.rfind("CONVERGENCE", 0) == 0) {
      EXPECT_EQ(ending, "converged") << term;
    } else if (term.rfind("screened", 0) == 0) {
      EXPECT_EQ(ending, "screened") << term;
    } else {
      EXPECT_EQ(ending, "stopped") << term;
    }
    if (!e["cost"].is_number()) continue;  // a start that could not be evaluated counts nowhere
    if (e["reached_best"].get<bool>()) {
      ++reached;
      continue;
    }
    bool inside = true;
    for (const auto& p : fit.parameters) {
      if (p.fixed) continue;
      const bool prof = std::isfinite(p.profile_ci95_low) || std::isfinite(p.profile_ci95_high);
      const double lo = prof ? p.profile_ci95_low : p.ci95_low, hi = prof ? p.profile_ci95_high : p.ci95_high;
      const double v = e["end"][p.class_name + "." + p.name].get<double>();
      inside = inside && !(v < lo) && !(v > hi);  // NaN: an open side
    }
    near += inside;
    above_converged += !inside && ending == "converged";
    above_stopped += !inside && ending == "stopped";
  }
  EXPECT_EQ(reached, gs["reached_best"].get<int>());
  EXPECT_EQ(near, gs["near_best"].get<int>());
  EXPECT_EQ(above_converged, gs["higher_optima"].get<int>());
  EXPECT_EQ(above_stopped, gs["stopped_short"].get<int>());
  std::string lone;  // the warning of a best optimum found once says how the others ended
  for (const auto& w : fit.settings["warnings"])
    if (w.get<std::string>().find("reached by only") != std::string::npos) lone = w.get<std::string>();
  EXPECT_EQ(!lone.empty(), reached + near <= 1 && gs["solved_locally"].get<int>() > 1) << lone;
  if (!lone.empty()) {
    EXPECT_EQ(lone.find("converged to higher minima") != std::string::npos, above_converged > 0) << lone;
    EXPECT_EQ(lone.find("stopped above it before converging") != std::string::npos, above_stopped > 0) << lone;
  }
  std::printf("global search: reached by %d of %zu, %d more inside its intervals; above it %d converged, %d stopped\n",
              reached, fit.multistart.size(), near, above_converged, above_stopped);
  // params.toml: the estimates, readable by a simulator release.
  const auto ps = ds::read_params(dir / "out" / "params.toml");
  EXPECT_DOUBLE_EQ(ps.classes.at(1).c1_N_per_mm2, param(fit, 1, "c1").estimate);
  EXPECT_DOUBLE_EQ(ps.classes.at(2).mu, param(fit, 2, "mu").estimate);
  // `report` of the calibrate directory shows what the fit held: its per-axis rows of
  // "calibrate / all" reproduce fit.json's RMSE and R² over x, y, z to 1e-6 relative.
  const fs::path rep = dir / "rep" / "report.html";
  const std::string dom = report_dom(dir / "out", rep, dir / "chromium");
  EXPECT_NEAR(pooled_calibrate_rmse_N(rep.parent_path() / "metrics.json") / fit.metrics["calibration"]["rmse_xyz_N"].get<double>(),
              1.0, 1e-6);
  EXPECT_NEAR((1 - pooled_calibrate_r2_xyz(rep.parent_path() / "metrics.json")) / (1 - fit.metrics["calibration"]["r2_xyz"].get<double>()),
              1.0, 1e-6);
  // The report draws the waterfall and every profile in a real browser (headless Chromium).
  EXPECT_NE(dom.find("id=\"plot-waterfall\" data-rendered=\"1\""), std::string::npos);
  // Its legend names each way the starts ended.
  std::vector<std::string> legend{"start (sorted)"};
  for (const std::string ending : {"converged", "stopped", "screened"}) {
    bool any = false;
    for (const auto& e : fit.multistart) any = any || e["ending"].get<std::string>() == ending;
    if (any)
      legend.push_back(ending == "converged" ? "converged (a minimum)"
                       : ending == "stopped" ? "stopped before converging"
                                             : "screened at its pre-fit");
  }
  EXPECT_EQ(plot_legend(dom, "plot-waterfall"), legend);
  // A fit.json written before the starts' endings were stored draws them as one series.
  {
    const fs::path old = dir / "old";
    fs::copy(dir / "out", old, fs::copy_options::recursive);
    nlohmann::json j;
    {
      std::ifstream f(old / "fit.json");
      j = nlohmann::json::parse(f);
    }
    for (auto& e : j["multistart"]) e.erase("ending");
    std::ofstream(old / "fit.json") << j.dump(1);
    const std::string old_dom = report_dom(old, dir / "rep_old" / "report.html", dir / "chromium_old");
    EXPECT_NE(old_dom.find("id=\"plot-waterfall\" data-rendered=\"1\""), std::string::npos);
    EXPECT_EQ(plot_legend(old_dom, "plot-waterfall"), (std::vector<std::string>{"start (sorted)", "cost"}));
  }
  for (int k = 0; k < 6; ++k) {
    EXPECT_NE(dom.find(fmt::format("id=\"plot-profile-{}\" data-rendered=\"1\"", k)), std::string::npos) << k;
    // The curve between the computed points (quadratic, as the walk models it) and the
    // points themselves, apart.
    const auto l = plot_legend(dom, fmt::format("plot-profile-{}", k));
    ASSERT_EQ(l.size(), 4u) << k;
    EXPECT_EQ(std::vector<std::string>(l.begin() + 1, l.end()),
              (std::vector<std::string>{"profile", "computed points", "95 % threshold"}));
  }
  EXPECT_NE(dom.find("held at the optimum"), std::string::npos);
  EXPECT_EQ(dom.find("bootstrap 95 %"), std::string::npos);  // no --bootstrap: no column of blanks
  // The cross-validation's folds as a table (held-out figures to 6 digits), not JSON.
  const std::size_t cv_at = dom.find("Leave-one-out cross-validation");
  ASSERT_NE(cv_at, std::string::npos);
  const std::string cv_table = dom.substr(cv_at, dom.find("</table>", cv_at) - cv_at);
  EXPECT_EQ(cv_table.find("{&quot;"), std::string::npos) << cv_table;
  for (const auto& cv : fit.cross_validation)
    EXPECT_NE(cv_table.find(fmt::format("<td>{}</td><td class=\"num\">{}</td><td class=\"num\">{:.6g}</td>", cv.held_out,
                                        cv.metrics["held_out"]["samples"].dump(),
                                        cv.metrics["held_out"]["rmse_xyz_N"].get<double>())),
              std::string::npos)
        << cv.held_out << "\n" << cv_table;
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(CalibrateCli, OnlyCompactTouchedLeavesTrabecularNotIdentifiable) {
  const fs::path dir = scratch("compact_only");
  ReferenceSpec s;
  s.trabecular = false;
  s.multistart = 1;
  const auto r = calibrate(make_reference_experiment(dir, s, cli()), dir / "out",
                           "--no-cross-validation --bootstrap 12 --bootstrap-block-s 0.25");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto fit = ds::read_fit(dir / "out" / "fit.json");
  for (const char* n : {"alpha", "c1", "mu"}) {
    // Block bootstrap interval reported beside the covariance one, around the estimate.
    const auto& c = param(fit, 1, n);
    EXPECT_LT(c.bootstrap_ci95_low, c.estimate * 1.001) << n;
    EXPECT_GT(c.bootstrap_ci95_high, c.estimate * 0.999) << n;
    EXPECT_LT(c.bootstrap_ci95_low, c.bootstrap_ci95_high) << n;
    const auto& t = param(fit, 2, n);
    EXPECT_TRUE(std::isnan(t.bootstrap_ci95_low)) << n;
    EXPECT_FALSE(t.identifiable) << n;
    EXPECT_TRUE(std::isnan(t.estimate)) << n;
    EXPECT_NE(t.reason.find("never in contact"), std::string::npos) << t.reason;
    EXPECT_TRUE(param(fit, 1, n).identifiable) << n << ": " << param(fit, 1, n).reason;
  }
  EXPECT_NEAR(param(fit, 1, "c1").estimate / s.c1_1, 1.0, 0.02);
  // The report's parameter table gives the bootstrap's column, with each interval.
  const fs::path rep = dir / "rep" / "report.html";
  ASSERT_EQ(run_cli(fmt::format("report '{}' --out '{}'", (dir / "out").string(), rep.string()), dir / "report.stderr").code, 0);
  const std::string html = read_text(rep);
  EXPECT_NE(html.find("<th>bootstrap 95 %</th>"), std::string::npos);
  for (const char* n : {"alpha", "c1", "mu"}) {
    const auto& c = param(fit, 1, n);
    EXPECT_NE(html.find(fmt::format("[{:.4g}, {:.4g}]", c.bootstrap_ci95_low, c.bootstrap_ci95_high)), std::string::npos) << n;
  }
  if (!HasFailure()) fs::remove_all(dir);
}

TEST(CalibrateCli, ErosionOffLeavesAlphaNotIdentifiable) {
  const fs::path dir = scratch("no_erosion");
  ReferenceSpec s;
  s.erosion = false;
  s.multistart = 1;
  s.time_scale = 0.5;  // half the data: α's flat profiles cost many re-optimisations
  const auto r = calibrate(make_reference_experiment(dir, s, cli()), dir / "out", "--no-cross-validation");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto fit = ds::read_fit(dir / "out" / "fit.json");
  for (int k : {1, 2}) {
    EXPECT_FALSE(param(fit, k, "alpha").identifiable) << "class " << k << " alpha = " << param(fit, k, "alpha").estimate;
    EXPECT_FALSE(param(fit, k, "alpha").reason.empty());
    EXPECT_TRUE(param(fit, k, "c1").identifiable) << param(fit, k, "c1").reason;
    EXPECT_NEAR(param(fit, k, "c1").estimate / (k == 1 ? s.c1_1 : s.c1_2), 1.0, 0.03);
  }
  if (!HasFailure()) fs::remove_all(dir);
}

// The discretization check refits at 2l (R/l = 5 here), where the forward sensitivities of
// the reference's long plunge diverge (columns of 1e97 N per unit of ln θ): Ceres's steps
// for compact α, C1, μ and the plunge's lag then vanish, and the check reported those
// constants as unchanged by the coarser voxel (error 0, not limited). The diverged
// Jacobians are differenced instead: every constant is measured, and fit.json says so.
TEST(CalibrateCli, DivergedSensitivitiesDoNotFreezeTheDiscretizationCheck) {
  const fs::path dir = scratch("diverged");
  const auto r = calibrate(long_reference(dir), dir / "out",
                           "--no-cross-validation --no-profiles --starts 1");
  ASSERT_EQ(r.code, 0) << r.err;
  const auto fit = ds::read_fit(dir / "out" / "fit.json");
  int measured = 0;
  for (int k : {1, 2})
    for (const char* n : {"alpha", "c1", "mu"}) {
      const auto& p = param(fit, k, n);
      if (!p.identifiable) continue;
      ++measured;
      EXPECT_GT(std::abs(std::log(p.coarse_estimate / p.estimate)), 1e-6)
          << "class " << k << " " << n << ": the coarse refit left it at " << p.estimate;
    }
  EXPECT_EQ(measured, 6);
  std::ifstream f(dir / "out" / "fit.json");
  const auto j = nlohmann::json::parse(f);
  const auto& diverged = j.at("settings").at("derivatives").at("diverged");
  ASSERT_FALSE(diverged.empty()) << "the reference's coarse refit no longer diverges: the test lost its case";
  bool coarse = false;
  for (const auto& d : diverged) coarse |= d.at("voxel_mm").get<double>() == 0.2;
  EXPECT_TRUE(coarse) << diverged.dump();
  // fit.json says how the coarse refit ended.
  const auto& check = j.at("settings").at("discretization_check");
  EXPECT_GT(check.at("refit_iterations").get<int>(), 1);
  EXPECT_FALSE(check.at("refit_termination").get<std::string>().empty());
  if (!HasFailure()) fs::remove_all(dir);
}

// A fit validated on a sample at twice its voxel (a simulator running coarser): there the
// plunge's band sensitivities diverge (the band read 1e92 N). Its band is left out with a
// warning and a limitation in the report; the other recordings keep theirs.
TEST(CalibrateCli, DivergedBandIsLeftOutNotDrawn) {
  const fs::path dir = scratch("band");
  const fs::path m = long_reference(dir);
  const auto r = calibrate(m, dir / "out", "--no-cross-validation --no-profiles --no-discretization-check --starts 1");
  ASSERT_EQ(r.code, 0) << r.err;
  {
    // fit.json's replay work adds up: every replay of the fit but the overlaps stage's one
    // per recording ran on the pool, and the plain-replay equivalents weigh its
    // sensitivity replays (the diverged ones too) at their measured cost.
    std::ifstream f(dir / "out" / "fit.json");
    const auto j = nlohmann::json::parse(f);
    const auto& w = j.at("settings").at("derivatives").at("replay_work");
    const auto replays = j.at("solver").at("replays").get<double>();
    const auto sens = w.at("sensitivity").at("replays").get<double>();
    const auto plain = w.at("plain").at("replays").get<double>();
    const auto& stages = j.at("solver").at("stages");
    ASSERT_EQ(stages.back().at("stage"), "overlaps");
    const auto overlaps = stages.back().at("replays").get<double>();
    EXPECT_GT(sens, 0);
    EXPECT_EQ(plain + sens + overlaps, replays) << w.dump();
    const double k = w.at("sensitivity_cost_plain").get<double>();
    EXPECT_GT(k, 1.0);
    EXPECT_NEAR(w.at("replay_equivalents").get<double>(), replays + (k - 1) * sens, 1e-9 * replays);
    // The summary is written before the overlaps stage.
    EXPECT_NE(r.out.find(fmt::format("{} of them with sensitivities, each the CPU of {:.2f} plain ones: {:.0f} "
                                     "plain-replay equivalents",
                                     sens, k, replays - overlaps + (k - 1) * sens)),
              std::string::npos)
        << r.out;
  }
  auto run = [&](const std::string& args) { return run_cli(args, dir / "run.stderr"); };
  ASSERT_EQ(run(fmt::format("sample resample --merge 2 '{}' --out '{}'", (dir / "sample.h5").string(),
                            (dir / "coarse.h5").string())).code, 0);
  std::string text = read_text(m);
  const auto at = text.find("path = \"sample.h5\"");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 18, "path = \"coarse.h5\"");
  burrbench::calibration::testing::write_text(dir / "coarse.toml", text);
  burrbench::calibration::testing::write_text(dir / "criteria.toml", R"(format = "burrbench.criteria"
format_version = "1.1"
[[criterion]]
name = "force explained"
metric = "r2"
axis = "magnitude"
data = "calibrate"
min = 0.1
)");
  const auto v = run(fmt::format("validate --experiment '{}' --params '{}' --fit '{}' --criteria '{}' --out '{}' "
                                 "--no-verification",
                                 (dir / "coarse.toml").string(), (dir / "out" / "params.toml").string(),
                                 (dir / "out" / "fit.json").string(), (dir / "criteria.toml").string(),
                                 (dir / "val").string()));
  ASSERT_EQ(v.code, 0) << v.err;
  EXPECT_NE(v.err.find("warning: No prediction band for plunge:"), std::string::npos) << v.err;
  const auto pred = burrbench::data_schema::read_prediction(dir / "val" / "prediction.h5");
  bool limitation = false;
  for (const auto& l : pred.context.at("findings"))
    limitation |= l.get<std::string>().rfind("No prediction band for plunge", 0) == 0;
  EXPECT_TRUE(limitation);
  int with_band = 0;
  // What is drawn stays a band of the constants' uncertainty: finite, well below 1 N.
  double widest = 0;
  std::size_t rows = 0;
  for (const auto& rec : pred.recordings) {
    const bool band = !rec.band95_N.empty();
    if (rec.recording_id == "plunge") {
      EXPECT_FALSE(band);
    }
    with_band += band;
    for (const auto& w : rec.band95_N) {
      widest = std::max({widest, w.x, w.y, w.z});
      ++rows;
    }
  }
  EXPECT_EQ(with_band, 4) << "the other recordings keep their band";
  EXPECT_GT(rows, 0u);
  EXPECT_LT(widest, 1.0);
  if (!HasFailure()) fs::remove_all(dir);
}

// Bad manifests: one small valid experiment, then one defect at a time → exit 2 + message.
class CalibrateBadManifest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(scratch("bad"));
    ReferenceSpec s;
    s.trabecular = false;
    s.time_scale = 0.5;
    good_ = new fs::path(make_reference_experiment(*dir_, s, cli()));
    text_ = new std::string(read_text(*good_));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*dir_);
    delete dir_;
    delete good_;
    delete text_;
  }
  // Replace `from` by `to` in the manifest, run, expect exit 2 and `needle` on stderr.
  void expect_rejected(const std::string& from, const std::string& to, const std::string& needle) {
    std::string t = *text_;
    const auto at = t.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    t.replace(at, from.size(), to);
    const fs::path m = *dir_ / "bad.toml";
    burrbench::calibration::testing::write_text(m, t);
    const auto before = fs::last_write_time(*dir_ / "sample.h5");
    const auto r = calibrate(m, *dir_ / "out_bad", "--no-cross-validation");
    EXPECT_EQ(r.code, 2) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << "one line: " << r.err;
    EXPECT_EQ(fs::last_write_time(*dir_ / "sample.h5"), before);  // inputs untouched
  }
  static fs::path* dir_;
  static fs::path* good_;
  static std::string* text_;
};
fs::path* CalibrateBadManifest::dir_ = nullptr;
fs::path* CalibrateBadManifest::good_ = nullptr;
std::string* CalibrateBadManifest::text_ = nullptr;

TEST_F(CalibrateBadManifest, MissingRecordingFile) {
  expect_rejected("path = \"sweep.h5\"", "path = \"no_such_sweep.h5\"", "no_such_sweep.h5");
}
TEST_F(CalibrateBadManifest, MissingSampleFile) {
  expect_rejected("path = \"sample.h5\"", "path = \"absent.h5\"", "absent.h5");
}
TEST_F(CalibrateBadManifest, UnknownClass) {
  expect_rejected("[fit.classes.trabecular]", "[fit.classes.cortical_bone]", "cortical_bone");
}
TEST_F(CalibrateBadManifest, EmptySegment) {
  expect_rejected("lag_ms = 0.0\n", "lag_ms = 0.0\n  [[recordings.segments]]\n  start_s = 500.0\n  end_s = 600.0\n",
                  "segments[0]");
}
TEST_F(CalibrateBadManifest, BoundsReversed) {
  expect_rejected("c1    = { initial = 10.0, lower = 0.1, upper = 200.0 }",
                  "c1    = { initial = 10.0, lower = 200.0, upper = 0.1 }", "c1");
}
TEST_F(CalibrateBadManifest, NoCalibratingRecording) {
  std::string t = *text_;
  for (std::size_t p; (p = t.find("role = \"calibrate\"")) != std::string::npos;)
    t.replace(p, 18, "role = \"validate\"");
  burrbench::calibration::testing::write_text(*dir_ / "bad2.toml", t);
  const auto r = calibrate(*dir_ / "bad2.toml", *dir_ / "out_bad2");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("role"), std::string::npos) << r.err;
}
