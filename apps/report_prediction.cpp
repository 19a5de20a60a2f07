#include "report_prediction.hpp"

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
namespace fs = std::filesystem;
namespace ds = data_schema;
using nlohmann::json;

namespace {

// The report of a fit replays the files the fit was made from: one changed since (a sample
// re-imported, a recording re-exported) would give a report that contradicts it.
void check_fit_inputs(const model::Experiment& ex, const ds::FitResult& fit) {
  for (const auto& now : ex.inputs)
    for (const auto& then : fit.provenance.inputs)
      if (then.path == now.path && then.sha256 != now.sha256)
        throw InputError(now.path, "file",
                         fmt::format("the file the fit was made from (SHA-256 {}… in its fit.json)",
                                     then.sha256.substr(0, 12)),
                         fmt::format("changed since (now {}…)", now.sha256.substr(0, 12)));
}

// Did the fit estimate (not hold fixed) a nuisance whose name starts with `prefix`?
bool fitted(const ds::FitResult* fit, const char* prefix) {
  return fit && std::any_of(fit->nuisance.begin(), fit->nuisance.end(), [&](const ds::FitNuisance& n) {
           return n.name.rfind(prefix, 0) == 0 && !n.fixed;
         });
}

json model_settings(const model::Experiment& ex, const model::ReplayOptions& ropt) {
  return {{"model", "voxel burr–bone contact, friction and erosion (MODEL.md)"},
          {"replay step", "half the median sample period"},
          {"erosion", ropt.erosion},
          {"burr radius (mm)", ex.manifest.burr.radius_mm},
          {"sensor measures", ds::to_string(ex.manifest.sensor.measures)},
          {"buried samples", ds::to_string(ex.manifest.fit.buried)}};
}

// What the replay applied: the fit's nuisances (those it estimated, not those it held
// fixed), or the tare and the manifest's lag.
json calibration_settings(const ReportPredictionOptions& opt) {
  const std::string tare = "measured force minus its mean over samples with no predicted contact";
  if (opt.made_by == "validate" && !opt.fit)
    return {{"method", "none: fixed parameters replayed (burrbench validate)"},
            {"tare", opt.tare ? tare : "off"},
            {"lag", "the manifest's lag_ms per recording"}};
  std::vector<std::string> applied;
  for (const auto& [prefix, name] : {std::pair{"bias_", "bias"}, {"lag", "lag"}, {"depth_offset", "depth offset"},
                                     {"torque_bias_", "moment bias"}, {"spindle_", "spindle idle and viscous terms"},
                                     {"pose_", "the registration's pose correction per sample mounting"}})
    if (fitted(opt.fit, prefix)) applied.push_back(name);
  json j = {{"method", opt.made_by == "calibrate"
                           ? "Ceres least squares on the recorded sensor force (burrbench calibrate)"
                           : "none: the fit's constants replayed at its nuisances (burrbench validate --fit)"},
            {"nuisances applied", applied.empty() ? std::string("none (all held fixed)")
                                                  : fmt::format("from fit.json: {}", fmt::join(applied, ", "))},
            {"recordings without a fitted bias", opt.tare ? "tare: " + tare : "none"}};
  if (opt.made_by == "validate")
    j["lag"] = "the fit's lag per recording it fitted (fit.json nuisance lag_*), else the manifest's lag_ms";
  return j;
}

std::vector<std::string> standing_limitations(bool pose_fitted, bool has_fit) {
  return {
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
                (has_fit ? " (the fit estimated no pose: a given transform is taken as exact, or [fit.nuisance] "
                           "pose is off)"
                         : "") +
                ": its uncertainty is not propagated into these metrics" +
                (has_fit ? " nor into the constants' intervals" : "") +
                ". The registration column gives the fiducial RMS and Fitzpatrick's predicted TRE along the path: "
                "force is stiff in depth (about 20 N/mm at 0.5 mm immersion), so a TRE of a few micrometres is "
                "already comparable to the sensor noise."};
}

// What the data say about the sensor, over the samples either role counts: a zero that
// moved during a recording (the fitted bias, or the tare, is one number per recording and
// channel: calibration::zero_drift, the force's and the moment's), readings that fit the
// prediction better in a turned or mirrored frame (calibration::SensorFrameCheck, which
// centres each recording: its bias or tare is one constant), friction that acts against
// its predicted direction (calibration::FrictionDirectionCheck: a spin the other way round),
// a force that follows the prediction at another lag than the one replayed
// (analysis::lag_mismatch) and a band left out because its sensitivities diverged.
std::vector<std::string> data_findings(const model::Experiment& ex, const model::ExperimentPrediction& pred) {
  std::vector<std::string> out;
  for (const model::RemovedOverlap& o : pred.overlaps) out.push_back(o.text());
  for (const std::string& w : model::alignment_warnings(ex)) out.push_back(w);
  auto add = [&](std::string w) {
    if (!w.empty()) out.push_back(std::move(w));
  };
  calibration::SensorFrameCheck frame;
  calibration::FrictionDirectionCheck friction;
  for (const auto& p : pred.recordings) {
    std::vector<double> counted(p.t_s.size());
    for (std::size_t k = 0; k < counted.size(); ++k) counted[k] = p.used_calibrate[k] || p.used_validate[k];
    auto drift = [&](const std::vector<glm::dvec3>& measured, calibration::DriftChannel channel) {
      if (measured.empty()) return;
      const auto d = calibration::zero_drift(p.t_s, measured, p.class_mask, counted);
      add(d ? d->text(p.recording_id, channel) : "");
    };
    drift(p.force_sensor_meas_N, calibration::kForceChannel);
    drift(p.torque_sensor_meas_Nmm, calibration::kMomentChannel);
    frame.add(p.force_sensor_pred_N, p.force_sensor_meas_N, p.class_mask, counted);
    friction.add(p.force_sensor_pred_N, p.friction_sensor_pred_N, p.force_sensor_meas_N, p.class_mask, counted);
    const auto lag = analysis::lag_mismatch(p.t_s, p.force_sensor_pred_N, p.force_sensor_meas_N, counted);
    add(lag ? lag->text(p.recording_id, p.lag_ms) : "");
  }
  for (std::string& w : calibration::frame_and_friction_lines(frame.result(), friction.result(),
                                                              ex.manifest.sensor.rotation_sensor_to_rig,
                                                              ex.manifest.burr.spin_sign))
    add(std::move(w));
  std::vector<std::string> no_band;
  for (const auto& p : pred.recordings)
    if (p.band_diverged) no_band.push_back(p.recording_id);
  if (!no_band.empty())
    out.push_back(fmt::format(
        "No prediction band for {}: the forward sensitivities of its replay diverged (not finite, or above {:g} "
        "x the largest predicted force per unit of a constant; the explicit erosion step's tangent is unstable "
        "where erosion is fast against the step, e.g. on a sample coarser than the fit's). The band is left out "
        "rather than drawn from them; the prediction itself is unaffected.",
        fmt::join(no_band, ", "), model::kMaxSensitivityRatio));
  return out;
}

// The session's log as the report's data-quality table shows it, with the stretches
// without force samples the replay followed the stage through.
json quality_of(const model::AlignedRecording& r) {
  std::vector<model::AlignedRecording::SessionEvent> events = r.events;
  json ev = json::array();
  std::vector<std::tuple<double, std::string, std::string, std::string>> rows;
  for (const auto& e : events) rows.emplace_back(e.t_s, e.kind, e.stream, e.detail);
  for (const auto& s : r.silences())
    rows.emplace_back(s.from_s, "force_silent", r.force_stream,
                      fmt::format("no force sample for {:.4g} s: the replay followed the stage's path through it "
                                  "(docs/replay.md \"Alignment and lag\")",
                                  s.to_s - s.from_s));
  std::stable_sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return std::get<0>(a) < std::get<0>(b); });
  for (const auto& [t, kind, stream, detail] : rows)
    ev.push_back({{"t_s", t}, {"kind", kind}, {"stream", stream}, {"detail", detail}});
  return {{"dropped_force_samples", r.dropped_force_samples}, {"stale_rows", r.stale_rows}, {"events", ev}};
}

