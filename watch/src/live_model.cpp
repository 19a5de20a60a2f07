#include "burrbench/watch/live_model.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/fitted_nuisances.hpp"

namespace burrbench::watch {

namespace {

const data_schema::RecordingRef& find_ref(const data_schema::ExperimentManifest& m,
                                          const std::string& id) {
  for (const auto& r : m.recordings)
    if (r.id == id) return r;
  std::string ids;
  for (const auto& r : m.recordings) ids += (ids.empty() ? "" : ", ") + r.id;
  throw InputError(m.file.string(), "--recording",
                   fmt::format("the id of one of its recordings ({})", ids), id);
}

const data_schema::SampleRef& find_sample(const data_schema::ExperimentManifest& m,
                                          const std::string& id) {
  for (const auto& s : m.samples)
    if (s.id == id) return s;
  throw InputError(m.file.string(), "recordings.sample", "a sample id listed in [[samples]]", id);
}

// The force samples whose burr position (at t − lag) and spindle speed are already
// logged: a later one would be paired with a position held at the stage's last sample.
std::size_t ready_samples(const model::AlignedRecording& r, const model::Trajectory& tr,
                          double lag_s) {
  double last_s = r.stage_rig_mm.t_s.empty() ? -INFINITY : r.stage_rig_mm.t_s.back();
  if (!r.spindle_rpm.t_s.empty()) last_s = std::min(last_s, r.spindle_rpm.t_s.back());
  const auto it = std::upper_bound(tr.t_s.begin(), tr.t_s.end(), last_s + lag_s);
  return std::size_t(it - tr.t_s.begin());
}

}  // namespace

LiveModel::LiveModel(data_schema::ExperimentManifest manifest, const std::string& recording_id,
                     const data_schema::ParameterSet& params,
                     std::optional<data_schema::FitResult> fit, const LiveSettings& settings)
    : manifest_(std::move(manifest)),
      ref_(find_ref(manifest_, recording_id)),
      sample_(data_schema::read_sample(find_sample(manifest_, ref_.sample).path)),
      params_(model::ModelParams::from(params)),
      fit_(std::move(fit)),
      settings_(settings),
      alarms_(settings.alarms) {
  {  // check_covers takes a map of samples: lend it ours rather than copy the volume
    std::map<std::string, data_schema::SampleVolume> one;
    one.emplace(ref_.sample, std::move(sample_));
    model::check_covers(params, one, "--params");
    sample_ = std::move(one.at(ref_.sample));
  }
  if (const std::string bad = settings.alarms.invalid(); !bad.empty())
    throw InputError("watch", "alarms", bad);
  if (settings_.sigma_N > 0) {
    sigma_N_ = settings_.sigma_N;
    sigma_source_ = "--sigma-N";
  } else if (fit_ && fit_->residuals_summary.sigma_N > 0) {
    sigma_N_ = fit_->residuals_summary.sigma_N;
    sigma_source_ = "the fit's residual sigma";
  }
  if (fit_) {
    const auto n = model::fitted_nuisances(*fit_, ref_.id);
    if (n.force_bias_N) {
      bias_N_ = *n.force_bias_N;
      bias_known_ = true;
      bias_source_ = "the fit's bias";
    }
    torque_bias_Nmm_ = n.torque_bias_Nmm;
    spindle_idle_Nmm_ = n.spindle_idle_Nmm;
  }
}

LiveModel::~LiveModel() = default;

double LiveModel::step_s() const { return replay_ ? replay_->step_s() : 0; }
std::size_t LiveModel::replayed() const { return replay_ ? replay_->reported() : 0; }

void LiveModel::start(const model::AlignedRecording& r) {
  model::ReplayOptions ro;
  ro.step_s = settings_.step_s > 0 ? settings_.step_s : model::default_step_s(r.t_s);
  replay_ = std::make_unique<IncrementalReplay>(model::Volume::from_sample(sample_), r.radius_mm,
                                                params_, ro);
}

void LiveModel::tare(const LivePoint& p, const glm::dvec3& raw) {
  // As `rig tare` does, the session is taken to begin with the burr in air: the model is
  // not asked, since a registration that is off puts it in bone from the start, and that
  // is what the alarms are for.
  (void)p;
  if (bias_known_ && sigma_N_ > 0) return;
  free_.push_back(raw);
  if (free_.size() < std::max<std::size_t>(2, settings_.tare_samples)) return;
  glm::dvec3 mean(0);
  for (const auto& f : free_) mean += f;
  mean /= double(free_.size());
  if (!bias_known_) {
    bias_N_ = mean;
    bias_known_ = true;
    bias_source_ = fmt::format("the mean of the session's first {} force samples", free_.size());
  }
  if (!(sigma_N_ > 0)) {
    double ss = 0;  // pooled over the three axes, about each axis's own mean
    for (const auto& f : free_) {
      const glm::dvec3 d = f - mean;
      ss += glm::dot(d, d);
    }
    sigma_N_ = std::sqrt(ss / (3.0 * double(free_.size() - 1)));
    sigma_source_ = fmt::format("the spread of the session's first {} force samples", free_.size());
  }
  free_.clear();
}

void LiveModel::wrench(const model::AlignedRecording& r, const model::ContactResult& c,
                       const model::Trajectory& tr, const model::PoseCorrection* pose, bool fresh,
                       LivePoint& p) {
  const std::size_t k = p.index;
  const bool torque = k < r.torque_sensor_Nmm.size(), spindle = !r.spindle_torque_Nmm.t_s.empty();
  const double load_Nmm = spindle ? r.spindle_torque_Nmm.at(p.t_s) : NAN;
  if (fresh && offsets_n_ < settings_.tare_samples) {
    ++offsets_n_;
    if (torque) torque_sum_Nmm_ += r.torque_sensor_Nmm[k];
    if (spindle) spindle_sum_Nmm_ += load_Nmm;
    if (offsets_n_ == settings_.tare_samples) {
      if (torque && !torque_bias_Nmm_) torque_bias_Nmm_ = torque_sum_Nmm_ / double(offsets_n_);
      if (spindle && !spindle_idle_Nmm_) spindle_idle_Nmm_ = spindle_sum_Nmm_ / double(offsets_n_);
    }
  }
  if (torque) {
    p.torque_measured_Nmm = r.torque_sensor_Nmm[k] - torque_bias_Nmm_.value_or(glm::dvec3(0));
    p.torque_predicted_Nmm =
        r.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, tr.centre_vol_mm[k], pose);
  }
  if (spindle) {
    p.spindle_measured_Nmm = load_Nmm - spindle_idle_Nmm_.value_or(0.0);
    p.spindle_predicted_Nmm = model::spindle_torque_Nmm(c.moment_Nmm, tr.omega_vol_rad_s[k]);
  }
}

