// Replaying an aligned recording and writing the prediction: the HDF5 file through
// data_schema (format "burrbench.prediction", docs/formats.md) and an optional CSV.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <exception>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <utility>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/same_file.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/job_queue.hpp"
#include "burrbench/model/reach.hpp"
#include "burrbench/model/sensitivity.hpp"

namespace burrbench::model {

namespace {

constexpr std::size_t kMinTareSamples = 10;

// Per sample, the largest removal any recording made per voxel, kept over the rows its
// recordings reach (whole rows along x, as reach.hpp cuts them): nothing is removed
// elsewhere, and a lab's CT block would cost 4 bytes per voxel of it otherwise.
struct RemovedChi {
  std::optional<VoxelBox> box;  // none: no recording replayed on the sample
  std::vector<float> chi;       // box's voxels, x fastest
  std::size_t at(const data_schema::SampleVolume& s, std::size_t x, std::size_t y, std::size_t z) const {
    return x + s.dims[0] * ((y - box->lo[1]) + (box->hi[1] - box->lo[1]) * (z - box->lo[2]));
  }
};

// The removed bone of one sample projected along z. Voxels outside the box add exact
// zeros, so they are skipped: the sums are those over the whole sample.
data_schema::RemovedBone removed_bone(const std::string& id, const data_schema::SampleVolume& s,
                                      const RemovedChi& removed) {
  data_schema::RemovedBone out;
  out.sample_id = id;
  out.voxel_mm = s.voxel_mm;
  out.nx = s.dims[0];
  out.ny = s.dims[1];
  out.removed_depth_mm.assign(out.nx * out.ny, 0.0f);
  std::vector<std::array<float, kMaxClasses>> per_class(out.nx * out.ny);
  for (auto& c : per_class) c.fill(0.0f);
  double total = 0;
  const VoxelBox b = removed.box.value_or(VoxelBox{});
  for (std::size_t z = b.lo[2]; z < b.hi[2]; ++z)
    for (std::size_t y = b.lo[1]; y < b.hi[1]; ++y)
      for (std::size_t x = 0; x < out.nx; ++x) {
        const std::size_t i = s.index(x, y, z), col = x + out.nx * y;
        const float v = removed.chi[removed.at(s, x, y, z)];
        out.removed_depth_mm[col] += float(v * s.voxel_mm);
        total += v;
        if (s.labels[i] < kMaxClasses) per_class[col][s.labels[i]] += v;
      }
  out.removed_volume_mm3 = total * std::pow(s.voxel_mm, 3);
  // The class of most removed bone per column (its share of each label summed along z).
  out.removed_class.assign(out.nx * out.ny, 0);
  for (std::size_t c = 0; c < per_class.size(); ++c) {
    float best = 0;
    for (int k = 1; k < kMaxClasses; ++k)
      if (per_class[c][std::size_t(k)] > best) {
        best = per_class[c][std::size_t(k)];
        out.removed_class[c] = std::uint8_t(k);
      }
  }
  return out;
}

// One recording's removal from its sample: (voxel index in the sample, removed χ) for
// each voxel it removed from, in increasing index order.
using Removal = std::vector<std::pair<std::size_t, float>>;

// Pairs of recordings of one sample that removed the same bone, beyond kOverlapShare of
// the smaller removal: Σ min over the voxels both removed from (a merge of the two sorted
// lists, so the figure does not depend on the order the replays finished in).
std::vector<RemovedOverlap> overlaps(const Experiment& e, const std::vector<Removal>& removal) {
  std::vector<RemovedOverlap> out;
  const std::size_t n = e.recordings.size();
  std::vector<double> total(n, 0.0);
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& [j, d] : removal[i]) total[i] += d;
  // A file listed again (e.g. once per role) is its first listing's drilling, not a second
  // drilling of its spot: only first listings form pairs. Recordings built in memory
  // (no file) are each their own.
  std::vector<bool> again(n, false);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < i && !again[i]; ++k)
      again[i] = e.recordings[k].sample_id == e.recordings[i].sample_id && !e.recordings[i].file.empty() &&
                 !e.recordings[k].file.empty() && data_schema::same_file(e.recordings[k].file, e.recordings[i].file);
  for (const auto& sref : e.manifest.samples) {
    if (!e.samples.count(sref.id)) continue;
    const double l3 = std::pow(e.samples.at(sref.id).voxel_mm, 3);
    for (std::size_t a = 0; a < n; ++a)
      for (std::size_t b = a + 1; b < n; ++b) {
        const AlignedRecording &ra = e.recordings[a], &rb = e.recordings[b];
        if (ra.sample_id != sref.id || rb.sample_id != sref.id || again[a] || again[b]) continue;
        double shared = 0;
        auto p = removal[a].begin(), q = removal[b].begin();
        while (p != removal[a].end() && q != removal[b].end()) {
          if (p->first < q->first) {
            ++p;
          } else if (q->first < p->first) {
            ++q;
          } else {
            shared += std::min(p->second, q->second);
            ++p;
            ++q;
          }
        }
        if (shared > 0 && shared > kOverlapShare * std::min(total[a], total[b]))
          out.push_back({sref.id, ra.id, rb.id, shared * l3, total[a] * l3, total[b] * l3});
      }
  }
  return out;
}

