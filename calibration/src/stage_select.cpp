// Stage "select recordings": which recordings and samples calibrate, which classes are
// present, the parameter layout, the replay pool and the noise level σ.
#include <algorithm>
#include <array>

#include <Eigen/Dense>
#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/registration.hpp"
#include "burrbench/model/verification.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {
namespace {

// Defaults for a class present in the samples but absent from [fit.classes]: wide enough
// for bone (docs/calibration.md "Defaults"): α is a specific cutting energy, 1 … 1e5 N/mm²
// (= mJ/mm³); C1 1e-2 … 1e4 N/mm²; μ 1e-2 … 3. Starts at the geometric middle of α's
// range; the global search covers the rest.
ds::ClassFitSpec default_spec(std::uint8_t label) {
  ds::ClassFitSpec s;
  s.label = label;
  s.alpha = {316.0, 1.0, 1e5, false};
  s.c1 = {10.0, 1e-2, 1e4, false};
  s.mu = {0.3, 1e-2, 3.0, false};
  return s;
}

// Robust noise level from the used samples without predicted contact
// (model::no_contact_sigma_N, shared with `verify`).
std::optional<double> estimate_sigma(const Objective& obj, const Evaluation& ev,
                                     const SampleWeights& w, std::size_t& n_used) {
  std::vector<std::vector<glm::dvec3>> quiet(obj.models().size());
  for (std::size_t r = 0; r < obj.models().size(); ++r) {
    const auto& meas = obj.models()[r]->measured_sensor_N();
    for (std::size_t j = 0; j < meas.size(); ++j)
      if (w[r][j] > 0 && ev.predictions[r].class_mask[j] == 0) quiet[r].push_back(meas[j]);
  }
  return model::no_contact_sigma_N(quiet, n_used);
}

// The load about its least-squares line in the speed (idle + slope·Δkrpm), or about its
// mean when the speed does not vary; the robust spread of these is the noise.
std::vector<double> idle_line_residuals(const std::vector<double>& krpm, const std::vector<double>& load) {
  const double n = double(load.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t j = 0; j < load.size(); ++j) {
    sx += krpm[j];
    sy += load[j];
    sxx += krpm[j] * krpm[j];
    sxy += krpm[j] * load[j];
  }
  const double det = n * sxx - sx * sx;
  const double slope = n > 1 && det / (n * n) > 1e-6 ? (n * sxy - sx * sy) / det : 0.0;
  const double idle = n > 0 ? (sy - slope * sx) / n : 0.0;
  std::vector<double> out(load.size());
  for (std::size_t j = 0; j < load.size(); ++j) out[j] = load[j] - idle - slope * krpm[j];
  return out;
}

bool any(const std::vector<std::uint8_t>& v) {
  return std::any_of(v.begin(), v.end(), [](std::uint8_t u) { return u != 0; });
}

}  // namespace

