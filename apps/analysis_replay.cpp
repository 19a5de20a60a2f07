#include "analysis_replay.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/analysis/lag_check.hpp"
#include "burrbench/calibration/friction_check.hpp"
#include "burrbench/calibration/sensor_frame.hpp"
#include "burrbench/calibration/zero_drift.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/fitted_nuisances.hpp"
#include "burrbench/model/model_params.hpp"

namespace burrbench::apps {
using namespace analysis;
namespace fs = std::filesystem;
namespace ds = data_schema;

namespace {

// The analysis series of one recording (one role) from its prediction.
RecordingSeries series_of(const model::Experiment& ex, const model::AlignedRecording& r, const ds::RecordingRef& ref,
                          const model::RecordingPrediction& p, const ds::ParameterSet& params) {
  RecordingSeries rs;
  rs.id = r.id;
  rs.sample_id = r.sample_id;
  rs.role = p.role;
  rs.path = r.file.string();
  rs.sha256 = ex.sha256_of(r.file);
  rs.registration = r.registration.text();
  rs.notes = r.notes;
  rs.quality.dropped_force_samples = r.dropped_force_samples;
  rs.quality.stale_rows = r.stale_rows;
  for (const auto& e : r.events) rs.quality.events.push_back({e.t_s, e.kind, e.stream, e.detail});
  // The stretches without force samples the replay followed the stage through.
  for (const auto& s : r.silences())
    rs.quality.events.push_back({s.from_s, "force_silent", r.force_stream,
                                 fmt::format("no force sample for {:.4g} s: the replay followed the stage's path "
                                             "through it (docs/replay.md \"Alignment and lag\")",
                                             s.to_s - s.from_s)});
  std::stable_sort(rs.quality.events.begin(), rs.quality.events.end(),
                   [](const auto& a, const auto& b) { return a.t_s < b.t_s; });
  for (const auto& seg : ref.segments)
    if (seg.use) rs.segments.push_back({seg.label.empty() ? "segment" : seg.label, seg.start_s, seg.end_s});
  rs.t_s = p.t_s;
  rs.measured_N = p.force_sensor_meas_N;
  rs.predicted_N = p.force_sensor_pred_N;
  rs.band95_N = p.band95_N;
  const std::size_t n = p.samples();
  rs.used.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    rs.used[k] = p.used_calibrate[k] || p.used_validate[k];
    rs.quality.buried_samples += p.buried[k] != 0;
  }
  if (p.torque_sensor_meas_Nmm.size() == n) {
    rs.torque_measured_Nmm = p.torque_sensor_meas_Nmm;
    rs.torque_predicted_Nmm = p.torque_sensor_pred_Nmm;
  }
  if (!p.spindle_torque_meas_Nmm.empty()) {
    rs.spindle_measured_Nmm = p.spindle_torque_meas_Nmm;
    rs.spindle_predicted_Nmm = p.spindle_torque_pred_Nmm;
    rs.spindle_offset_Nmm = p.spindle_offset_Nmm.empty() ? std::vector<double>(n, 0.0) : p.spindle_offset_Nmm;
    rs.spindle_offset_source = p.spindle_offset_source;
    rs.spin_rad_s.resize(n);
    const model::Trajectory tr = r.trajectory(p.lag_ms / 1000.0, p.depth_offset_mm);  // ω does not depend on the pose
    for (std::size_t k = 0; k < n; ++k) rs.spin_rad_s[k] = glm::length(tr.omega_vol_rad_s[k]);
  }
  for (const auto& [label, c] : params.classes)
    if (p.removed_mm3[std::size_t(label)] > 0 || p.friction_energy_mJ[std::size_t(label)] > 0)
      rs.energy.push_back({int(label), c.name, c.alpha_N_per_mm2, p.removed_mm3[std::size_t(label)],
                           p.friction_energy_mJ[std::size_t(label)]});
  return rs;
}

}  // namespace