// The sensor's moment and the spindle's load beside the force (MODEL.md "Moments"), with
// the fitted moment bias and spindle idle/viscous terms, or the tare, added.
void add_wrench_offsets(const AlignedRecording& r, const ReplayResult& res, const Trajectory& tr,
                        const FittedNuisances& fit, bool tare, RecordingPrediction& p) {
  const std::size_t n = res.samples.size();
  auto no_contact = [&](std::size_t k) { return res.samples[k].contact.class_mask == 0; };
  if (r.torque_sensor_Nmm.size() == n) {
    glm::dvec3 free_sum(0);
    std::size_t free_n = 0;
    for (std::size_t k = 0; k < n; ++k)
      if (no_contact(k)) {
        free_sum += r.torque_sensor_Nmm[k] - p.torque_sensor_pred_Nmm[k];
        ++free_n;
      }
    if (fit.torque_bias_Nmm) {
      p.torque_bias_Nmm = *fit.torque_bias_Nmm;
      p.torque_bias_source = "fit";
    } else if (tare && free_n >= kMinTareSamples) {
      p.torque_bias_Nmm = free_sum / double(free_n);
      p.torque_bias_source = "tare";
    }
    for (auto& t : p.torque_sensor_pred_Nmm) t += p.torque_bias_Nmm;
  }
  if (p.spindle_torque_meas_Nmm.empty()) return;
  // The drive's own lag on top of the force's (the fit's spindle_lag): the load logged at t
  // answers the cut at t − lag, linear between the samples (the fit's objective.cpp shift).
  if (fit.spindle_lag_ms != 0 && n > 1) {
    const std::vector<double> cut = p.spindle_torque_pred_Nmm;
    const std::vector<double>& t = tr.t_s;
    for (std::size_t k = 0; k < n; ++k) {
      const double tq = t[k] - 1e-3 * fit.spindle_lag_ms;
      if (tq <= t.front()) { p.spindle_torque_pred_Nmm[k] = cut.front(); continue; }
      if (tq >= t.back()) { p.spindle_torque_pred_Nmm[k] = cut.back(); continue; }
      const std::size_t i = std::size_t(std::upper_bound(t.begin(), t.end(), tq) - t.begin()) - 1;
      const double u = (tq - t[i]) / (t[i + 1] - t[i]);
      p.spindle_torque_pred_Nmm[k] = (1 - u) * cut[i] + u * cut[i + 1];
    }
  }
  // The drive's viscous term acts on the speed's deviation from the recording's mean
  // (AlignedRecording::spindle_krpm_deviation, as in the fit). The tare: the load without
  // contact while spinning, fitted as idle + slope·Δkrpm by least squares (a mean when the
  // speed never changes), so samples with the spindle stopped do not bias it.
  const std::vector<double> krpm = r.spindle_krpm_deviation();
  double s1 = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (std::size_t k = 0; k < n; ++k)
    if (no_contact(k) && glm::length(tr.omega_vol_rad_s[k]) > 0) {
      const double y = p.spindle_torque_meas_Nmm[k];
      s1 += 1;
      sx += krpm[k];
      sy += y;
      sxx += krpm[k] * krpm[k];
      sxy += krpm[k] * y;
    }
  double idle = 0, slope = 0;
  if (fit.spindle_idle_Nmm) {
    idle = *fit.spindle_idle_Nmm;
    slope = fit.spindle_viscous_Nmm_per_krpm;
    p.spindle_offset_source = "fit";
  } else if (tare && s1 >= double(kMinTareSamples)) {
    const double det = s1 * sxx - sx * sx;
    if (det / (s1 * s1) > 1e-6) {  // the speed varies by more than ~1 rpm
      slope = (s1 * sxy - sx * sy) / det;
      idle = (sy - slope * sx) / s1;
    } else {
      idle = sy / s1;
    }
    p.spindle_offset_source = "tare";
  } else {
    return;
  }
  p.spindle_offset_Nmm.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    p.spindle_offset_Nmm[k] = idle + slope * krpm[k];
    p.spindle_torque_pred_Nmm[k] += p.spindle_offset_Nmm[k];
  }
}

