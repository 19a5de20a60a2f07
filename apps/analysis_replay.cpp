#include "analysis_replay.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/model_params.hpp"
#include "burrbench/model/registration.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/model/sensitivity.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::apps {
using namespace analysis;
namespace fs = std::filesystem;
namespace ds = data_schema;

namespace {

constexpr std::size_t kMinTareSamples = 10;

// The fit's nuisance value for a recording, or `fallback` when absent/undefined.
double nuisance(const ds::FitResult* fit, const std::string& rec, const std::string& name,
                double fallback) {
  if (!fit) return fallback;
  for (const auto& n : fit->nuisance)
    if (n.recording_id == rec && n.name == name && std::isfinite(n.estimate)) return n.estimate;
  return fallback;
}

// The registration's pose correction the fit held for a recording (fit.json
// settings.registration.<id>.pose_correction), if one was fitted.
std::optional<model::PoseCorrection> fitted_pose(const ds::FitResult* fit, const std::string& rec) {
  if (!fit || !fit->settings.contains("registration")) return std::nullopt;
  const auto& reg = fit->settings["registration"];
  if (!reg.is_object() || !reg.contains(rec) || !reg[rec].is_object() || !reg[rec].contains("pose_correction"))
    return std::nullopt;
  const auto& pc = reg[rec]["pose_correction"];
  const auto vec = [&](const char* key) {
    const auto& a = pc.at(key);
    if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() || !a[2].is_number())
      throw InputError("fit.json", fmt::format("settings.registration.{}.pose_correction.{}", rec, key),
                       "3 numbers");
    return glm::dvec3(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
  };
  if (!pc.contains("rotation_rad") || !pc.contains("translation_mm") || !pc.contains("centre_vol_mm"))
    throw InputError("fit.json", fmt::format("settings.registration.{}.pose_correction", rec),
                     "rotation_rad, translation_mm and centre_vol_mm");
  model::PoseCorrection p;
  p.rotation_rad = vec("rotation_rad");
  p.translation_mm = vec("translation_mm");
  p.centre_vol_mm = vec("centre_vol_mm");
  return p;
}

// The moments and the spindle's load beside the force (MODEL.md "Moments"): predicted
// with the fit's moment bias and spindle idle/viscous terms, or, without a fit, with the
// tare (the measured mean over samples with no predicted contact), as for the force.
void fill_wrench(const model::AlignedRecording& r, const model::ReplayResult& res,
                 const model::Trajectory& tr, const ds::FitResult* fit, bool tare, RecordingSeries& rs) {
  const std::size_t n = res.samples.size();
  auto no_contact = [&](std::size_t k) { return res.samples[k].contact.class_mask == 0; };
  if (r.torque_sensor_Nmm.size() == n) {
    rs.torque_measured_Nmm = r.torque_sensor_Nmm;
    rs.torque_predicted_Nmm.resize(n);
    glm::dvec3 free_sum(0);
    std::size_t free_n = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const auto& c = res.samples[k].contact;
      rs.torque_predicted_Nmm[k] = r.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, tr.centre_vol_mm[k]);
      if (no_contact(k)) {
        free_sum += r.torque_sensor_Nmm[k] - rs.torque_predicted_Nmm[k];
        ++free_n;
      }
    }
    glm::dvec3 bias(nuisance(fit, r.id, "torque_bias_x", NAN), nuisance(fit, r.id, "torque_bias_y", NAN),
                    nuisance(fit, r.id, "torque_bias_z", NAN));
    if (!std::isfinite(bias.x))
      bias = tare && free_n >= kMinTareSamples ? free_sum / double(free_n) : glm::dvec3(0);
    for (auto& p : rs.torque_predicted_Nmm) p += bias;
  }
  if (!r.spindle_torque_Nmm.t_s.empty()) {
    rs.spindle_measured_Nmm.resize(n);
    rs.spindle_predicted_Nmm.resize(n);
    rs.spindle_offset_Nmm.resize(n);
    rs.spin_rad_s.resize(n);
    // The drive's viscous term acts on the speed's deviation from the recording's mean
    // (model::AlignedRecording::spindle_krpm_deviation, as in the fit).
    const std::vector<double> krpm = r.spindle_krpm_deviation();
    // The tare: the drive's load without contact while spinning, fitted as idle + slope·krpm
    // by least squares (a mean when the speed never changes), so samples with the spindle
    // stopped or at another speed do not bias it.
    double s1 = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (std::size_t k = 0; k < n; ++k) {
      rs.spindle_measured_Nmm[k] = r.spindle_torque_Nmm.at(r.t_s[k]);
      rs.spindle_predicted_Nmm[k] = model::spindle_torque_Nmm(res.samples[k].contact.moment_Nmm, tr.omega_vol_rad_s[k]);
      rs.spin_rad_s[k] = glm::length(tr.omega_vol_rad_s[k]);
      if (no_contact(k) && rs.spin_rad_s[k] > 0) {
        const double y = rs.spindle_measured_Nmm[k];
        s1 += 1;
        sx += krpm[k];
        sy += y;
        sxx += krpm[k] * krpm[k];
        sxy += krpm[k] * y;
      }
    }
    const double idle = nuisance(fit, r.id, "spindle_idle", NAN);
    const double viscous = nuisance(fit, r.id, "spindle_viscous", 0.0);
    const bool can_tare = tare && s1 >= double(kMinTareSamples);
    rs.spindle_offset_source = std::isfinite(idle) ? "fit" : can_tare ? "tare" : "none";
    double tare_a = 0, tare_b = 0;
    if (can_tare) {
      const double det = s1 * sxx - sx * sx;
      if (det / (s1 * s1) > 1e-6) {  // the speed varies by more than ~1 rpm
        tare_b = (s1 * sxy - sx * sy) / det;
        tare_a = (sy - tare_b * sx) / s1;
      } else {
        tare_a = sy / s1;
      }
    }
    for (std::size_t k = 0; k < n; ++k) {
      rs.spindle_offset_Nmm[k] = std::isfinite(idle) ? idle + viscous * krpm[k]
                                                     : can_tare ? tare_a + tare_b * krpm[k] : 0.0;
      rs.spindle_predicted_Nmm[k] += rs.spindle_offset_Nmm[k];
    }
  }
}