namespace {

// The recordings (and segments) that calibrate, each segment checked to hold samples;
// returns their indices in the manifest.
std::vector<std::size_t> calibrating_recordings(Run& run) {
  const auto& M = run.exp.manifest;
  const std::string& mfile = run.mfile;
  std::vector<std::size_t> rec_index;
  for (std::size_t i = 0; i < run.exp.recordings.size(); ++i) {
    const auto& r = run.exp.recordings[i];
    const auto& ref = M.recordings[i];
    for (std::size_t k = 0; k < ref.segments.size(); ++k) {
      const auto& seg = ref.segments[k];
      const bool holds = std::any_of(r.t_s.begin(), r.t_s.end(), [&](double t) {
        return t >= seg.start_s && t <= seg.end_s;
      });
      if (!holds)
        throw InputError(mfile, fmt::format("recordings[{}].segments[{}]", i, k),
                         fmt::format("a span holding force samples (the recording covers 0..{:.6g} s)",
                                     r.t_s.empty() ? 0.0 : r.t_s.back()),
                         fmt::format("{}..{} s", seg.start_s, seg.end_s));
    }
    if (ref.role == ds::RecordingRole::kCalibrate && !any(r.use))
      throw InputError(mfile, fmt::format("recordings[{}].segments", i),
                       "at least one used force sample (use = true segments)", "none");
    if (!any(r.use_calibrate)) continue;
    run.recs.push_back(&r);
    rec_index.push_back(i);
  }
  if (run.recs.empty())
    throw InputError(mfile, "recordings",
                     "at least one recording (or segment) with role = \"calibrate\"");

  return rec_index;
}

using ClassSpecs = std::vector<std::pair<std::uint8_t, std::pair<std::string, ds::ClassFitSpec>>>;

// Classes present in the samples the calibrating recordings use, and those [fit.classes]
// names, each with its fit spec.
ClassSpecs present_classes(Run& run) {
  const auto& M = run.exp.manifest;
  for (const auto* r : run.recs) {
    const auto& s = run.exp.samples.at(r->sample_id);
    std::array<bool, 256> seen{};
    for (std::size_t i = 0; i < s.labels.size(); ++i)
      if (s.labels[i] != 0 && s.fraction[i] > 0) seen[s.labels[i]] = true;
    for (int k = 1; k < 256; ++k)
      if (seen[std::size_t(k)]) {
        if (k >= kLabels)
          throw InputError(r->sample_id, "labels", fmt::format("class labels < {}", kLabels),
                           std::to_string(k));
        auto it = s.classes.find(std::uint8_t(k));
        run.present.emplace(std::uint8_t(k),
                            it != s.classes.end() ? it->second : fmt::format("class{}", k));
      }
  }
  for (const auto& c : M.fit.classes)
    if (!run.present.count(c.label)) {
      // Named in [fit.classes] but no voxel of it in the samples: kept, reported untouched.
      std::string name = c.key;
      for (const auto& [id, s] : run.exp.samples)
        if (auto it = s.classes.find(c.label); it != s.classes.end()) name = it->second;
      run.present.emplace(c.label, name);
    }
  ClassSpecs classes;
  for (const auto& [label, name] : run.present) {
    ds::ClassFitSpec spec = default_spec(label);
    for (const auto& c : M.fit.classes)
      if (c.label == label) spec = c;
    classes.push_back({label, {name, spec}});
  }

  return classes;
}

// Mountings registered by fiducials (same sample, same fiducials) share a pose correction.
void share_mountings(Run& run, const std::vector<std::size_t>& rec_index) {
  const auto& M = run.exp.manifest;
  std::vector<std::vector<std::size_t>> groups;
  for (std::size_t q = 0; q < rec_index.size(); ++q) {
    const auto& ref = M.recordings[rec_index[q]];
    if (!ref.registration.from_fiducials()) continue;
    bool placed = false;
    for (auto& g : groups) {
      const auto& first = M.recordings[rec_index[g.front()]];
      if (first.sample == ref.sample && first.registration.fiducials_vol_mm == ref.registration.fiducials_vol_mm &&
          first.registration.fiducials_rig_mm == ref.registration.fiducials_rig_mm) {
        g.push_back(q);
        placed = true;
        break;
      }
    }
    if (!placed) groups.push_back({q});
  }
  for (std::size_t gi = 0; gi < groups.size(); ++gi) {
    const auto& ref = M.recordings[rec_index[groups[gi].front()]];
    const auto& fid = ref.registration.fiducials_vol_mm;
    Mounting m;
    m.name = ref.sample;
    for (std::size_t gj = 0; gj < gi; ++gj)
      if (M.recordings[rec_index[groups[gj].front()]].sample == ref.sample) m.name = fmt::format("{}#{}", ref.sample, gi);
    for (const auto& p : fid) m.centre_vol_mm += p / double(fid.size());
    const auto info = model::fiducial_fit_information(
        fid, ref.registration.fiducial_error_mm.value_or(model::kDefaultFiducialErrorMm));
    Eigen::Matrix<double, 6, 6> I;
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) I(i, j) = info[std::size_t(6 * i + j)];
    const Eigen::Matrix<double, 6, 6> U = Eigen::LLT<Eigen::Matrix<double, 6, 6>>(I).matrixU();  // UᵀU = I
    for (int i = 0; i < 6; ++i)
      for (int j = 0; j < 6; ++j) m.sqrt_information[std::size_t(6 * i + j)] = U(i, j);
    run.layout->add_mounting(std::move(m), groups[gi]);
  }
}