// Reports every recording's replay to one sink, from any worker: the fraction is the
// experiment's (each recording weighted by its samples) and each line names its recording.
class ExperimentProgress {
 public:
  ExperimentProgress(const Experiment& e, Progress* sink) : sink_(sink), done_(e.recordings.size(), 0.0) {
    for (const auto& r : e.recordings) weight_.push_back(double(r.t_s.size()));
    for (double w : weight_) total_ += w;
  }
  // The reporter handed to recording i's replay (null when there is no sink).
  std::unique_ptr<Progress> child(std::size_t i, const std::string& id) {
    if (!sink_) return nullptr;
    return std::make_unique<Child>(*this, i, id);
  }

 private:
  class Child final : public Progress {
   public:
    Child(ExperimentProgress& p, std::size_t i, std::string id) : p_(p), i_(i), id_(std::move(id)) {}
    void update(double fraction, const std::string& line) override {
      const std::lock_guard<std::mutex> lock(p_.mutex_);
      if (fraction >= 0) p_.done_[i_] = fraction;
      p_.sink_->update(p_.overall(), p_.done_.size() > 1 ? id_ + ": " + line : line);
    }
    void finish(const std::string& summary_line) override {
      const std::lock_guard<std::mutex> lock(p_.mutex_);
      p_.done_[i_] = 1.0;
      p_.sink_->finish(p_.done_.size() > 1 ? id_ + ": " + summary_line : summary_line);
    }

   private:
    ExperimentProgress& p_;
    std::size_t i_;
    std::string id_;
  };
  double overall() const {
    if (!(total_ > 0)) return -1;
    double s = 0;
    for (std::size_t i = 0; i < done_.size(); ++i) s += done_[i] * weight_[i];
    return s / total_;
  }
  Progress* sink_;
  std::mutex mutex_;
  std::vector<double> done_, weight_;
  double total_ = 0;
};

}  // namespace

std::string RemovedOverlap::text() const {
  const double smaller = std::min(removed_first_mm3, removed_second_mm3);
  return fmt::format(
      "Recordings {} and {} removed the same bone of sample {}: {:.3g} mm³, {:.0f} % of the smaller removal "
      "({} removed {:.3g} mm³, {} {:.3g} mm³). Each recording is replayed from the sample as scanned, so the one "
      "drilled second was predicted against bone that was already gone: its forces, and constants fitted to "
      "them, are biased. Drill each recording into fresh bone, or leave one of the two out.",
      first, second, sample_id, shared_mm3, 100.0 * shared_mm3 / smaller, first, removed_first_mm3, second,
      removed_second_mm3);
}