LiveStep LiveModel::advance(const data_schema::Recording& rec, std::size_t max_samples) {
  LiveStep out;
  const data_schema::Stream* force = rec.stream_with("force_N");
  const data_schema::Stream* stage = rec.stream_with("position_mm");
  // Alignment needs a few samples of each stream; until then there is nothing to replay.
  if (!force || !stage || force->samples() < 3 || stage->samples() < 3) return out;
  const model::AlignedRecording r =
      model::align_recording(manifest_, ref_, rec, ref_.path.string() + " (journal)");
  if (r.t_s.size() < 3) return out;
  if (!replay_) start(r);
  if (!bias_known_ && rec.meta.bias.size() >= 3) {
    bias_N_ = {rec.meta.bias[0], rec.meta.bias[1], rec.meta.bias[2]};
    bias_known_ = true;
    bias_source_ = "the session's tare (acquire --tare)";
  }
  model::PredictOptions po;
  po.fit = fit_ ? &*fit_ : nullptr;
  model::Trajectory tr = model::prediction_trajectory(r, po);
  tr.vias.clear();  // a live view replays the straight line across a silence (docs/watch.md)
  const double lag_s =
      fit_ ? model::fitted_nuisances(*fit_, ref_.id).lag_ms.value_or(r.lag_s * 1e3) * 1e-3
           : r.lag_s;
  const std::size_t ready = ready_samples(r, tr, lag_s);
  const std::size_t upto = std::min(ready, replay_->reported() + max_samples);
  out.recorded_to_s = r.t_s.back();
  out.waiting = ready - upto;
  if (upto <= replay_->reported()) {
    out.replayed_to_s = replay_->reported() ? r.t_s[replay_->reported() - 1] : 0;
    return out;
  }
  tr.t_s.resize(upto);
  tr.centre_vol_mm.resize(upto);
  tr.omega_vol_rad_s.resize(upto);
  const ReplayChunk chunk = replay_->extend(tr);
  const model::PoseCorrection* pose = nullptr;
  std::optional<model::FittedNuisances> nuis;
  if (fit_) {
    nuis = model::fitted_nuisances(*fit_, ref_.id);
    if (nuis->pose) pose = &*nuis->pose;
  }
  const auto& m = rec.meta;
  for (std::size_t i = 0; i < chunk.contacts.size(); ++i) {
    const std::size_t k = chunk.first_index + i;
    const model::ContactResult& c = chunk.contacts[i];
    LivePoint p;
    p.index = k;
    p.t_s = r.t_s[k];
    const double t_mono_ns = double(r.t0_ns) + r.t_s[k] * 1e9;
    p.wall_ms = (double(m.session_wall_ns) + (t_mono_ns - double(m.session_monotonic_ns))) * 1e-6;
    p.predicted_N = r.sensor_force_from_burr_force(c.force_N, pose);
    p.depth_b_mm = c.depth_b_mm;
    p.centre_vol_mm = tr.centre_vol_mm[k];
    // A revised sample (the previous chunk's last) was already tared and judged.
    const bool fresh = k >= judged_;
    if (fresh) tare(p, r.force_sensor_N[k]);
    wrench(r, c, tr, pose, fresh, p);
    p.measured_N = r.force_sensor_N[k] - bias_N_;
    if (fresh) {
      judged_ = k + 1;
      if (auto a = alarms_.update(p.t_s, p.measured_N, p.predicted_N, bias_known_ ? sigma_N_ : 0))
        out.alarms.push_back(*a);
    }
    out.points.push_back(p);
  }
  out.replayed_to_s = r.t_s[upto - 1];
  return out;
}

}  // namespace burrbench::watch
