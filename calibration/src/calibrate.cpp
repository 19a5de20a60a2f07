// The calibration driver: a short pipeline of named stages (pipeline.hpp), each in its own
// file. docs/calibration.md explains each step.
#include "burrbench/calibration/calibrate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "overall_progress.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration {

void validate(const CalibrateOptions& o) {
  const std::string cl = "command line";
  if (o.threads < 1 || o.threads > model::kMaxThreads)
    throw InputError(cl, "--threads", fmt::format("1..{}", model::kMaxThreads), std::to_string(o.threads));
  if (o.max_iterations < 1 || o.max_iterations > 1000)
    throw InputError(cl, "--max-iterations", "1..1000", std::to_string(o.max_iterations));
  if (o.starts < 0 || o.starts > 1000)
    throw InputError(cl, "--starts", "1..1000 (0: the manifest's fit.multistart)", std::to_string(o.starts));
  if (o.solve_starts < 1 || o.solve_starts > 1000)
    throw InputError(cl, "--solve-starts", "1..1000", std::to_string(o.solve_starts));
  if (o.start_iterations < 1 || o.start_iterations > 1000)
    throw InputError(cl, "--start-iterations", "1..1000", std::to_string(o.start_iterations));
  if (o.profile_points < 2 || o.profile_points > 100)
    throw InputError(cl, "--profile-points", "2..100 per side", std::to_string(o.profile_points));
  if (o.bootstrap < 0 || o.bootstrap > 10000)
    throw InputError(cl, "--bootstrap", "0..10000 replicates", std::to_string(o.bootstrap));
  if (!(o.bootstrap_block_s > 0) || !std::isfinite(o.bootstrap_block_s))
    throw InputError(cl, "--bootstrap-block-s", "a block length > 0 s", fmt::format("{}", o.bootstrap_block_s));
}

namespace detail {

nlohmann::json Metrics::json() const {
  nlohmann::json j;
  j["rmse_xyz_N"] = std::isfinite(rmse_xyz_N) ? nlohmann::json(rmse_xyz_N) : nlohmann::json(nullptr);
  j["r2_xyz"] = std::isfinite(r2_xyz) ? nlohmann::json(r2_xyz) : nlohmann::json(nullptr);
  j["samples"] = samples;
  return j;
}

// RMSE (N, over the three axes) and R² (1 − SS_res/SS_tot, SS_tot about each axis's mean,
// summed over the axes: the `_xyz` metrics) of the bias-corrected prediction over samples with weight > 0
// (buried ones excluded).
Metrics metrics(const Objective& obj, const Evaluation& ev, const std::vector<double>& x,
                const SampleWeights& w) {
  double ss = 0, n = 0;
  glm::dvec3 sum(0), sum2(0);
  for (std::size_t r = 0; r < obj.models().size(); ++r) {
    if (ev.predictions[r].force_sensor_N.empty()) continue;
    const auto& nz = obj.layout().recordings()[r];
    const glm::dvec3 bias = nz.bias >= 0 ? glm::dvec3(x[std::size_t(nz.bias)], x[std::size_t(nz.bias) + 1],
                                                      x[std::size_t(nz.bias) + 2])
                                         : glm::dvec3(0);
    const auto& meas = obj.models()[r]->measured_sensor_N();
    for (std::size_t j = 0; j < meas.size(); ++j) {
      if (!(w[r][j] > 0) || ev.predictions[r].buried[j]) continue;
      const glm::dvec3 d = ev.predictions[r].force_sensor_N[j] + bias - meas[j];
      ss += glm::dot(d, d);
      sum += meas[j];
      sum2 += meas[j] * meas[j];
      n += 1;
    }
  }
  Metrics m;
  m.samples = std::uint64_t(n);
  if (n < 2) return m;
  const glm::dvec3 var = sum2 - sum * sum / n;
  const double tot = var.x + var.y + var.z;
  m.rmse_xyz_N = std::sqrt(ss / (3 * n));
  m.r2_xyz = tot > 0 ? 1 - ss / tot : NAN;
  return m;
}

const PhysicsParam* physics_of(const Layout& L, const ds::FitParameter& fp) {
  for (const auto& q : L.physics())
    if (q.label == fp.class_id && to_string(q.kind) == fp.name) return &q;
  return nullptr;
}

std::pair<double, double> check_interval(const ds::FitParameter& fp) {
  return {std::isfinite(fp.profile_ci95_low) ? fp.profile_ci95_low : fp.ci95_low,
          std::isfinite(fp.profile_ci95_high) ? fp.profile_ci95_high : fp.ci95_high};
}

std::string percent(double pct, bool sign) {
  // Two significant digits at least, one decimal at least, never an exponent.
  const double a = std::fabs(pct);
  const int decimals = a > 0 && std::isfinite(a) ? std::clamp(1 - int(std::floor(std::log10(a))), 1, 4) : 1;
  return sign ? fmt::format("{:+.{}f}", pct, decimals) : fmt::format("{:.{}f}", pct, decimals);
}

}  // namespace detail

CalibrationOutput calibrate(const std::filesystem::path& manifest_path, const CalibrateOptions& opt) {
  validate(opt);
  const auto t_start = std::chrono::steady_clock::now();
  // The stages report to the caller's sink through `overall`, which adds the run's fraction.
  CalibrateOptions o = opt;
  const detail::Run* live = nullptr;
  auto replays = [&live] {
    return !live ? 0 : live->obj ? live->replays_before + live->obj->replays() : live->replays_before;
  };
  detail::OverallProgress overall(opt.progress, replays);
  if (opt.progress) o.progress = &overall;
  detail::Run run(o, manifest_path);
  live = &run;
  // Each stage's wall time and replays go to fit.json (solver.stages) and the summary.
  auto stage = [&](const char* name, void (*fn)(detail::Run&)) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::uint64_t r0 = replays();
    overall.begin(name);
    fn(run);
    overall.end(name);
    run.stages.push_back({{"stage", name},
                          {"wall_s", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()},
                          {"replays", replays() - r0}});
  };
  stage("select", detail::select_recordings);
  overall.plan(detail::planned_replays(run));
  stage("steps", detail::choose_steps);
  if (opt.coarse_to_fine) {
    stage("coarse_to_fine", detail::coarse_search);
  } else {
    stage("global_search", detail::global_search);
    stage("refine", detail::refine);
  }
  stage("assess", detail::assess);
  run.calibration_metrics = detail::metrics(*run.obj, run.ev, run.x, run.w_all);
  stage("depth_check", detail::depth_check);
  stage("discretization", detail::discretization_check);
  stage("bootstrap", detail::bootstrap);
  stage("cross_validation", detail::cross_validate);
  stage("validation", detail::score_validation);
  run.out.solver.wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  CalibrationOutput res = detail::results(run);
  const auto t0 = std::chrono::steady_clock::now();
  detail::name_overlaps(run, res);
  const auto t1 = std::chrono::steady_clock::now();
  res.fit.solver.stages.push_back({{"stage", "overlaps"},
                                   {"wall_s", std::chrono::duration<double>(t1 - t0).count()},
                                   {"replays", run.exp.recordings.size()}});
  res.fit.solver.wall_s = std::chrono::duration<double>(t1 - t_start).count();
  // A file replaced while the fit ran: the results would name a file they did not come from.
  check_unchanged(run.exp.inputs, "calibrate");
  overall.complete(fmt::format("fitted: {} replays in {:.1f} s", res.fit.solver.replays, res.fit.solver.wall_s));
  return res;
}

}  // namespace burrbench::calibration