json recordings_context(const model::Experiment& ex) {
  json out = json::object();
  for (const auto& r : ex.recordings) {
    const auto* ref = ex.manifest.recording(r.id);
    BURRBENCH_CHECK(ref, "aligned recording without manifest entry");
    json segs = json::array();
    for (const auto& seg : ref->segments)
      if (seg.use)
        segs.push_back({{"label", seg.label.empty() ? "segment" : seg.label}, {"start_s", seg.start_s},
                        {"end_s", seg.end_s}, {"role", ds::to_string(seg.role.value_or(ref->role))}});
    out[r.id] = {{"sample", r.sample_id}, {"path", r.file.string()}, {"sha256", ex.sha256_of(r.file)},
                 {"notes", r.notes},      {"registration", r.registration.text()},
                 {"segments", segs},      {"quality", quality_of(r)}};
  }
  return out;
}

json samples_context(const model::Experiment& ex) {
  json out = json::object();
  for (const auto& s : ex.manifest.samples) {
    json classes = json::object();
    for (const auto& [label, name] : ex.samples.at(s.id).classes) classes[std::to_string(int(label))] = name;
    out[s.id] = {{"path", s.path.string()}, {"sha256", ex.sha256_of(s.path)}, {"classes", classes}};
  }
  return out;
}