ExperimentPrediction predict_experiment(const Experiment& e, const ModelParams& params,
                                        const PredictOptions& options) {
  BURRBENCH_CHECK(options.threads >= 1, "predict_experiment needs at least one thread");
  const std::size_t n = e.recordings.size();
  const std::size_t workers = std::min<std::size_t>(std::size_t(options.threads), std::max<std::size_t>(n, 1));
  // Only the part of a sample a recording's replay reaches is copied (reach.hpp). When the
  // replay erodes, each recording erodes a fresh cut, whose difference to the scan is its
  // removal: the overlaps compare them, and the removed bone is kept over the hull of the
  // cuts. Otherwise a recording replays in place and each worker keeps its cut volumes for
  // the next recording.
  const bool fresh = options.removed_bone || options.replay.erosion;
  std::vector<ReachVolumes> own;
  if (!fresh)
    for (std::size_t w = 0; w < workers; ++w) own.emplace_back(e.samples);
  std::map<std::string, RemovedChi> removed;
  std::vector<VoxelBox> cut(fresh ? n : 0);
  std::vector<Removal> removal(fresh ? n : 0);  // each recording's, for the overlaps
  for (std::size_t i = 0; i < cut.size(); ++i) {
    const AlignedRecording& r = e.recordings[i];
    try {
      cut[i] = replay_box(e.samples.at(r.sample_id), prediction_trajectory(r, options), r.radius_mm);
    } catch (const InputError& err) {
      throw err.in("recording " + r.id);
    }
  }
  if (options.removed_bone) {
    for (const auto& [id, s] : e.samples) removed[id];  // every sample has its map, if only of zeros
    for (std::size_t i = 0; i < n; ++i) {
      auto& box = removed[e.recordings[i].sample_id].box;
      box = box ? box->hull(cut[i]) : cut[i];
    }
    for (auto& [id, rm] : removed)
      if (rm.box) rm.chi.assign(rm.box->voxel_count(), 0.0f);
  }

  ExperimentPrediction out;
  out.recordings.resize(n);
  ExperimentProgress shared(e, options.progress);
  std::mutex removed_mutex;
  // Longest recording first: one started last would leave the other workers idle.
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return e.recordings[a].t_s.size() > e.recordings[b].t_s.size();
  });
  // A failure reports the first failing recording in manifest order, as one thread would.
  run_job_queue(n, order, int(workers), [&](std::size_t w, std::size_t i) {
    const AlignedRecording& r = e.recordings[i];
    try {
      const std::unique_ptr<Progress> progress = shared.child(i, r.id);
      if (fresh) {
        const data_schema::SampleVolume& s = e.samples.at(r.sample_id);
        Volume vol = Volume::from_sample(s, cut[i]);
        out.recordings[i] = predict(r, vol, params, options, progress.get(), false);
        // Left eroded: its difference to the scan is the removed bone (χ only falls, so
        // the voxels it did not remove from hold exact zeros and are left out).
        Removal& mine = removal[i];
        const VoxelBox& b = vol.box();
        std::size_t v = 0;
        for (std::size_t z = b.lo[2]; z < b.hi[2]; ++z)
          for (std::size_t y = b.lo[1]; y < b.hi[1]; ++y)
            for (std::size_t x = b.lo[0]; x < b.hi[0]; ++x, ++v) {
              const std::size_t j = s.index(x, y, z);
              const double scanned = s.labels[j] == 0 ? 0.0 : double(s.fraction[j]);
              const float d = float(scanned - vol.chi(v));
              if (d > 0) mine.push_back({j, d});
            }
        if (options.removed_bone) {
          const std::lock_guard<std::mutex> lock(removed_mutex);
          auto& rem = removed.at(r.sample_id);
          const std::size_t nx = s.dims[0], ny = s.dims[1];
          for (const auto& [j, d] : mine) {
            float& m = rem.chi[rem.at(s, j % nx, (j / nx) % ny, j / (nx * ny))];
            m = std::max(m, d);
          }
        }
      } else {
        Volume& vol = own[w].for_replay(r.sample_id, prediction_trajectory(r, options), r.radius_mm);
        out.recordings[i] = predict(r, vol, params, options, progress.get(), true);
      }
      if (const auto* ref = e.manifest.recording(r.id)) out.recordings[i].role = data_schema::to_string(ref->role);
      out.recordings[i].quadrature = quadrature_name(options.replay.quadrature);
    } catch (const InputError& err) {
      throw err.in("recording " + r.id);
    }
  });
  if (options.removed_bone) {
    for (const auto& sref : e.manifest.samples)
      if (removed.count(sref.id))
        out.removed.push_back(removed_bone(sref.id, e.samples.at(sref.id), removed.at(sref.id)));
  }
  if (fresh) out.overlaps = overlaps(e, removal);
  return out;
}

Trajectory prediction_trajectory(const AlignedRecording& r, const PredictOptions& options) {
  const FittedNuisances fit = options.fit ? fitted_nuisances(*options.fit, r.id) : FittedNuisances{};
  const double lag_ms = fit.lag_ms.value_or(r.lag_s * 1000.0);
  const double depth_mm = fit.depth_offset_mm.value_or(0.0);
  return r.trajectory(lag_ms / 1000.0, depth_mm, fit.pose ? &*fit.pose : nullptr);
}