// The fitted constants that have a covariance, as sensitivity directions, with their
// covariance in ln θ (fit.json's is in natural units: C_ln = C / (θ_a θ_b)).
struct BandDirections {
  std::vector<model::Direction> dirs;
  std::vector<double> cov_ln;  // dirs.size()² row-major
};

BandDirections band_directions(const ds::FitResult* fit, const ds::ParameterSet& params, const model::ModelParams& mp) {
  BandDirections out;
  if (!fit || fit->covariance.size() == 0) return out;
  std::vector<std::size_t> at;
  std::vector<double> value;
  for (const auto& [label, c] : params.classes)
    for (const auto kind : {model::Direction::Kind::kLogAlpha, model::Direction::Kind::kLogC1, model::Direction::Kind::kLogMu}) {
      const char* k = kind == model::Direction::Kind::kLogAlpha ? "alpha" : kind == model::Direction::Kind::kLogC1 ? "c1" : "mu";
      const auto& names = fit->covariance.names;
      const auto it = std::find(names.begin(), names.end(), c.name + "." + k);
      const auto& cc = mp.by_label[label];
      const double v = kind == model::Direction::Kind::kLogAlpha ? cc.alpha_N_per_mm2
                       : kind == model::Direction::Kind::kLogC1  ? cc.c1_N_per_mm2
                                                                 : cc.mu;
      if (it == names.end() || !std::isfinite(v) || !(v > 0) || out.dirs.size() >= model::kMaxDirections) continue;
      model::Direction d;
      d.kind = kind;
      d.label = label;
      out.dirs.push_back(d);
      at.push_back(std::size_t(it - names.begin()));
      value.push_back(v);
    }
  const std::size_t m = at.size();
  out.cov_ln.resize(m * m);
  for (std::size_t a = 0; a < m; ++a)
    for (std::size_t b = 0; b < m; ++b) out.cov_ln[a * m + b] = fit->covariance.at(at[a], at[b]) / (value[a] * value[b]);
  return out;
}

}  // namespace

