// The calibration driver: experiment → problem → starting values → solve → uncertainty →
// bootstrap → cross-validation → fit result. docs/calibration.md explains each step.
#include "burrbench/calibration/calibrate.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include <fmt/format.h>

#include "burrbench/calibration/objective.hpp"
#include "burrbench/calibration/replay_model.hpp"
#include "burrbench/calibration/steps.hpp"
#include "burrbench/calibration/uncertainty.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::calibration {
namespace {

namespace ds = data_schema;
using Clock = std::chrono::steady_clock;

// Defaults for a class present in the samples but absent from [fit.classes].
ds::ClassFitSpec default_spec(std::uint8_t label) {
  ds::ClassFitSpec s;
  s.label = label;
  s.alpha = {20.0, 0.1, 1000.0, false};
  s.c1 = {10.0, 0.01, 1000.0, false};
  s.mu = {0.3, 0.01, 2.0, false};
  return s;
}

// Robust noise level from samples without predicted contact: 1.4826·MAD about the
// per-recording, per-axis median (the median absorbs the bias).
std::optional<double> estimate_sigma(const Objective& obj, const Evaluation& ev,
                                     const SampleWeights& w, std::size_t& n_used) {
  std::vector<double> dev;
  for (std::size_t r = 0; r < obj.models().size(); ++r) {
    const auto& meas = obj.models()[r]->measured_sensor_N();
    const auto& p = ev.predictions[r];
    for (int a = 0; a < 3; ++a) {
      std::vector<double> v;
      for (std::size_t j = 0; j < meas.size(); ++j)
        if (w[r][j] > 0 && p.class_mask[j] == 0) v.push_back(meas[j][a]);
      if (v.size() < 10) continue;
      std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
      const double med = v[v.size() / 2];
      for (double x : v) dev.push_back(std::abs(x - med));
    }
  }
  n_used = dev.size() / 3;
  if (dev.size() < 30) return std::nullopt;
  std::nth_element(dev.begin(), dev.begin() + long(dev.size() / 2), dev.end());
  const double s = 1.4826 * dev[dev.size() / 2];
  return s > 0 ? std::optional<double>(s) : std::nullopt;
}

struct Metrics {
  double rmse_N = NAN, r2 = NAN;
  std::uint64_t samples = 0;
  nlohmann::json json() const {
    nlohmann::json j;
    j["rmse_N"] = std::isfinite(rmse_N) ? nlohmann::json(rmse_N) : nlohmann::json(nullptr);
    j["r2"] = std::isfinite(r2) ? nlohmann::json(r2) : nlohmann::json(nullptr);
    j["samples"] = samples;
    return j;
  }
};

// RMSE (N, over the three axes) and R² (1 − SS_res/SS_tot about each axis's mean) of the
// bias-corrected prediction over samples with weight > 0 (buried ones excluded).
Metrics metrics(const Objective& obj, const Evaluation& ev, const std::vector<double>& x,
                const SampleWeights& w) {
  double ss = 0, n = 0;
  glm::dvec3 sum(0), sum2(0);
  std::vector<std::pair<glm::dvec3, glm::dvec3>> pairs;
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
  m.rmse_N = std::sqrt(ss / (3 * n));
  m.r2 = tot > 0 ? 1 - ss / tot : NAN;
  return m;
}

// Contiguous runs of used samples per recording, cut into blocks of at most block_s.
struct Block { std::size_t rec, begin, end; };
std::vector<Block> blocks_of(const std::vector<const RecordingModel*>& models,
                             const SampleWeights& w, double block_s) {
  std::vector<Block> out;
  for (std::size_t r = 0; r < models.size(); ++r) {
    const auto& t = models[r]->t_s();
    std::size_t j = 0;
    while (j < t.size()) {
      if (!(w[r][j] > 0)) { ++j; continue; }
      const std::size_t b = j;
      while (j < t.size() && w[r][j] > 0 && t[j] - t[b] < block_s) ++j;
      out.push_back({r, b, j});
    }
  }
  return out;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double pos = q * double(v.size() - 1);
  const std::size_t i = std::size_t(pos);
  const double f = pos - double(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

}  // namespace

CalibrationOutput calibrate(const std::filesystem::path& manifest_path,
                            const CalibrateOptions& opt) {
  const auto t_start = Clock::now();
  const std::string mfile = manifest_path.string();
  model::Experiment exp = model::load_experiment(manifest_path);
  const auto& M = exp.manifest;

  // ---- recordings that calibrate, and their used samples ----
  std::vector<const model::AlignedRecording*> recs;
  for (std::size_t i = 0; i < exp.recordings.size(); ++i) {
    const auto& r = exp.recordings[i];
    if (M.recordings[i].role != ds::RecordingRole::kCalibrate) continue;
    const auto& ref = M.recordings[i];
    for (std::size_t k = 0; k < ref.segments.size(); ++k) {
      const auto& seg = ref.segments[k];
      const bool any = std::any_of(r.t_s.begin(), r.t_s.end(), [&](double t) {
        return t >= seg.start_s && t <= seg.end_s;
      });
      if (!any)
        throw InputError(mfile, fmt::format("recordings[{}].segments[{}]", i, k),
                         fmt::format("a span holding force samples (the recording covers 0..{:.6g} s)",
                                     r.t_s.empty() ? 0.0 : r.t_s.back()),
                         fmt::format("{}..{} s", seg.start_s, seg.end_s));
    }
    if (std::none_of(r.use.begin(), r.use.end(), [](std::uint8_t u) { return u != 0; }))
      throw InputError(mfile, fmt::format("recordings[{}].segments", i),
                       "at least one used force sample (use = true segments)", "none");
    recs.push_back(&r);
  }
  if (recs.empty())
    throw InputError(mfile, "recordings", "at least one recording with role = \"calibrate\"");

  // ---- classes present in the samples the calibrating recordings use ----
  std::map<std::uint8_t, std::string> present;
  for (const auto* r : recs) {
    const auto& s = exp.samples.at(r->sample_id);
    std::array<bool, 256> seen{};
    for (std::size_t i = 0; i < s.labels.size(); ++i)
      if (s.labels[i] != 0 && s.fraction[i] > 0) seen[s.labels[i]] = true;
    for (int k = 1; k < 256; ++k)
      if (seen[std::size_t(k)]) {
        if (k >= kLabels)
          throw InputError(r->sample_id, "labels", fmt::format("class labels < {}", kLabels),
                           std::to_string(k));
        auto it = s.classes.find(std::uint8_t(k));
        present.emplace(std::uint8_t(k), it != s.classes.end() ? it->second : fmt::format("class{}", k));
      }
  }
  std::vector<std::pair<std::uint8_t, std::pair<std::string, ds::ClassFitSpec>>> classes;
  for (const auto& c : M.fit.classes)
    if (!present.count(c.label)) {
      // Named in [fit.classes] but no voxel of it in the samples: kept, reported untouched.
      std::string name = c.key;
      for (const auto& [id, s] : exp.samples)
        if (auto it = s.classes.find(c.label); it != s.classes.end()) name = it->second;
      present.emplace(c.label, name);
    }
  for (const auto& [label, name] : present) {
    ds::ClassFitSpec spec = default_spec(label);
    for (const auto& c : M.fit.classes)
      if (c.label == label) spec = c;
    classes.push_back({label, {name, spec}});
  }

  // ---- layout, replay pool, models ----
  std::vector<std::pair<std::string, double>> rec_lags;
  for (std::size_t i = 0; i < exp.recordings.size(); ++i)
    if (M.recordings[i].role == ds::RecordingRole::kCalibrate)
      rec_lags.emplace_back(exp.recordings[i].id, M.recordings[i].lag_ms);
  const double depth_bound = 0.5 * M.burr.radius_mm;
  Layout layout(classes, rec_lags, M.fit.nuisance, depth_bound);
  std::map<std::string, ds::SampleVolume> used_samples;
  for (const auto* r : recs) used_samples.emplace(r->sample_id, exp.samples.at(r->sample_id));
  ReplayPool pool(used_samples, opt.threads);
  std::vector<std::unique_ptr<ReplayRecordingModel>> owned;
  std::vector<const RecordingModel*> models;
  for (const auto* r : recs) {
    owned.push_back(std::make_unique<ReplayRecordingModel>(*r, pool));
    models.push_back(owned.back().get());
  }
  SampleWeights w_all;
  for (const auto* r : recs) w_all.emplace_back(r->use.begin(), r->use.end());

  ObjectiveSettings settings;
  settings.loss = M.fit.loss;
  settings.loss_scale = M.fit.loss_scale;
  settings.buried = M.fit.buried;
  std::vector<double> x = layout.initial();
  std::string sigma_source = "manifest (sensor.sigma_N)";
  std::uint64_t replays_before = 0;
  if (M.sensor.sigma_N) {
    settings.sigma_N = *M.sensor.sigma_N;
  } else {
    Objective probe(layout, models, settings);
    const auto ev0 = probe.evaluate(x, w_all);
    replays_before += probe.replays();
    std::size_t n_free = 0;
    auto s = estimate_sigma(probe, ev0, w_all, n_free);
    if (!s)
      throw InputError(mfile, "sensor.sigma_N",
                       "a noise level, or >= 10 used samples without contact to estimate it from",
                       fmt::format("{} such samples", n_free));
    settings.sigma_N = *s;
    sigma_source = fmt::format("estimated from {} no-contact samples (1.4826·MAD)", n_free);
  }
  Objective obj(layout, models, settings);
  auto say = [&](const std::string& s) {
    if (opt.progress) opt.progress->update(-1, s);
  };

  // ---- starting values: scan over α (all classes scaled together) ----
  std::vector<std::size_t> alpha_idx, lag_idx, depth_idx;
  for (const auto& p : layout.physics())
    if (p.index >= 0 && p.kind == PhysKind::kAlpha) alpha_idx.push_back(std::size_t(p.index));
  for (const auto& r : layout.recordings()) {
    if (r.lag >= 0) lag_idx.push_back(std::size_t(r.lag));
    if (r.depth >= 0) depth_idx.push_back(std::size_t(r.depth));
  }
  const int starts = alpha_idx.empty() ? 1 : std::max(1, M.fit.multistart);
  nlohmann::json scan = nlohmann::json::array();
  {
    double best = INFINITY;
    std::vector<double> best_x = x;
    for (int s = 0; s < starts; ++s) {
      std::vector<double> xs = x;
      if (s > 0)  // log-uniform grid inside each α's bounds (the manifest start is candidate 0)
        for (std::size_t i : alpha_idx) {
          const double f = (double(s) - 0.5) / double(starts - 1);
          xs[i] = layout.lower(i) + (layout.upper(i) - layout.lower(i)) * std::clamp(f, 0.05, 0.95);
        }
      SolveOptions so;
      so.max_iterations = 4;
      so.geometry_terms = false;
      so.hold.assign(layout.size(), false);
      for (std::size_t i : alpha_idx) so.hold[i] = true;
      for (std::size_t i : lag_idx) so.hold[i] = true;
      for (std::size_t i : depth_idx) so.hold[i] = true;
      say(fmt::format("start {}/{}: C1, μ, bias at fixed α", s + 1, starts));
      const auto r = obj.solve(xs, w_all, so);
      nlohmann::json e;
      for (std::size_t i : alpha_idx) e[layout.name(i)] = std::exp(xs[i]);
      e["cost"] = r.final_cost;
      scan.push_back(e);
      if (r.usable && r.final_cost < best) {
        best = r.final_cost;
        best_x = r.x;
      }
    }
    x = best_x;
  }

  // ---- difference steps from cost sweeps at the start point ----
  DiffSteps steps;
  nlohmann::json sweeps = nlohmann::json::array();
  auto record = [&](const StepSweep& s) {
    sweeps.push_back({{"parameter", s.name}, {"h", s.h}, {"curvature", s.curvature}, {"chosen", s.chosen}});
  };
  // α (per class; a class whose cost does not curve keeps the default 0.1).
  for (const auto& p : layout.physics())
    if (p.index >= 0 && p.kind == PhysKind::kAlpha) {
      auto s = sweep_step(obj, x, w_all, std::size_t(p.index), {0.4, 0.2, 0.1, 0.05}, -1);
      record(s);
      if (s.curvature.front() > 0) steps.log_alpha[p.label] = s.chosen;
    }
  if (!lag_idx.empty()) {
    auto s = sweep_step(obj, x, w_all, lag_idx[0], {2.0, 1.0, 0.5, 0.25}, 0);
    record(s);
    steps.lag_ms = s.chosen;
  }
  if (!depth_idx.empty()) {
    const double l = used_samples.begin()->second.voxel_mm;
    auto s = sweep_step(obj, x, w_all, depth_idx[0], {0.5 * l, 0.25 * l, 0.125 * l, 0.0625 * l}, 0);
    record(s);
    steps.depth_mm = s.chosen;
  }
  for (auto& m : owned) m->set_steps(steps);

  // ---- the fit ----
  SolveOptions so;
  so.max_iterations = opt.max_iterations;
  so.progress = opt.progress;
  auto fit = obj.solve(x, w_all, so);
  {
    // A second pass from the solution with a fresh trust region: the first one can stop
    // early in the long α–μ valley when its region has shrunk.
    SolveOptions again = so;
    again.max_iterations = std::max(5, opt.max_iterations / 3);
    auto second = obj.solve(fit.x, w_all, again);
    if (second.usable && second.final_cost <= fit.final_cost) {
      second.initial_cost = fit.initial_cost;
      second.iterations += fit.iterations;
      fit = second;
    }
  }
  x = fit.x;
  const Evaluation ev = obj.evaluate(x, w_all);
  UncertaintyReport unc = assess_uncertainty(obj, x, w_all, ev);
  const Metrics cal = metrics(obj, ev, x, w_all);

  ds::FitResult out;
  out.parameters = unc.parameters;
  out.nuisance = unc.nuisance;
  out.covariance = unc.covariance;
  out.correlation = unc.correlation;
  out.residuals_summary.samples_used = ev.samples_used;
  out.residuals_summary.samples_buried = ev.samples_buried;
  out.residuals_summary.samples_excluded = ev.samples_excluded;
  out.residuals_summary.sigma_N = settings.sigma_N;
  out.residuals_summary.rms_normalised =
      ev.residuals_used ? std::sqrt(2 * ev.cost / double(ev.residuals_used)) : NAN;

  // ---- block bootstrap: resample blocks of used samples, refit warm-started ----
  const auto blocks = blocks_of(models, w_all, opt.bootstrap_block_s);
  std::map<std::string, std::vector<double>> boot;  // physics name → replicate estimates
  int boot_ok = 0;
  if (opt.bootstrap > 0 && blocks.size() >= 2) {
    std::mt19937_64 rng(M.fit.seed);
    std::uniform_int_distribution<std::size_t> pick(0, blocks.size() - 1);
    for (int b = 0; b < opt.bootstrap; ++b) {
      say(fmt::format("bootstrap {}/{}", b + 1, opt.bootstrap));
      SampleWeights wb;
      for (const auto& wr : w_all) wb.emplace_back(wr.size(), 0.0);
      for (std::size_t k = 0; k < blocks.size(); ++k) {
        const auto& bl = blocks[pick(rng)];
        for (std::size_t j = bl.begin; j < bl.end; ++j) wb[bl.rec][j] += 1.0;
      }
      SolveOptions sb;
      sb.max_iterations = 8;
      sb.hold = unc.held;
      const auto r = obj.solve(x, wb, sb);
      if (!r.usable) continue;
      ++boot_ok;
      for (const auto& p : layout.physics())
        if (p.index >= 0 && !unc.held[std::size_t(p.index)])
          boot[layout.name(std::size_t(p.index))].push_back(std::exp(r.x[std::size_t(p.index)]));
    }
    for (auto& p : out.parameters) {
      auto it = boot.find(p.class_name + "." + p.name);
      if (it == boot.end() || it->second.size() < 10) continue;
      p.bootstrap_ci95_low = percentile(it->second, 0.025);
      p.bootstrap_ci95_high = percentile(it->second, 0.975);
    }
  }

  // ---- cross-validation: leave one recording out (or one used span if only one) ----
  if (opt.cross_validate) {
    struct Fold { std::string name; SampleWeights train, test; int rec = -1; };
    std::vector<Fold> folds;
    if (models.size() >= 2) {
      for (std::size_t r = 0; r < models.size(); ++r) {
        Fold f{models[r]->id(), w_all, {}, int(r)};
        for (auto& wr : f.train) std::fill(wr.begin(), wr.end(), 0.0);
        f.test = f.train;
        for (std::size_t q = 0; q < models.size(); ++q) (q == r ? f.test : f.train)[q] = w_all[q];
        folds.push_back(std::move(f));
      }
    } else {
      // One recording: leave out each contiguous used span (a segment) in turn.
      const auto spans = blocks_of(models, w_all, INFINITY);
      if (spans.size() >= 2)
        for (std::size_t s = 0; s < spans.size(); ++s) {
          Fold f{fmt::format("{}@{:.3f}-{:.3f}s", models[0]->id(), models[0]->t_s()[spans[s].begin],
                             models[0]->t_s()[spans[s].end - 1]),
                 w_all, w_all, -1};
          std::fill(f.test[0].begin(), f.test[0].end(), 0.0);
          for (std::size_t j = spans[s].begin; j < spans[s].end; ++j) {
            f.train[0][j] = 0;
            f.test[0][j] = 1;
          }
          folds.push_back(std::move(f));
        }
    }
    for (const auto& f : folds) {
      say(fmt::format("cross-validation: without {}", f.name));
      SolveOptions sf;
      sf.max_iterations = 6;
      sf.hold = unc.held;
      auto r = obj.solve(x, f.train, sf);
      std::vector<double> xf = r.x;
      if (f.rec >= 0) {
        // The held-out recording's own nuisances (bias, lag, depth) are re-fitted on it
        // with the physics held at the fold's estimates: they belong to that recording.
        SolveOptions sn;
        sn.max_iterations = 6;
        sn.hold.assign(layout.size(), true);
        const auto& nz = layout.recordings()[std::size_t(f.rec)];
        for (int i : {nz.bias, nz.bias + 1, nz.bias + 2})
          if (nz.bias >= 0) sn.hold[std::size_t(i)] = false;
        if (nz.lag >= 0) sn.hold[std::size_t(nz.lag)] = false;
        if (nz.depth >= 0) sn.hold[std::size_t(nz.depth)] = false;
        xf = obj.solve(xf, f.test, sn).x;
      }
      const Metrics held = metrics(obj, obj.evaluate(xf, f.test, f.rec), xf, f.test);
      const Metrics train = metrics(obj, obj.evaluate(xf, f.train), xf, f.train);
      ds::CrossValidationFold cv;
      cv.held_out = f.name;
      cv.metrics["held_out"] = held.json();
      cv.metrics["calibration"] = train.json();
      nlohmann::json params = nlohmann::json::object();
      for (const auto& p : layout.physics())
        if (p.index >= 0 && !unc.held[std::size_t(p.index)])
          params[layout.name(std::size_t(p.index))] = std::exp(xf[std::size_t(p.index)]);
      cv.metrics["parameters"] = params;
      cv.metrics["termination"] = r.termination;
      out.cross_validation.push_back(std::move(cv));
    }
  }

  // ---- solver summary, settings, provenance ----
  const double wall = std::chrono::duration<double>(Clock::now() - t_start).count();
  out.solver.iterations = fit.iterations;
  out.solver.initial_cost = fit.initial_cost;
  out.solver.final_cost = fit.final_cost;
  out.solver.wall_s = wall;
  out.solver.replays = replays_before + obj.replays();
  out.solver.termination = fit.termination;
  out.solver.multistart = std::uint64_t(starts);
  out.metrics["calibration"] = cal.json();
  auto& st = out.settings;
  st["loss"] = ds::to_string(settings.loss);
  st["loss_scale_sigma"] = settings.loss_scale;
  st["buried"] = ds::to_string(settings.buried);
  st["buried_weight"] = settings.buried == ds::BuriedPolicy::kDownweight ? settings.buried_weight : 0.0;
  st["sigma_source"] = sigma_source;
  st["residual_variance"] = unc.residual_variance;
  st["parameterisation"] = "ln(alpha), ln(C1), ln(mu); bias N; lag ms; depth offset mm";
  st["derivatives"] = {{"c1_mu", "exact fixed-geometry partials + erosion coupling (-d/d ln alpha)"},
                       {"step_log_alpha", [&] {
                          nlohmann::json j = nlohmann::json::object();
                          for (const auto& [label, name] : present) j[name] = steps.log_alpha[label];
                          return j;
                        }()},
                       {"step_lag_ms", steps.lag_ms},
                       {"step_depth_mm", steps.depth_mm},
                       {"sweeps", sweeps}};
  st["start_scan"] = scan;
  st["depth_offset_bound_mm"] = depth_bound;
  st["bootstrap"] = {{"replicates", opt.bootstrap}, {"usable", boot_ok},
                     {"blocks", blocks.size()}, {"block_s", opt.bootstrap_block_s},
                     {"seed", M.fit.seed}};
  st["cross_validation"] = models.size() >= 2 ? "leave one recording out" : "leave one used span out";
  st["threads"] = opt.threads;
  std::vector<std::filesystem::path> inputs{manifest_path};
  for (const auto& s : M.samples) inputs.push_back(s.path);
  for (const auto& r : M.recordings) inputs.push_back(r.path);
  out.provenance = make_provenance(inputs);
  out.experiment_path = std::filesystem::absolute(manifest_path).string();
  out.experiment_sha256 = sha256_file(manifest_path);

  // ---- parameter set: every class, estimates where identifiable ----
  CalibrationOutput res;
  std::string notes = fmt::format("fitted by burrbench calibrate from {}", mfile);
  for (const auto& p : out.parameters) {
    auto& c = res.params.classes[p.class_id];
    c.name = p.class_name;
    double v = p.estimate;
    if (!p.identifiable) {
      // Not determined by the data: the manifest's start value is written and flagged.
      const auto& phys = layout.physics();
      for (const auto& q : phys)
        if (q.label == p.class_id && to_string(q.kind) == p.name) v = q.spec.initial;
      notes += fmt::format("; {}.{} NOT identifiable ({}), start value written", p.class_name, p.name, p.reason);
    }
    if (p.name == "alpha") c.alpha_N_per_mm2 = v;
    else if (p.name == "c1") c.c1_N_per_mm2 = v;
    else c.mu = v;
  }
  res.params.notes = notes;

  // ---- summary ----
  std::string s = fmt::format("calibrated {} recording(s), {} used samples ({} buried, {} excluded), "
                              "σ = {:.4g} N\n", models.size(), ev.samples_used, ev.samples_buried,
                              ev.samples_excluded, settings.sigma_N);
  s += fmt::format("solver: {} iterations, cost {:.6g} → {:.6g}, {} replays, {:.1f} s wall, {}\n",
                   fit.iterations, fit.initial_cost, fit.final_cost, out.solver.replays, wall,
                   fit.termination);
  for (const auto& p : out.parameters) {
    if (p.fixed)
      s += fmt::format("  {:<12} {:<5} = {:.6g} {} (fixed)\n", p.class_name, p.name, p.estimate, p.unit);
    else if (!p.identifiable)
      s += fmt::format("  {:<12} {:<5}   NOT identifiable from these data: {}\n", p.class_name, p.name, p.reason);
    else
      s += fmt::format("  {:<12} {:<5} = {:.6g} ± {:.3g} {} (95 % [{:.6g}, {:.6g}]{})\n", p.class_name,
                       p.name, p.estimate, p.std_error, p.unit, p.ci95_low, p.ci95_high,
                       std::isfinite(p.bootstrap_ci95_low)
                           ? fmt::format("; bootstrap [{:.6g}, {:.6g}]", p.bootstrap_ci95_low, p.bootstrap_ci95_high)
                           : "");
  }
  for (const auto& n : out.nuisance)
    if (!n.fixed)
      s += fmt::format("  {:<12} {:<12} = {:.4g} ± {:.2g} {}\n", n.recording_id, n.name, n.estimate,
                       n.std_error, n.unit);
  s += fmt::format("fit: RMSE {:.4g} N, R² {:.4f}, rms(residual/σ) {:.3f}\n", cal.rmse_N, cal.r2,
                   out.residuals_summary.rms_normalised);
  for (const auto& cv : out.cross_validation)
    s += fmt::format("  without {}: held-out RMSE {} N, R² {}\n", cv.held_out,
                     cv.metrics["held_out"]["rmse_N"].dump(), cv.metrics["held_out"]["r2"].dump());
  res.summary = s;
  res.fit = std::move(out);
  return res;
}

}  // namespace burrbench::calibration