RecordingPrediction predict(const AlignedRecording& r, Volume& volume, const ModelParams& params,
                            const PredictOptions& options, Progress* progress, bool restore) {
  const FittedNuisances fit = options.fit ? fitted_nuisances(*options.fit, r.id) : FittedNuisances{};
  const double lag_ms = fit.lag_ms.value_or(r.lag_s * 1000.0);
  const double depth_mm = fit.depth_offset_mm.value_or(0.0);
  const Trajectory tr = prediction_trajectory(r, options);
  const PoseCorrection* pose = fit.pose ? &*fit.pose : nullptr;  // the rig as the fit corrected it
  ReplayOptions ro = options.replay;
  Sensitivities sens;
  const bool band = options.band && !options.band->directions.empty();
  if (band) {
    ro.directions = &options.band->directions;
    ro.sensitivities = &sens;
  }
  const ReplayResult res = replay(volume, r.radius_mm, params, tr, ro, restore, progress);
  RecordingPrediction p;
  p.recording_id = r.id;
  p.registration_method = r.registration.method;
  p.registration_rms_mm = r.registration.rms_mm;
  p.registration_max_mm = r.registration.max_mm;
  p.fiducial_error_mm = r.registration.method == "fiducials" ? r.registration.fle_mm : NAN;
  p.tre_path_rms_mm = r.registration.tre_path_rms_mm;
  p.tre_path_max_mm = r.registration.tre_path_max_mm;
  p.t_s = tr.t_s;
  p.centre_vol_mm = tr.centre_vol_mm;
  p.force_sensor_meas_N = r.force_sensor_N;
  p.use = r.use;
  p.removed_mm3 = res.removed_mm3;
  p.friction_energy_mJ = res.friction_energy_mJ;
  p.steps = static_cast<std::int64_t>(res.steps);
  p.wall_s = res.wall_s;
  p.lag_ms = lag_ms;
  p.depth_offset_mm = depth_mm;
  const std::size_t n = res.samples.size();
  BURRBENCH_CHECK(n == r.t_s.size(), "replay returned a different sample count");
  p.force_burr_vol_N.resize(n);
  p.force_sensor_pred_N.resize(n);
  p.friction_sensor_pred_N.resize(n);
  p.normal_vol.resize(n);
  p.depth_b_mm.resize(n);
  p.class_mask.resize(n);
  p.buried.resize(n);
  p.used_calibrate.resize(n);
  p.used_validate.resize(n);
  p.moment_burr_vol_Nmm.resize(n);
  p.torque_sensor_pred_Nmm.resize(n);
  p.spindle_torque_pred_Nmm.resize(n);
  p.torque_sensor_meas_Nmm = r.torque_sensor_Nmm;
  if (!r.spindle_torque_Nmm.t_s.empty()) {
    for (double t : tr.t_s) p.spindle_torque_meas_Nmm.push_back(r.spindle_torque_Nmm.at(t));
    // The speed the load is compared at (the report plots the load against it).
    for (const glm::dvec3& w : tr.omega_vol_rad_s) p.spin_rad_s.push_back(glm::length(w));
  }
  glm::dvec3 free_sum(0);
  std::size_t free_n = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const ContactResult& c = res.samples[k].contact;
    p.force_burr_vol_N[k] = c.force_N;
    p.force_sensor_pred_N[k] = r.sensor_force_from_burr_force(c.force_N, pose);
    p.friction_sensor_pred_N[k] = r.sensor_force_from_burr_force(c.friction_N, pose);
    p.normal_vol[k] = c.normal;
    p.depth_b_mm[k] = c.depth_b_mm;
    p.class_mask[k] = c.class_mask;
    p.buried[k] = c.buried ? 1 : 0;
    const bool counts = !(options.exclude_buried && c.buried);
    p.used_calibrate[k] = r.use_calibrate[k] && counts;
    p.used_validate[k] = r.use_validate[k] && counts;
    p.moment_burr_vol_Nmm[k] = c.moment_Nmm;
    p.torque_sensor_pred_Nmm[k] = r.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, tr.centre_vol_mm[k], pose);
    p.spindle_torque_pred_Nmm[k] = spindle_torque_Nmm(c.moment_Nmm, tr.omega_vol_rad_s[k]);
    if (c.class_mask == 0) {
      free_sum += r.force_sensor_N[k];
      ++free_n;
    }
  }
  // The sensor's bias is a nuisance, not a model constant: it is added to the prediction.
  if (fit.force_bias_N) {
    p.force_bias_N = *fit.force_bias_N;
    p.force_bias_source = "fit";
  } else if (options.tare && free_n >= kMinTareSamples) {
    p.force_bias_N = free_sum / double(free_n);
    p.force_bias_source = "tare";
  }
  for (auto& f : p.force_sensor_pred_N) f += p.force_bias_N;
  if (band) {
    double fmax = 0;
    for (const auto& s : res.samples) fmax = std::max(fmax, glm::length(s.contact.force_N));
    p.band_diverged = sensitivities_diverged(sens.dforce_N, fmax);
  }
  if (band && !p.band_diverged) {
    // 95 % band of the prediction from the constants' uncertainty alone (delta method):
    // per axis 1.96·√(gᵀ C g), g = ∂F_sensor/∂ln θ.
    const auto& C = options.band->cov_ln;
    const std::size_t m = options.band->directions.size();
    p.band95_N.resize(n);
    std::vector<glm::dvec3> g(m);
    for (std::size_t k = 0; k < n; ++k) {
      for (std::size_t a = 0; a < m; ++a) g[a] = r.sensor_force_from_burr_force(sens.dforce_N[a][k], pose);
      glm::dvec3 var(0);
      for (std::size_t a = 0; a < m; ++a)
        for (std::size_t b = 0; b < m; ++b) var += g[a] * g[b] * C[a * m + b];
      p.band95_N[k] = 1.959963984540054 * glm::sqrt(glm::max(var, glm::dvec3(0)));
    }
  }
  add_wrench_offsets(r, res, tr, fit, options.tare, p);
  return p;
}