AnalysisInput replay_experiment(const fs::path& manifest, const ds::ParameterSet& params,
                                const ds::FitResult* fit, const ReplayInputOptions& opt) {
  const model::Experiment ex = model::load_experiment(manifest);
  const model::ModelParams mp = model::ModelParams::from(params);
  model::check_covers(params, ex.samples, opt.params_file);
  const bool exclude_buried = ex.manifest.fit.buried == ds::BuriedPolicy::kExclude;

  AnalysisInput in;
  in.mode = fit ? "calibrate" : "validate";
  in.experiment_name = ex.manifest.name;
  in.experiment_description = ex.manifest.description;
  in.experiment_path = fs::absolute(manifest).string();
  in.experiment_sha256 = sha256_file(manifest);
  in.context_of_use = opt.context_of_use;
  in.seed = ex.manifest.fit.seed;
  const model::ReplayOptions ropt{};
  in.model = {{"model", "voxel burr–bone contact, friction and erosion (MODEL.md)"},
              {"replay step", "half the median sample period"},
              {"erosion", ropt.erosion},
              {"burr radius (mm)", ex.manifest.burr.radius_mm},
              {"sensor measures", ds::to_string(ex.manifest.sensor.measures)},
              {"buried samples", ds::to_string(ex.manifest.fit.buried)}};
  if (fit) {
    in.calibration = {{"method", "Ceres least squares on the recorded sensor force (burrbench calibrate)"},
                      {"nuisances applied", "per-recording bias, lag, depth offset and the registration's "
                                            "pose correction per sample mounting, from fit.json"},
                      {"recordings without a fitted bias", opt.tare ? "tare: measured force minus its mean over samples with no predicted contact" : "none"}};
  } else {
    in.calibration = {{"method", "none: fixed parameters replayed (burrbench validate)"},
                      {"tare", opt.tare ? "measured force minus its mean over samples with no predicted contact"
                                        : "off"},
                      {"lag", "the manifest's lag_ms per recording"}};
  }
  in.limitations = {
      "Each recording is replayed from the sample's unmodified state (recordings are assumed "
      "not to overlap in removed bone).",
      "The removed-bone picture shows, per voxel, the largest bone fraction any recording "
      "removed, summed along the volume z axis.",
      "Forces are compared in the sensor frame; the sensor's own calibration is taken as exact.",
      fit ? "The registration (rig to volume) is a measurement: calibrate fitted its pose correction per "
            "sample mounting, with the fiducial fit's covariance as its prior, so the parameter intervals "
            "include the registration's uncertainty; this replay applies the fitted correction. The "
            "registration column gives the fiducial RMS and Fitzpatrick's predicted TRE along the path."
          : "The registration (rig to volume) is the manifest's (or the fiducial fit's) without a "
            "correction: its uncertainty is not propagated into these metrics. The registration column "
            "gives the fiducial RMS and Fitzpatrick's predicted TRE along the path: force is stiff in depth "
            "(about 20 N/mm at 0.5 mm immersion), so a TRE of a few micrometres is already comparable to "
            "the sensor noise."};
  for (const auto& [label, c] : params.classes)
    in.parameters.push_back({int(label), c.name, c.alpha_N_per_mm2, c.c1_N_per_mm2, c.mu});

  // Removed χ per sample: per voxel the largest removal by any recording.
  std::map<std::string, std::vector<float>> removed;
  std::map<std::string, model::Volume> pristine;
  for (const auto& [id, s] : ex.samples) {
    pristine.emplace(id, model::Volume::from_sample(s));
    removed[id].assign(s.voxel_count(), 0.0f);
  }

  for (const auto& r : ex.recordings) {
    const auto* ref = ex.manifest.recording(r.id);
    BURRBENCH_CHECK(ref, "aligned recording without manifest entry");
    model::Volume vol = pristine.at(r.sample_id);
    const double lag_s = nuisance(fit, r.id, "lag", r.lag_s * 1000.0) / 1000.0;
    const double depth_mm = nuisance(fit, r.id, "depth_offset", 0.0);
    const auto pose = fitted_pose(fit, r.id);
    const model::Trajectory tr = r.trajectory(lag_s, depth_mm, pose ? &*pose : nullptr);
    // restore = false: the eroded state is what the removed-bone picture shows. With a
    // fit, the replay also differentiates the force in the fitted constants (the band).
    const BandDirections band = band_directions(opt.band_fit ? opt.band_fit : fit, params, mp);
    model::Sensitivities sens;
    model::ReplayOptions ro = ropt;
    if (!band.dirs.empty()) {
      ro.directions = &band.dirs;
      ro.sensitivities = &sens;
    }
    const model::ReplayResult res = model::replay(vol, r.radius_mm, mp, tr, ro, false, opt.progress);
    auto& rem = removed[r.sample_id];
    const auto& p0 = pristine.at(r.sample_id);
    for (std::size_t i = 0; i < rem.size(); ++i)
      rem[i] = std::max(rem[i], float(p0.chi(i) - vol.chi(i)));

    RecordingSeries rs;
    rs.id = r.id;
    rs.sample_id = r.sample_id;
    rs.role = ds::to_string(ref->role);
    rs.path = r.file.string();
    rs.sha256 = sha256_file(r.file);
    rs.registration = r.registration.text();
    rs.notes = r.notes;
    rs.quality.dropped_force_samples = r.dropped_force_samples;
    rs.quality.stale_rows = r.stale_rows;
    for (const auto& e : r.events) rs.quality.events.push_back({e.t_s, e.kind, e.stream, e.detail});
    for (const auto& seg : ref->segments)
      if (seg.use) rs.segments.push_back({seg.label.empty() ? "segment" : seg.label, seg.start_s, seg.end_s});
    rs.t_s = r.t_s;
    rs.measured_N = r.force_sensor_N;
    const std::size_t n = res.samples.size();
    BURRBENCH_CHECK(n == r.t_s.size(), "replay returned a different sample count");
    rs.predicted_N.resize(n);
    rs.used.resize(n);
    glm::dvec3 bias(nuisance(fit, r.id, "bias_x", 0), nuisance(fit, r.id, "bias_y", 0),
                    nuisance(fit, r.id, "bias_z", 0));
    glm::dvec3 free_sum(0);
    std::size_t free_n = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const auto& c = res.samples[k].contact;
      rs.predicted_N[k] = r.sensor_force_from_burr_force(c.force_N);
      rs.used[k] = r.use[k] && !(exclude_buried && c.buried);
      rs.quality.buried_samples += c.buried != 0;
      if (c.class_mask == 0) {
        free_sum += r.force_sensor_N[k];
        ++free_n;
      }
    }
    // Held-out recordings of a calibration have no fitted bias: they get the tare too.
    const bool fitted_bias = fit && std::isfinite(nuisance(fit, r.id, "bias_x", NAN));
    if (!fitted_bias && opt.tare && free_n >= kMinTareSamples) bias = free_sum / double(free_n);
    for (auto& p : rs.predicted_N) p += bias;  // the bias is added to the prediction
    if (!band.dirs.empty()) {
      // 95 % band of the prediction from the constants' uncertainty alone (delta method):
      // per axis 1.96·√(gᵀ C g), g = ∂F_sensor/∂ln θ.
      const std::size_t m = band.dirs.size();
      rs.band95_N.resize(n);
      for (std::size_t k = 0; k < n; ++k) {
        std::vector<glm::dvec3> g(m);
        for (std::size_t a = 0; a < m; ++a) g[a] = r.sensor_force_from_burr_force(sens.dforce_N[a][k]);
        glm::dvec3 var(0);
        for (std::size_t a = 0; a < m; ++a)
          for (std::size_t b = 0; b < m; ++b) var += g[a] * g[b] * band.cov_ln[a * m + b];
        rs.band95_N[k] = 1.959963984540054 * glm::sqrt(glm::max(var, glm::dvec3(0)));
      }
    }
    fill_wrench(r, res, tr, fit, opt.tare, rs);
    for (const auto& [label, c] : params.classes)
      if (res.removed_mm3[std::size_t(label)] > 0 || res.friction_energy_mJ[std::size_t(label)] > 0)
        rs.energy.push_back({int(label), c.name, c.alpha_N_per_mm2, res.removed_mm3[std::size_t(label)],
                             res.friction_energy_mJ[std::size_t(label)]});
    // A recording whose segments carry both roles appears once per role, each with its
    // own used samples (its fitted nuisances are the recording's, whichever the role).
    const bool both = std::any_of(r.use_calibrate.begin(), r.use_calibrate.end(), [](auto u) { return u != 0; }) &&
                      std::any_of(r.use_validate.begin(), r.use_validate.end(), [](auto u) { return u != 0; });
    if (both) {
      RecordingSeries val = rs;
      rs.role = ds::to_string(ds::RecordingRole::kCalibrate);
      val.role = ds::to_string(ds::RecordingRole::kValidate);
      val.id = r.id + "@validate";  // ids are unique in analysis.json
      for (std::size_t k = 0; k < n; ++k) {
        rs.used[k] = rs.used[k] && r.use_calibrate[k];
        val.used[k] = val.used[k] && r.use_validate[k];
      }
      auto keep = [&](RecordingSeries& s, ds::RecordingRole role) {
        s.segments.clear();
        for (const auto& seg : ref->segments)
          if (seg.use && seg.role.value_or(ref->role) == role)
            s.segments.push_back({seg.label.empty() ? "segment" : seg.label, seg.start_s, seg.end_s});
      };
      keep(rs, ds::RecordingRole::kCalibrate);
      keep(val, ds::RecordingRole::kValidate);
      in.recordings.push_back(std::move(rs));
      in.recordings.push_back(std::move(val));
      continue;
    }
    in.recordings.push_back(std::move(rs));
  }


  for (const auto& sref : ex.manifest.samples) {
    const auto& s = ex.samples.at(sref.id);
    SampleInfo si;
    si.id = sref.id;
    si.path = sref.path.string();
    si.sha256 = sha256_file(sref.path);
    si.voxel_mm = s.voxel_mm;
    si.nx = s.dims[0];
    si.ny = s.dims[1];
    si.removed_depth_mm.assign(si.nx * si.ny, 0.0f);
    const auto& rem = removed.at(sref.id);
    double total = 0;
    for (std::size_t z = 0; z < s.dims[2]; ++z)
      for (std::size_t y = 0; y < si.ny; ++y)
        for (std::size_t x = 0; x < si.nx; ++x) {
          const float v = rem[s.index(x, y, z)];
          si.removed_depth_mm[x + si.nx * y] += float(v * s.voxel_mm);
          total += v;
        }
    si.removed_volume_mm3 = total * std::pow(s.voxel_mm, 3);
    // The class of most removed bone per column (its share of each label summed along z).
    std::vector<std::array<float, model::kMaxClasses>> per_class(si.nx * si.ny);
    for (auto& c : per_class) c.fill(0.0f);
    for (std::size_t z = 0; z < s.dims[2]; ++z)
      for (std::size_t y = 0; y < si.ny; ++y)
        for (std::size_t x = 0; x < si.nx; ++x) {
          const std::size_t i = s.index(x, y, z);
          if (s.labels[i] < model::kMaxClasses) per_class[x + si.nx * y][s.labels[i]] += rem[i];
        }
    si.removed_class.assign(si.nx * si.ny, 0);
    for (std::size_t c = 0; c < per_class.size(); ++c) {
      float best = 0;
      for (int k = 1; k < model::kMaxClasses; ++k)
        if (per_class[c][std::size_t(k)] > best) {
          best = per_class[c][std::size_t(k)];
          si.removed_class[c] = std::uint8_t(k);
        }
    }
    for (const auto& [label, name] : s.classes) si.classes[int(label)] = name;
    in.samples.push_back(std::move(si));
  }

  std::vector<fs::path> inputs = {manifest};
  for (const auto& s : ex.manifest.samples) inputs.push_back(s.path);
  for (const auto& r : ex.manifest.recordings) inputs.push_back(r.path);
  in.provenance = make_provenance(inputs);
  return in;
}

AnalysisInput replay_calibrate_directory(const fs::path& dir, const std::string& context_of_use) {
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
                                        (dir / (has_params ? "params.toml" : "fit.json")).string()});
  if (has_params) {
    in.params_path = fs::absolute(dir / "params.toml").string();
    in.params_sha256 = sha256_file(dir / "params.toml");
  }
  for (const char* name : {"fit.json", "params.toml"})
    if (fs::exists(dir / name)) in.provenance.inputs.push_back({(dir / name).string(), sha256_file(dir / name)});
  return in;
}

}  // namespace burrbench::apps