AnalysisInput replay_experiment(const fs::path& manifest, const ds::ParameterSet& params,
                                const ds::FitResult* fit, const ReplayInputOptions& opt) {
  const model::Experiment ex = model::load_experiment(manifest);
  // The analysis of a fit replays the files the fit was made from: one changed since (a
  // sample re-imported, a recording re-exported) would give a report that contradicts it.
  if (fit)
    for (const auto& now : ex.inputs)
      for (const auto& then : fit->provenance.inputs)
        if (then.path == now.path && then.sha256 != now.sha256)
          throw InputError(now.path, "file",
                           fmt::format("the file the fit was made from (SHA-256 {}… in its fit.json)",
                                       then.sha256.substr(0, 12)),
                           fmt::format("changed since (now {}…)", now.sha256.substr(0, 12)));
  // validate pools the listings' samples per role (calibrate has checked before its fit;
  // an older calibrate directory is rendered as it was fitted).
  if (!fit) model::check_each_sample_used_once_per_role(ex);
  const model::ModelParams mp = model::ModelParams::from(params);
  model::check_covers(params, ex.samples, opt.params_file);
  const bool exclude_buried = ex.manifest.fit.buried == ds::BuriedPolicy::kExclude;

  AnalysisInput in;
  in.mode = fit ? "calibrate" : "validate";
  in.experiment_name = ex.manifest.name;
  in.experiment_description = ex.manifest.description;
  in.experiment_path = fs::absolute(manifest).string();
  in.experiment_sha256 = ex.sha256_of(manifest);
  in.context_of_use = opt.context_of_use;
  in.seed = ex.manifest.fit.seed;
  const model::ReplayOptions ropt{};
  in.model = {{"model", "voxel burr–bone contact, friction and erosion (MODEL.md)"},
              {"replay step", "half the median sample period"},
              {"erosion", ropt.erosion},
              {"burr radius (mm)", ex.manifest.burr.radius_mm},
              {"sensor measures", ds::to_string(ex.manifest.sensor.measures)},
              {"buried samples", ds::to_string(ex.manifest.fit.buried)}};
  // The nuisances the fit estimated (not those it held fixed), as this replay applies them.
  const auto fitted = [&](const char* prefix) {
    return fit && std::any_of(fit->nuisance.begin(), fit->nuisance.end(), [&](const ds::FitNuisance& n) {
             return n.name.rfind(prefix, 0) == 0 && !n.fixed;
           });
  };
  // A pose correction per fiducial-registered mounting (pose_rx … pose_tz), or none (a
  // given transform is taken as exact).
  const bool pose_fitted = fitted("pose_");
  if (fit) {
    std::vector<std::string> applied;
    if (fitted("bias_")) applied.push_back("bias");
    if (fitted("lag")) applied.push_back("lag");
    if (fitted("depth_offset")) applied.push_back("depth offset");
    if (fitted("torque_bias_")) applied.push_back("moment bias");
    if (fitted("spindle_")) applied.push_back("spindle idle and viscous terms");
    if (pose_fitted) applied.push_back("the registration's pose correction per sample mounting");
    in.calibration = {{"method", "Ceres least squares on the recorded sensor force (burrbench calibrate)"},
                      {"nuisances applied", applied.empty() ? std::string("none (all held fixed)")
                                                            : fmt::format("from fit.json: {}", fmt::join(applied, ", "))},
                      {"recordings without a fitted bias", opt.tare ? "tare: measured force minus its mean over samples with no predicted contact" : "none"}};
  } else {
    in.calibration = {{"method", "none: fixed parameters replayed (burrbench validate)"},
                      {"tare", opt.tare ? "measured force minus its mean over samples with no predicted contact"
                                        : "off"},
                      {"lag", "the manifest's lag_ms per recording"}};
  }
  in.limitations = {
      fmt::format("Each recording is replayed from the sample's unmodified state, so recordings of one sample "
                  "must drill separate spots: the replays checked that no two recordings removed the same bone "
                  "(beyond {:g} % of the smaller removal), and a pair that did is named below.",
                  100 * model::kOverlapShare),
      "The removed-bone picture shows, per voxel, the largest bone fraction any recording "
      "removed, summed along the volume z axis.",
      "Forces are compared in the sensor frame; the sensor's own calibration is taken as exact.",
      pose_fitted
          ? "The registration (rig to volume) is a measurement: calibrate fitted its pose correction per "
            "sample mounting, with the fiducial fit's covariance as its prior, so the parameter intervals "
            "include the registration's uncertainty; this replay applies the fitted correction. The "
            "registration column gives the fiducial RMS and Fitzpatrick's predicted TRE along the path."
          : std::string("The registration (rig to volume) is the manifest's (or the fiducial fit's) without a "
                        "correction") +
                (fit ? " (the fit estimated no pose: a given transform is taken as exact, or [fit.nuisance] pose "
                       "is off)"
                     : "") +
                ": its uncertainty is not propagated into these metrics" +
                (fit ? " nor into the constants' intervals" : "") +
                ". The registration column gives the fiducial RMS and Fitzpatrick's predicted TRE along the path: "
                "force is stiff in depth (about 20 N/mm at 0.5 mm immersion), so a TRE of a few micrometres is "
                "already comparable to the sensor noise."};
  for (const auto& [label, c] : params.classes)
    in.parameters.push_back({int(label), c.name, c.alpha_N_per_mm2, c.c1_N_per_mm2, c.mu});

  // The one path from model to prediction (model::predict_experiment), with the fit's
  // nuisances, the tare for what the fit did not estimate, the band and the removed bone.
  model::PredictOptions po;
  po.replay = ropt;
  po.fit = fit;
  po.tare = opt.tare;
  po.exclude_buried = exclude_buried;
  po.removed_bone = true;
  po.progress = opt.progress;
  po.threads = opt.threads;
  const ds::FitResult* band_fit = opt.band_fit ? opt.band_fit : fit;
  const model::BandCovariance band = band_fit ? model::band_covariance(*band_fit, params) : model::BandCovariance{};
  po.band = &band;
  model::ExperimentPrediction pred = model::predict_experiment(ex, mp, po);
  for (const model::RemovedOverlap& o : pred.overlaps) {
    in.limitations.push_back(o.text());
    if (opt.warn) fmt::print(stderr, "warning: {}\n", in.limitations.back());
  }
  for (const std::string& w : model::alignment_warnings(ex)) {
    in.limitations.push_back(w);
    if (opt.warn) fmt::print(stderr, "warning: {}\n", w);
  }
  // What the data say about the sensor, over the samples either role counts: a zero that
  // moved during a recording (the fitted bias, or the tare, is one number per recording and
  // channel: calibration::zero_drift, the force's and the moment's), readings that fit the
  // prediction better in a turned or mirrored frame (calibration::SensorFrameCheck, which
  // centres each recording: its bias or tare is one constant), friction that acts against
  // its predicted direction (calibration::FrictionDirectionCheck: a spin the other way round)
  // and a force that follows the prediction at another lag than the one replayed
  // (analysis::lag_mismatch).
  auto limitation = [&](std::string w) {
    if (w.empty()) return;
    if (opt.warn) fmt::print(stderr, "warning: {}\n", w);
    in.limitations.push_back(std::move(w));
  };
  calibration::SensorFrameCheck frame;
  calibration::FrictionDirectionCheck friction;
  for (const auto& p : pred.recordings) {
    std::vector<double> counted(p.t_s.size());
    for (std::size_t k = 0; k < counted.size(); ++k) counted[k] = p.used_calibrate[k] || p.used_validate[k];
    auto drift = [&](const std::vector<glm::dvec3>& measured, calibration::DriftChannel channel) {
      if (measured.empty()) return;
      const auto d = calibration::zero_drift(p.t_s, measured, p.class_mask, counted);
      limitation(d ? d->text(p.recording_id, channel) : "");
    };
    drift(p.force_sensor_meas_N, calibration::kForceChannel);
    drift(p.torque_sensor_meas_Nmm, calibration::kMomentChannel);
    frame.add(p.force_sensor_pred_N, p.force_sensor_meas_N, p.class_mask, counted);
    friction.add(p.force_sensor_pred_N, p.friction_sensor_pred_N, p.force_sensor_meas_N, p.class_mask, counted);
    const auto lag = analysis::lag_mismatch(p.t_s, p.force_sensor_pred_N, p.force_sensor_meas_N, counted);
    limitation(lag ? lag->text(p.recording_id, p.lag_ms) : "");
  }
  for (std::string& w : calibration::frame_and_friction_lines(frame.result(), friction.result(),
                                                              ex.manifest.sensor.rotation_sensor_to_rig,
                                                              ex.manifest.burr.spin_sign))
    limitation(std::move(w));
  std::vector<std::string> no_band;
  for (const auto& p : pred.recordings)
    if (p.band_diverged) no_band.push_back(p.recording_id);
  if (!no_band.empty()) {
    const std::string msg = fmt::format(
        "No prediction band for {}: the forward sensitivities of its replay diverged (not finite, or above {:g} "
        "x the largest predicted force per unit of a constant; the explicit erosion step's tangent is unstable "
        "where erosion is fast against the step, e.g. on a sample coarser than the fit's). The band is left out "
        "rather than drawn from them; the prediction itself is unaffected.",
        fmt::join(no_band, ", "), model::kMaxSensitivityRatio);
    in.limitations.push_back(msg);
    fmt::print(stderr, "warning: {}\n", msg);
  }

  for (std::size_t i = 0; i < ex.recordings.size(); ++i) {
    const auto& r = ex.recordings[i];
    const auto& p = pred.recordings[i];
    const auto* ref = ex.manifest.recording(r.id);
    BURRBENCH_CHECK(ref, "aligned recording without manifest entry");
    RecordingSeries rs = series_of(ex, r, *ref, p, params);
    // A recording whose segments carry both roles appears once per role, each with its
    // own used samples (its fitted nuisances are the recording's, whichever the role).
    const bool cal = std::any_of(r.use_calibrate.begin(), r.use_calibrate.end(), [](auto u) { return u != 0; });
    const bool val = std::any_of(r.use_validate.begin(), r.use_validate.end(), [](auto u) { return u != 0; });
    if (cal && val) {
      RecordingSeries v = rs;
      rs.role = ds::to_string(ds::RecordingRole::kCalibrate);
      v.role = ds::to_string(ds::RecordingRole::kValidate);
      v.id = r.id + "@validate";  // ids are unique in analysis.json
      rs.used.assign(p.used_calibrate.begin(), p.used_calibrate.end());
      v.used.assign(p.used_validate.begin(), p.used_validate.end());
      auto keep = [&](RecordingSeries& s, ds::RecordingRole role) {
        s.segments.clear();
        for (const auto& seg : ref->segments)
          if (seg.use && seg.role.value_or(ref->role) == role)
            s.segments.push_back({seg.label.empty() ? "segment" : seg.label, seg.start_s, seg.end_s});
      };
      keep(rs, ds::RecordingRole::kCalibrate);
      keep(v, ds::RecordingRole::kValidate);
      in.recordings.push_back(std::move(rs));
      in.recordings.push_back(std::move(v));
      continue;
    }
    in.recordings.push_back(std::move(rs));
  }

  for (const auto& rb : pred.removed) {
    const auto* sref = ex.manifest.sample(rb.sample_id);
    BURRBENCH_CHECK(sref, "removed bone of a sample without manifest entry");
    SampleInfo si;
    si.id = rb.sample_id;
    si.path = sref->path.string();
    si.sha256 = ex.sha256_of(sref->path);
    si.voxel_mm = rb.voxel_mm;
    si.nx = rb.nx;
    si.ny = rb.ny;
    si.removed_depth_mm = rb.removed_depth_mm;
    si.removed_class = rb.removed_class;
    si.removed_volume_mm3 = rb.removed_volume_mm3;
    for (const auto& [label, name] : ex.samples.at(rb.sample_id).classes) si.classes[int(label)] = name;
    in.samples.push_back(std::move(si));
  }

  // The files as they were read; and none changed while they were replayed.
  in.provenance = make_provenance_hashed(ex.inputs);
  check_unchanged(ex.inputs, "the replay");
  if (opt.prediction) *opt.prediction = std::move(pred);
  return in;
}