// The replay pool, one model per calibrating recording, and the weights of its samples.
void build_models(Run& run) {
  for (const auto* r : run.recs) run.used_samples.emplace(r->sample_id, &run.exp.samples.at(r->sample_id));
  // The pool copies only what the replays reach of the samples they ask for.
  run.pool = std::make_unique<ReplayPool>(run.exp.samples, run.opt.threads);
  for (const auto* r : run.recs) {
    run.owned.push_back(make_model(run, *r, *run.pool));
    run.models.push_back(run.owned.back().get());
  }
  for (const auto* r : run.recs) {
    run.w_all.emplace_back(r->use_calibrate.begin(), r->use_calibrate.end());
    run.w_validate.emplace_back(r->use_validate.begin(), r->use_validate.end());
  }
  // A recording listed again with role "validate" (the same file) validates on the
  // calibrating copy's fitted nuisances: they belong to the recording, not the listing.
  for (std::size_t i = 0; i < run.exp.recordings.size(); ++i) {
    const auto& r = run.exp.recordings[i];
    if (any(r.use_calibrate) || !any(r.use_validate)) continue;
    for (std::size_t q = 0; q < run.recs.size(); ++q)
      if (run.recs[q]->file == r.file && run.recs[q]->t_s == r.t_s)
        for (std::size_t j = 0; j < r.t_s.size(); ++j)
          if (r.use_validate[j] && !run.recs[q]->use_calibrate[j]) run.w_validate[q][j] = 1;
  }

}

// The force's noise level: the manifest's, else from the samples without contact.
void force_noise(Run& run) {
  const auto& M = run.exp.manifest;
  const std::string& mfile = run.mfile;
  if (M.sensor.sigma_N) {
    run.settings.sigma_N = *M.sensor.sigma_N;
  } else {
    Objective probe(*run.layout, run.models, run.settings);
    const auto ev0 = probe.evaluate(run.layout->initial(), run.w_all);
    run.replays_before += probe.replays();
    std::size_t n_free = 0;
    auto s = estimate_sigma(probe, ev0, run.w_all, n_free);
    if (!s)
      throw InputError(mfile, "sensor.sigma_N",
                       "a noise level, or >= 10 used samples without contact to estimate it from",
                       fmt::format("{} such samples", n_free));
    run.settings.sigma_N = *s;
    run.sigma_source = fmt::format("estimated from {} no-contact samples (1.4826·MAD)", n_free);
  }
}

