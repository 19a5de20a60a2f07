// Stage "results": fit.json content, the parameter set and the printed summary.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/calibration/friction_check.hpp"
#include "burrbench/calibration/sensor_frame.hpp"
#include "burrbench/calibration/zero_drift.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {
namespace {

nlohmann::json named(const Layout& L, const std::vector<double>& x) {
  nlohmann::json j = nlohmann::json::object();
  for (std::size_t i = 0; i < x.size(); ++i) j[L.name(i)] = L.natural(i, x[i]);
  return j;
}

// The replays' cost in plain-replay equivalents (the bench's fd/sensitivities comparison,
// docs/calibration.md "Derivatives"): `replays` with each sensitivity replay counted at
// its measured CPU per sample over a plain replay's on the same pool (the coarse level's
// replays at 2l have a pool, and a ratio, of their own). Null where a pool ran
// sensitivity replays but no plain one to measure them against.
nlohmann::json replay_work_json(const Run& run, std::uint64_t replays) {
  auto tally = [](const ReplayPool::Tally& t) {
    return nlohmann::json{{"replays", t.replays}, {"samples", t.samples}, {"cpu_s", t.cpu_s}};
  };
  const ReplayPool::Work w = run.pool->work_done();
  nlohmann::json j = {{"plain", tally(w.plain)}, {"sensitivity", tally(w.sensitivity)}};
  double equivalents = double(replays);
  bool known = true;
  std::vector<ReplayPool::Work> pools{w};
  if (run.coarse && run.coarse->pool) pools.push_back(run.coarse->pool->work_done());
  for (const ReplayPool::Work& p : pools) {
    if (p.sensitivity.replays == 0) continue;
    const double k = p.sensitivity_cost();
    known = known && std::isfinite(k);
    if (std::isfinite(k)) equivalents += (k - 1) * double(p.sensitivity.replays);
  }
  const double k = w.sensitivity_cost();
  j["sensitivity_cost_plain"] = std::isfinite(k) ? nlohmann::json(k) : nlohmann::json(nullptr);
  j["replay_equivalents"] = known ? nlohmann::json(equivalents) : nlohmann::json(nullptr);
  return j;
}

// rms(residual/σ) above which the fit is reported as limited by model error.
constexpr double kMisfitRms = 1.2;

void count_samples(Run& run) {
  auto& rs = run.out.residuals_summary;
  rs.samples_used = run.ev.samples_used;
  rs.samples_buried = run.ev.samples_buried;
  rs.samples_excluded = run.ev.samples_excluded;
  rs.sigma_N = run.settings.sigma_N;
}

// The alignment's warnings (the samples it left out of use count among the excluded), and
// a sensor zero that moved between the free stretches before and after the contact, in
// each fitted channel that holds one bias per recording (the force, the moment).
void warn_alignment_and_drift(Run& run) {
  const Layout& L = *run.layout;
  for (const std::string& w : model::alignment_warnings(run.exp)) run.warnings.push_back(w);
  for (std::size_t r = 0; r < run.models.size(); ++r) {
    const RecordingModel& m = *run.models[r];
    const auto& mask = run.ev.predictions[r].class_mask;
    const auto drift = zero_drift(m.t_s(), m.measured_sensor_N(), mask, run.w_all[r]);
    if (std::string w = drift ? drift->text(m.id()) : ""; !w.empty()) run.warnings.push_back(std::move(w));
    if (!L.channels().torque || m.measured_torque_Nmm().empty()) continue;
    const auto moment = zero_drift(m.t_s(), m.measured_torque_Nmm(), mask, run.w_all[r]);
    if (std::string w = moment ? moment->text(m.id(), kMomentChannel) : ""; !w.empty())
      run.warnings.push_back(std::move(w));
  }
}

// Readings that fit the prediction better in a turned or mirrored sensor frame, and
// friction that acts against its predicted direction (a spin the other way round).
void warn_frame_and_friction(Run& run) {
  const auto& ev = run.ev;
  SensorFrameCheck frame;
  for (std::size_t r = 0; r < run.models.size(); ++r)
    frame.add(ev.predictions[r].force_sensor_N, run.models[r]->measured_sensor_N(), ev.predictions[r].class_mask,
              run.w_all[r]);
  // Friction's part of the prediction comes from the fixed-geometry terms at the optimum:
  // one plain replay per recording.
  FrictionDirectionCheck friction;
  const std::vector<Prediction> parts = run.obj->predict_parts(run.x);
  for (std::size_t r = 0; r < run.models.size(); ++r) {
    const Prediction& p = parts[r];
    if (!p.fixed) continue;
    const FixedGeometryTerms& g = *p.fixed;
    std::vector<glm::dvec3> f(p.force_sensor_N.size(), glm::dvec3(0));
    for (std::size_t j = 0; j < f.size(); ++j)
      for (std::size_t i = 0; i < g.labels.size(); ++i)
        f[j] += g.at.mu[g.labels[i]] * g.terms[j * g.labels.size() + i].friction_force;
    friction.add(p.force_sensor_N, f, run.models[r]->measured_sensor_N(), p.class_mask, run.w_all[r]);
  }
  // Both compare the readings with the prediction at the optimum: at an optimum in doubt
  // (optimum_doubts) the misfit may be the optimum's, not the sensor's or the spin's.
  for (std::string& w : frame_and_friction_lines(frame.result(), friction.result(),
                                                 run.exp.manifest.sensor.rotation_sensor_to_rig,
                                                 run.exp.manifest.burr.spin_sign))
    run.warnings.push_back(run.doubts.empty()
                               ? std::move(w)
                               : fmt::format("conditional on an optimum that is not confirmed ({}), which may misfit "
                                             "for reasons of its own — find a better optimum first (more starts), "
                                             "then read this: {}",
                                             fmt::join(run.doubts, "; "), w));
}

// rms(residual/σ) of the fit, and a warning when it is well above 1.
void warn_misfit(Run& run) {
  const Layout& L = *run.layout;
  auto& out = run.out;
  out.residuals_summary.rms_normalised =
      run.ev.residuals_used ? std::sqrt(2 * run.ev.cost / double(run.ev.residuals_used)) : NAN;
  // σ comes from the manifest or from samples without contact, never from these
  // residuals: a fit well above it is a misfit the constants absorb (model error).
  if (!(out.residuals_summary.rms_normalised > kMisfitRms)) return;
  // A registration taken as exact whose depth nothing corrects misfits like this when it
  // is a few µm off along the shaft (docs/calibration.md "Registration is a measurement").
  // The depth check, when it ran, says whether a depth offset helps.
  std::vector<std::string> exact;
  for (std::size_t q = 0; q < run.recs.size() && run.depth.empty(); ++q)
    if (run.recs[q]->registration.method != "fiducials" && L.recordings()[q].depth < 0)
      exact.push_back(run.recs[q]->id);
  run.warnings.push_back(fmt::format(
      "rms(residual/σ) = {:.3f} (1 expected): the model does not follow the contact samples to the noise "
      "level; the intervals are scaled by the residual variance, but a systematic misfit biases the "
      "constants (limited by model error; see the discretization check and `burrbench verify`){}",
      out.residuals_summary.rms_normalised,
      exact.empty() ? ""
                    : fmt::format(". The registration of {} is given and taken as exact, and no depth offset is "
                                  "fitted: one 50 µm off along the shaft misfits like this and biases the "
                                  "constants far beyond their intervals; try [fit.nuisance] depth_offset = true",
                                  fmt::join(exact, ", "))));
}

// Sensitivity Jacobians that diverged and were differenced instead (replay_model.hpp):
// warned of, and returned for fit.json's settings.derivatives.diverged.
nlohmann::json warn_diverged_sensitivities(Run& run) {
  std::vector<std::string> diverged;
  nlohmann::json diverged_json = nlohmann::json::array();
  auto count = [&](const std::vector<std::unique_ptr<ReplayRecordingModel>>& models, double voxel_mm) {
    for (const auto& m : models)
      if (m->diverged_sensitivities() > 0) {
        diverged.push_back(fmt::format("{} at voxel {:.4g} mm ({}×)", m->id(), voxel_mm, m->diverged_sensitivities()));
        diverged_json.push_back(
            {{"recording", m->id()}, {"voxel_mm", voxel_mm}, {"jacobians", m->diverged_sensitivities()}});
      }
  };
  count(run.owned, run.used_samples.empty() ? NAN : run.used_samples.begin()->second->voxel_mm);
  if (run.coarse) count(run.coarse->owned, run.coarse->voxel_mm);
  if (!diverged.empty())
    run.warnings.push_back(fmt::format(
        "the forward sensitivities diverged for {}: those Jacobians were taken by finite differences of "
        "the replay instead (slower; the fit is unaffected)", fmt::join(diverged, ", ")));
  return diverged_json;
}

// The global search's starts, the solver's figures and the fit's metrics.
void record_solver(Run& run) {
  const Layout& L = *run.layout;
  auto& out = run.out;
  for (const auto& e : run.search.ends)
    out.multistart.push_back({{"index", e.index},
                              {"start", named(L, e.start)},
                              {"end", e.end.empty() ? nlohmann::json(nullptr) : named(L, e.end)},
                              {"prefit_cost", e.prefit_cost},
                              {"cost", std::isfinite(e.cost) ? nlohmann::json(e.cost) : nlohmann::json(nullptr)},
                              {"iterations", e.iterations},
                              {"termination", e.termination},
                              {"ending", to_string(e.ending)},
                              {"reached_best", reaches_best(e, run.search_reference_cost, run.search.tolerance)}});

  out.solver.iterations = run.fit.iterations;
  out.solver.initial_cost = run.fit.initial_cost;
  out.solver.final_cost = run.fit.final_cost;
  out.solver.replays = run.replays_before + run.obj->replays();
  out.solver.stages = run.stages;
  out.solver.termination = run.fit.termination;
  out.solver.multistart = std::uint64_t(run.starts);
  out.metrics["calibration"] = run.calibration_metrics.json();
  if (run.validation_metrics.samples > 0) out.metrics["validation"] = run.validation_metrics.json();
}

nlohmann::json channels_json(const Run& run) {
  const Channels& ch = run.layout->channels();
  nlohmann::json c = {{"force", true}, {"torque", ch.torque}, {"spindle", ch.spindle}};
  if (ch.torque) {
    c["sigma_torque_Nmm"] = run.settings.sigma_torque_Nmm;
    c["sigma_torque_source"] = run.sigma_torque_source;
  }
  if (ch.spindle) {
    c["sigma_spindle_Nmm"] = run.settings.sigma_spindle_Nmm;
    c["sigma_spindle_source"] = run.sigma_spindle_source;
  }
  return c;
}

nlohmann::json noise_model_json(const Run& run) {
  return {{"method", run.opt.noise_inflation ? "ar1_inflation" : "white"},
          {"description", run.opt.noise_inflation
                              ? "covariance and profile threshold x residual variance x (1+rho)/(1-rho), "
                                "rho = lag-1 autocorrelation of the residuals (capped at 0.95, never below 0)"
                              : "covariance and profile threshold x residual variance (residuals assumed white)"},
          {"residual_lag1", run.ev.residual_lag1},
          {"inflation", run.inflation},
          {"interval_widening", std::sqrt(run.inflation)}};
}

nlohmann::json derivatives_json(const Run& run, const nlohmann::json& diverged_json) {
  nlohmann::json deriv = {{"scheme", to_string(run.opt.derivatives)}};
  if (run.opt.derivatives == Derivatives::kSensitivities) deriv["diverged"] = diverged_json;
  if (run.opt.derivatives == Derivatives::kFiniteDifferences) {
    nlohmann::json steps = nlohmann::json::object();
    for (const auto& [label, name] : run.present) steps[name] = run.steps.log_alpha[label];
    deriv["step_log_alpha"] = steps;
    deriv["step_lag_ms"] = run.steps.lag_ms;
    deriv["step_depth_mm"] = run.steps.depth_mm;
    deriv["sweeps"] = run.sweeps;
  }
  deriv["replay_work"] = replay_work_json(run, run.out.solver.replays);
  return deriv;
}

nlohmann::json global_search_json(const Run& run) {
  const SearchTally& t = run.tally;
  return {{"starts", run.starts},
          {"design", "manifest start + Latin hypercube in ln(theta) over the bounds"},
          {"start_iterations", run.opt.start_iterations},
          {"solved_locally", run.search.solved},
          {"reached_best", run.search.reached_best},
          {"near_best", t.near},
          {"higher_optima", t.higher_optima},
          {"stopped_short", t.stopped_short},
          {"tolerance_cost", run.search.tolerance},
          {"noise_floor_cost", noise_floor_cost(run)},
          {"noise_floor", "half the used residuals less the free entries: the cost expected at the "
                          "true constants when the model and the noise levels are right"},
          {"local_function_tolerance", run.search_function_tolerance},
          {"seed", run.exp.manifest.fit.seed}};
}

nlohmann::json discretization_check_json(const Run& run) {
  return {
      {"computed", std::isfinite(run.coarse_voxel_mm)},
      {"coarse_voxel_mm", std::isfinite(run.coarse_voxel_mm) ? nlohmann::json(run.coarse_voxel_mm) : nlohmann::json(nullptr)},
      {"method", "refit from the optimum on the sample with voxels merged by 2; error of ln(theta) = "
                 "|ln theta_2l - ln theta_l| (Richardson, first order); limited when above half the 95 % "
                 "interval's half-width in ln(theta), the fit at l misfits (rms(residual/sigma) > 1.1) and the "
                 "refit's cost at 2l differs significantly from it, up or down (p < 0.001, and by a tenth of the "
                 "misfit in excess of the noise at l); interval widened by it on both sides; unconfirmed constants "
                 "are refitted and checked too"},
      {"cost_rise_at_coarse", std::isfinite(run.coarse_cost_rise) ? nlohmann::json(run.coarse_cost_rise) : nlohmann::json(nullptr)},
      {"grid_explains_the_move", run.coarse_grid_explains},
      {"refit_termination", run.coarse_termination.empty() ? nlohmann::json(nullptr) : nlohmann::json(run.coarse_termination)},
      {"refit_iterations", run.coarse_iterations}};
}

// fit.json's settings: how the fit was run and what each check found. Returns the
// registration's lines for the summary (the registration report may warn, so it comes
// before the warnings are copied).
std::string record_settings(Run& run, const nlohmann::json& diverged_json) {
  auto& st = run.out.settings;
  st["loss"] = ds::to_string(run.settings.loss);
  st["loss_scale_sigma"] = run.settings.loss_scale;
  st["buried"] = ds::to_string(run.settings.buried);
  st["buried_weight"] = run.settings.buried == ds::BuriedPolicy::kDownweight ? run.settings.buried_weight : 0.0;
  st["sigma_source"] = run.sigma_source;
  st["quadrature"] = model::quadrature_name(run.opt.quadrature);
  st["channels"] = channels_json(run);
  st["residual_variance"] = run.unc.residual_variance;
  st["noise_model"] = noise_model_json(run);
  st["parameterisation"] = "ln(alpha), ln(C1), ln(mu); bias N; lag ms; depth offset mm";
  st["derivatives"] = derivatives_json(run, diverged_json);
  st["global_search"] = global_search_json(run);
  nlohmann::json excess = nlohmann::json::array();
  for (const double d : run.texture.excess) excess.push_back(std::isfinite(d) ? nlohmann::json(d) : nlohmann::json(nullptr));
  st["profiles"] = {{"computed", run.opt.profiles},
                    {"threshold_cost", run.threshold},
                    {"threshold", "chi2_1(0.95)/2 x residual variance x noise-model inflation + texture allowance"},
                    {"chi2_threshold_cost", run.chi2_threshold},
                    {"texture", {{"probe_excess_cost", excess}, {"allowance_cost", run.texture.allowance}}},
                    {"restarts_from_profile", run.restarts}};
  st["optimum_doubts"] = run.doubts;
  st["started_utc"] = run.started_utc;
  std::string reg_text;
  st["registration"] = registration_report(run, reg_text);  // may warn
  st["warnings"] = run.warnings;
  st["discretization_check"] = discretization_check_json(run);
  st["depth_check"] = run.depth.empty() ? nlohmann::json({{"computed", false}}) : run.depth;
  if (!run.depth.empty()) st["depth_check"]["computed"] = true;
  st["coarse_to_fine"] = {
      {"used", run.opt.coarse_to_fine},
      {"coarse_voxel_mm", run.opt.coarse_to_fine && run.coarse ? nlohmann::json(run.coarse->voxel_mm) : nlohmann::json(nullptr)},
      {"coarse_cost", std::isfinite(run.coarse_cost) ? nlohmann::json(run.coarse_cost) : nlohmann::json(nullptr)}};
  st["depth_offset_bound_mm"] = 0.5 * run.exp.manifest.burr.radius_mm;
  st["threads"] = run.opt.threads;
  return reg_text;
}

// The files as they were read (hashed then), not as they are now.
void record_provenance(Run& run) {
  run.out.provenance = make_provenance_hashed(run.exp.inputs);
  run.out.experiment_path = std::filesystem::absolute(run.manifest_path).string();
  run.out.experiment_sha256 = run.exp.sha256_of(run.manifest_path);
}

// The parameter set holds what the fit held at its optimum; the constants that are not
// identifiable are flagged in it (never a start value).
data_schema::ParameterSet parameter_set(const Run& run) {
  data_schema::ParameterSet params;
  std::string notes = fmt::format("fitted by burrbench calibrate from {}", run.mfile);
  for (const auto& p : run.out.parameters) {
    auto& c = params.classes[p.class_id];
    c.name = p.class_name;
    const double v = p.held;
    if (!p.fixed && !p.identifiable) {
      params.not_identifiable[p.class_id].push_back(p.name);
      notes += fmt::format("; {}.{} NOT identifiable ({}): the value held at the optimum is written",
                           p.class_name, p.name, p.reason);
    }
    if (p.name == "alpha") c.alpha_N_per_mm2 = v;
    else if (p.name == "c1") c.c1_N_per_mm2 = v;
    else c.mu = v;
  }
  params.notes = notes;
  params.provenance = run.out.provenance;
  return params;
}

// The summary's head: what was fitted, the registrations, the search, the optimum, the
// solver and the time by stage.
std::string summary_run(const Run& run, const std::string& reg_text) {
  const Layout& L = *run.layout;
  const auto& ev = run.ev;
  const auto& out = run.out;
  std::string s = fmt::format("calibrated {} recording(s), {} used samples ({} buried, {} excluded), "
                              "σ = {:.4g} N\n", run.models.size(), ev.samples_used, ev.samples_buried,
                              ev.samples_excluded, run.settings.sigma_N);
  if (L.channels().torque || L.channels().spindle)
    s += fmt::format("channels: force{}{}\n",
                     L.channels().torque ? fmt::format(", moment (σ = {:.4g} N·mm, {})", run.settings.sigma_torque_Nmm,
                                                       run.sigma_torque_source)
                                         : "",
                     L.channels().spindle ? fmt::format(", spindle load (σ = {:.4g} N·mm, {})",
                                                        run.settings.sigma_spindle_Nmm, run.sigma_spindle_source)
                                          : "");
  for (const auto* r : run.recs) s += fmt::format("  {}: {}\n", r->id, r->registration.text());
  s += reg_text;
  s += fmt::format("global search: best optimum reached by {} of {} starts{} ({} solved locally after the "
                   "pre-fit; above it: {} converged to other minima, {} stopped before converging)\n",
                   run.search.reached_best, run.starts,
                   run.tally.near > 0 ? fmt::format(", {} more ended inside its 95 % intervals", run.tally.near) : "",
                   run.search.solved, run.tally.higher_optima, run.tally.stopped_short);
  if (!L.mountings().empty())
    s += fmt::format("  (the search held the registration as given; its best end, cost {:.6g}, is what the "
                     "refinement took, with the pose free, to the optimum)\n",
                     run.search_reference_cost);
  {
    const double floor = noise_floor_cost(run);
    const double rms = out.residuals_summary.rms_normalised;
    s += fmt::format("optimum: cost {:.6g} against the noise floor {:.6g} (rms(residual/σ) {:.3f}): {}\n",
                     run.fit.final_cost, floor, rms,
                     rms <= kLoneFindRms ? "it fits to the noise, so no other optimum can fit much better"
                     : rms <= kUnconfirmedRms ? "above the noise: another optimum or model error"
                                              : "far above the noise: not the answer");
  }
  const auto& work = out.settings["derivatives"]["replay_work"];
  s += fmt::format("solver: {} iterations, cost {:.6g} → {:.6g}, {} replays ({} derivatives{}), {}\n",
                   run.fit.iterations, run.fit.initial_cost, run.fit.final_cost, out.solver.replays,
                   to_string(run.opt.derivatives),
                   work["sensitivity"]["replays"].get<std::uint64_t>() > 0 && work["replay_equivalents"].is_number()
                       ? fmt::format("; {} of them with sensitivities, each the CPU of {:.2f} plain ones: {:.0f} "
                                     "plain-replay equivalents",
                                     work["sensitivity"]["replays"].get<std::uint64_t>(),
                                     work["sensitivity_cost_plain"].get<double>(),
                                     work["replay_equivalents"].get<double>())
                       : "",
                   run.fit.termination);
  std::string t;
  for (const auto& st : run.stages)
    if (st["wall_s"].get<double>() >= 0.05)
      t += fmt::format("{}{} {:.1f} s ({} replays)", t.empty() ? "" : ", ", st["stage"].get<std::string>(),
                       st["wall_s"].get<double>(), st["replays"].get<std::uint64_t>());
  s += "time by stage: " + t + "\n";
  return s;
}

// The summary's estimates: the constants, what the other channels add, the nuisances.
std::string summary_estimates(const Run& run, const std::vector<NuisanceAtBound>& pinned) {
  const Layout& L = *run.layout;
  const auto& out = run.out;
  std::string s;
  for (const auto& p : out.parameters) s += data_schema::describe_fit_parameter(p, run.coarse_voxel_mm);
  if (out.channel_information.is_object()) {
    // What the moments and the spindle's load add, linearised at the optimum.
    s += "channels (95 % factor of the linearised interval, force alone -> all channels):";
    for (const auto& p : out.channel_information["parameters"]) {
      auto f = [](const nlohmann::json& v) { return v.is_number() ? fmt::format("x{:.4g}", v.get<double>()) : std::string("none"); };
      s += fmt::format(" {}.{} {} -> {};", p["class_name"].get<std::string>(), p["name"].get<std::string>(),
                       f(p["ci95_factor_force"]), f(p["ci95_factor_all"]));
    }
    for (const auto& c : out.channel_information["correlations"]) {
      auto f = [](const nlohmann::json& v) { return v.is_number() ? fmt::format("{:.4f}", v.get<double>()) : std::string("n/a"); };
      s += fmt::format(" {} C1-alpha correlation {} -> {};", c["class_name"].get<std::string>(), f(c["force"]), f(c["all"]));
    }
    s.back() = '\n';
  }
  for (const auto& n : out.nuisance) {
    if (n.fixed) continue;
    const bool at_bound = std::any_of(pinned.begin(), pinned.end(), [&](const NuisanceAtBound& b) {
      return L.name(b.index) == n.recording_id + "." + n.name;
    });
    s += fmt::format("  {:<12} {:<12} = {:.4g} ± {:.2g} {}{}\n", n.recording_id, n.name, n.estimate, n.std_error,
                     n.unit, at_bound ? " (at its bound: see the warnings)" : "");
  }
  return s;
}

// The summary's tail: how well the fit follows the readings, held-out figures, warnings.
std::string summary_fit(const Run& run) {
  const auto& out = run.out;
  std::string s;
  s += fmt::format("fit (x, y, z together): RMSE {:.4g} N, R² {:.4f}, rms(residual/σ) {:.3f}\n",
                   run.calibration_metrics.rmse_xyz_N, run.calibration_metrics.r2_xyz, out.residuals_summary.rms_normalised);
  s += fmt::format("noise model: residual lag-1 autocorrelation {:.3f}; intervals {}\n", run.ev.residual_lag1,
                   !run.opt.noise_inflation ? "assume white residuals (--white-noise)"
                   : run.inflation > 1.0001 ? fmt::format("widened x{:.4g} for it (AR(1) factor {:.4g} on the variance)",
                                                          std::sqrt(run.inflation), run.inflation)
                                            : "not widened (residuals uncorrelated)");
  if (run.validation_metrics.samples > 0)
    s += fmt::format("validation spans (x, y, z together): RMSE {:.4g} N, R² {:.4f} over {} samples\n",
                     run.validation_metrics.rmse_xyz_N, run.validation_metrics.r2_xyz, run.validation_metrics.samples);
  if (!out.cross_validation.empty()) s += "cross-validation (each recording held out, x, y, z together):\n";
  for (const auto& cv : out.cross_validation) {
    // Same figures as the fit line above; a held-out recording without usable samples has none.
    const auto& h = cv.metrics["held_out"];
    auto fig = [&](const char* key, const char* spec) {
      return h.contains(key) && h[key].is_number() ? fmt::format(fmt::runtime(spec), h[key].get<double>())
                                                   : std::string("n/a");
    };
    s += fmt::format("  without {}: held-out RMSE {} N, R² {}\n", cv.held_out, fig("rmse_xyz_N", "{:.4g}"),
                     fig("r2_xyz", "{:.4f}"));
  }
  for (const auto& w : run.warnings) s += "warning: " + w + "\n";
  return s;
}

}  // namespace

CalibrationOutput results(Run& run) {
  count_samples(run);
  warn_alignment_and_drift(run);
  warn_frame_and_friction(run);
  // A lag, depth offset or pose that ended at a bound: the constants were fitted with it
  // held there.
  const std::vector<NuisanceAtBound> pinned = nuisances_at_bounds(*run.layout, run.x);
  for (const auto& b : pinned) run.warnings.push_back(b.text);
  warn_misfit(run);
  const nlohmann::json diverged = warn_diverged_sensitivities(run);
  record_solver(run);
  const std::string reg_text = record_settings(run, diverged);
  record_provenance(run);

  CalibrationOutput res;
  res.params = parameter_set(run);
  res.summary = summary_run(run, reg_text) + summary_estimates(run, pinned) + summary_fit(run);
  res.fit = std::move(run.out);
  return res;
}

}  // namespace burrbench::calibration::detail