void write_prediction(const std::filesystem::path& path,
                      const ExperimentPrediction& preds, const Provenance& prov, const nlohmann::json& context) {
  data_schema::Prediction file;
  file.provenance = prov;
  file.context = context;
  file.recordings.assign(preds.recordings.begin(), preds.recordings.end());  // the records without wall_s
  file.removed = preds.removed;
  data_schema::write_prediction(path, file);
}

void write_prediction_csv(const std::filesystem::path& path,
                          const std::vector<RecordingPrediction>& preds) {
  data_schema::AtomicFile out(path);
  // Columns named as the prediction file's datasets, a vector's component appended as
  // _x/_y/_z: the one naming scheme of every burrbench CSV export (docs/formats.md).
  out << "recording_id,t_s,force_burr_vol_N_x,force_burr_vol_N_y,force_burr_vol_N_z,force_sensor_pred_N_x,"
         "force_sensor_pred_N_y,force_sensor_pred_N_z,force_sensor_meas_N_x,force_sensor_meas_N_y,"
         "force_sensor_meas_N_z,depth_b_mm,normal_vol_x,normal_vol_y,normal_vol_z,class_mask,buried,use,"
         "moment_burr_vol_Nmm_x,moment_burr_vol_Nmm_y,moment_burr_vol_Nmm_z,torque_sensor_pred_Nmm_x,"
         "torque_sensor_pred_Nmm_y,torque_sensor_pred_Nmm_z,torque_sensor_meas_Nmm_x,torque_sensor_meas_Nmm_y,"
         "torque_sensor_meas_Nmm_z,spindle_torque_pred_Nmm,spindle_torque_meas_Nmm\n";
  // The wrench columns are empty where the prediction has none (nothing measured).
  auto v3 = [](const std::vector<glm::dvec3>& v, std::size_t k) {
    return k < v.size() ? fmt::format("{:.9g},{:.9g},{:.9g}", v[k].x, v[k].y, v[k].z) : std::string(",,");
  };
  auto v1 = [](const std::vector<double>& v, std::size_t k) {
    return k < v.size() ? fmt::format("{:.9g}", v[k]) : std::string();
  };
  for (const auto& p : preds)
    for (std::size_t k = 0; k < p.t_s.size(); ++k) {
      const auto &fb = p.force_burr_vol_N[k], &fp = p.force_sensor_pred_N[k],
                 &fm = p.force_sensor_meas_N[k], &n = p.normal_vol[k];
      out << fmt::format(
          "{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},"
          "{:.9g},{:.9g},{:.9g},{},{},{},{},{},{},{},{}\n",
          p.recording_id, p.t_s[k], fb.x, fb.y, fb.z, fp.x, fp.y, fp.z, fm.x, fm.y, fm.z,
          p.depth_b_mm[k], n.x, n.y, n.z, int(p.class_mask[k]), int(p.buried[k]), int(p.use[k]),
          v3(p.moment_burr_vol_Nmm, k), v3(p.torque_sensor_pred_Nmm, k), v3(p.torque_sensor_meas_Nmm, k),
          v1(p.spindle_torque_pred_Nmm, k), v1(p.spindle_torque_meas_Nmm, k));
    }
  out.commit();
}

}  // namespace burrbench::model