AnalysisInput replay_calibrate_directory(const fs::path& dir, const std::string& context_of_use,
                                        model::ExperimentPrediction* prediction, int threads) {
  const auto f = ds::read_fit(dir / "fit.json");  // validates
  if (f.experiment_path.empty() || !fs::exists(f.experiment_path))
    throw InputError((dir / "fit.json").string(), "experiment_path", "an existing experiment manifest", f.experiment_path);
  if (sha256_file(f.experiment_path) != f.experiment_sha256)
    throw InputError(f.experiment_path, "sha256", "the manifest the fit was made from (" + f.experiment_sha256 + ")",
                     "changed since");
  // params.toml is what calibrate hands on (the values the fit held); the fit's estimates
  // only when it is absent.
  const bool has_params = fs::exists(dir / "params.toml");
  const auto params = has_params ? ds::read_params(dir / "params.toml")
                                 : ds::parameter_set_from(f, (dir / "fit.json").string());
  AnalysisInput in = replay_experiment(f.experiment_path, params, &f,
                                       {true, context_of_use, nullptr,
                                        (dir / (has_params ? "params.toml" : "fit.json")).string(), nullptr,
                                        prediction, threads});
  if (has_params) {
    in.params_path = fs::absolute(dir / "params.toml").string();
    in.params_sha256 = sha256_file(dir / "params.toml");
  }
  for (const char* name : {"fit.json", "params.toml"})
    if (fs::exists(dir / name)) in.provenance.inputs.push_back({(dir / name).string(), sha256_file(dir / name)});
  return in;
}

}  // namespace burrbench::apps