// The moment's and the spindle load's noise: the manifest's, else from the samples
// without predicted contact (as σ_N; the per-recording median absorbs the biases and
// the idle torque).
void channel_noise(Run& run) {
  const auto& M = run.exp.manifest;
  const std::string& mfile = run.mfile;
  const Channels& ch = run.layout->channels();
  if (!ch.torque && !ch.spindle) return;
  Objective probe(*run.layout, run.models, run.settings);
  const auto ev0 = probe.evaluate(run.layout->initial(), run.w_all);
  run.replays_before += probe.replays();
  std::vector<std::vector<glm::dvec3>> qt(run.models.size());
  std::vector<std::vector<double>> qs(run.models.size());
  for (std::size_t r = 0; r < run.models.size(); ++r) {
    std::vector<double> krpm;
    for (std::size_t j = 0; j < run.models[r]->size(); ++j) {
      if (!(run.w_all[r][j] > 0) || ev0.predictions[r].class_mask[j] != 0) continue;
      if (ch.torque) qt[r].push_back(run.models[r]->measured_torque_Nmm()[j]);
      // The drive's load without contact is its idle line, idle + viscous·Δkrpm, not a
      // constant: with the speed varying, the spread about one median holds the line's
      // slope (issue 55: 0.154 N·mm for a true 0.1). Only samples with the spindle
      // turning are on that line.
      if (ch.spindle && run.recs[r]->spindle_rpm.at(run.models[r]->t_s()[j]) != 0) {
        qs[r].push_back(run.models[r]->measured_spindle_Nmm()[j]);
        krpm.push_back(run.models[r]->spindle_krpm()[j]);
      }
    }
    if (ch.spindle) qs[r] = idle_line_residuals(krpm, qs[r]);
  }
  auto pick = [&](const std::optional<double>& given, std::optional<double> est, std::size_t n,
                  const char* field, double& into, std::string& source) {
    if (given) {
      into = *given;
      source = std::string("manifest (") + field + ")";
      return;
    }
    if (!est)
      throw InputError(mfile, field, "a noise level, or >= 10 used samples without contact to estimate it from",
                       fmt::format("{} such samples", n));
    into = *est;
    source = fmt::format("estimated from {} no-contact samples (1.4826·MAD)", n);
  };
  std::size_t n = 0;
  if (ch.torque) {
    const auto est = model::no_contact_sigma_N(qt, n);
    pick(M.sensor.sigma_Nmm, est, n, "sensor.sigma_Nmm", run.settings.sigma_torque_Nmm, run.sigma_torque_source);
  }
  if (ch.spindle) {
    const auto est = model::no_contact_sigma(qs, n);
    pick(M.spindle.sigma_Nmm, est, n, "spindle.sigma_Nmm", run.settings.sigma_spindle_Nmm, run.sigma_spindle_source);
    if (!M.spindle.sigma_Nmm)
      run.sigma_spindle_source = fmt::format("estimated from {} no-contact samples with the spindle turning "
                                             "(1.4826·MAD about each recording's idle line in the speed)", n);
  }
}

}  // namespace

void select_recordings(Run& run) {
  const auto& M = run.exp.manifest;
  model::check_each_sample_used_once_per_role(run.exp);  // a sample fitted twice: too narrow intervals
  const std::vector<std::size_t> rec_index = calibrating_recordings(run);
  const ClassSpecs classes = present_classes(run);
  std::vector<std::pair<std::string, double>> rec_lags;
  for (std::size_t i : rec_index) rec_lags.emplace_back(run.exp.recordings[i].id, M.recordings[i].lag_ms);
  run.layout = std::make_unique<Layout>(classes, rec_lags, M.fit.nuisance, 0.5 * M.burr.radius_mm,
                                        Channels{M.fit.fit_torque, M.fit.fit_spindle});
  if (M.fit.nuisance.pose) share_mountings(run, rec_index);
  build_models(run);
  run.settings.loss = M.fit.loss;
  run.settings.loss_scale = M.fit.loss_scale;
  run.settings.buried = M.fit.buried;
  force_noise(run);
  channel_noise(run);
  run.obj = std::make_unique<Objective>(*run.layout, run.models, run.settings);
}

std::unique_ptr<ReplayRecordingModel> make_model(const Run& run, const model::AlignedRecording& r, ReplayPool& pool) {
  model::ReplayOptions ro;
  ro.cancel = run.opt.cancel;
  ro.quadrature = run.opt.quadrature;
  auto m = std::make_unique<ReplayRecordingModel>(r, pool, ro);
  m->set_derivatives(run.opt.derivatives);
  m->set_steps(run.steps);
  m->set_channels(run.layout->channels(), run.mfile);
  return m;
}

}  // namespace burrbench::calibration::detail