json parameters_context(const ds::ParameterSet& params) {
  json out = json::array();
  for (const auto& [label, c] : params.classes)
    out.push_back({{"class_label", int(label)}, {"class_name", c.name}, {"alpha_N_per_mm2", c.alpha_N_per_mm2},
                   {"c1_N_per_mm2", c.c1_N_per_mm2}, {"mu", c.mu}});
  return out;
}

}  // namespace

ds::Prediction predict_for_report(const fs::path& manifest, const ds::ParameterSet& params,
                                  const ReportPredictionOptions& opt) {
  const model::Experiment ex = model::load_experiment(manifest);
  if (opt.fit) check_fit_inputs(ex, *opt.fit);
  // validate pools the listings' samples per role (calibrate has checked before its fit).
  if (opt.made_by == "validate") model::check_each_sample_used_once_per_role(ex);
  model::check_covers(params, ex.samples, opt.params_file);

  model::PredictOptions po;
  po.fit = opt.fit;
  po.tare = opt.tare;
  po.exclude_buried = ex.manifest.fit.buried == ds::BuriedPolicy::kExclude;
  po.removed_bone = true;
  po.progress = opt.progress;
  po.threads = opt.threads;
  const model::BandCovariance band = opt.fit ? model::band_covariance(*opt.fit, params) : model::BandCovariance{};
  po.band = &band;
  model::ExperimentPrediction pred = model::predict_experiment(ex, model::ModelParams::from(params), po);

  std::vector<std::string> findings = standing_limitations(fitted(opt.fit, "pose_"), opt.fit != nullptr);
  for (std::string& w : data_findings(ex, pred)) {
    if (opt.warn) fmt::print(stderr, "warning: {}\n", w);
    findings.push_back(std::move(w));
  }
  ds::Prediction out;
  out.context = {{"made_by", opt.made_by},
                 {"experiment", {{"name", ex.manifest.name}, {"description", ex.manifest.description},
                                 {"path", fs::absolute(manifest).string()}, {"sha256", ex.sha256_of(manifest)}}},
                 {"context_of_use", opt.context_of_use},
                 {"seed", ex.manifest.fit.seed},
                 {"params", {{"path", ""}, {"sha256", ""}}},
                 {"model", model_settings(ex, po.replay)},
                 {"calibration", calibration_settings(opt)},
                 {"findings", findings},
                 {"parameters", parameters_context(params)},
                 {"samples", samples_context(ex)},
                 {"recordings", recordings_context(ex)}};
  out.recordings.assign(pred.recordings.begin(), pred.recordings.end());  // the records without wall_s
  out.removed = std::move(pred.removed);
  // The files as they were read; and none changed while they were replayed.
  out.provenance = make_provenance_hashed(ex.inputs);
  check_unchanged(ex.inputs, "the replay");
  return out;
}

}  // namespace burrbench::apps
