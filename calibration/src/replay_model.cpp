#include "burrbench/calibration/replay_model.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <deque>
#include <limits>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::calibration {

model::ModelParams to_model_params(const PhysicsValues& v) {
  model::ModelParams p;
  for (int k = 1; k < kLabels; ++k)
    p.by_label[std::size_t(k)] = {v.alpha[std::size_t(k)], v.c1[std::size_t(k)], v.mu[std::size_t(k)]};
  return p;
}

ReplayPool::ReplayPool(const std::map<std::string, data_schema::SampleVolume>& samples,
                       int threads) {
  const std::size_t n = std::size_t(std::max(1, threads));
  for (std::size_t w = 0; w < n; ++w) volumes_.emplace_back(samples);
  for (std::size_t w = 0; w < n; ++w) workers_.emplace_back([this, w] { work(w); });
}

ReplayPool::~ReplayPool() {
  {
    std::lock_guard lk(mu_);
    stop_ = true;
  }
  cv_.notify_all();
  for (auto& t : workers_) t.join();
}

void ReplayPool::work(std::size_t w) {
  for (;;) {
    std::function<void(std::size_t)> f;
    {
      std::unique_lock lk(mu_);
      cv_.wait(lk, [&] { return stop_ || !queue_.empty(); });
      if (queue_.empty()) return;
      f = std::move(queue_.front().run);
      queue_.pop_front();
    }
    f(w);
  }
}

namespace {
// The calling thread's CPU time (s): a replay's own cost, whatever else the machine runs.
double thread_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// Directions a job's replay carries sensitivities in (0: a plain replay).
std::size_t directions(const ReplayPool::Job& job) {
  return job.options.directions ? job.options.directions->size() : 0;
}

// A job's work in plain-replay sample equivalents, to start the longest first: a
// sensitivity replay costs ≈ 2.35 plain replays plus ≈ 0.22 per direction asked for
// (bench/sensitivity.sh on 2026-11-28: 1 / 4 / 8 asked for cost 2.54 / 3.35 / 4.04 at
// R/l = 10, 2.71 / 3.54 / 4.35 at R/l = 20; docs/model.md "Cost"). Only the order of the
// jobs depends on it, never a result.
double job_work(const ReplayPool::Job& job) {
  const std::size_t dirs = directions(job);
  return double(job.trajectory.t_s.size()) * (dirs > 0 ? 2.35 + 0.22 * double(dirs) : 1.0);
}
}  // namespace

void ReplayPool::run(std::vector<Job>& jobs) {
  std::size_t remaining = jobs.size();
  std::exception_ptr error;
  {
    std::lock_guard lk(mu_);
    for (auto& job : jobs) {
      const double work = job_work(job);
      auto at = std::find_if(queue_.begin(), queue_.end(), [&](const Queued& q) { return q.work < work; });
      queue_.insert(at, Queued{work, [this, &job, &remaining, &error](std::size_t w) {
        const double cpu0 = thread_cpu_s();
        try {
          auto& vol = volumes_[w].for_replay(*job.sample_id, job.trajectory, job.radius_mm);
          job.result = model::replay(vol, job.radius_mm, job.params, job.trajectory, job.options, true);
        } catch (...) {
          std::lock_guard lk2(mu_);
          if (!error) error = std::current_exception();
        }
        const double cpu_s = thread_cpu_s() - cpu0;
        std::lock_guard lk2(mu_);
        Tally& t = directions(job) > 0 ? done_.sensitivity : done_.plain;
        ++t.replays;
        t.samples += job.trajectory.t_s.size();
        t.cpu_s += cpu_s;
        if (--remaining == 0) done_cv_.notify_all();
      }});
    }
  }
  cv_.notify_all();
  std::unique_lock lk(mu_);
  done_cv_.wait(lk, [&] { return remaining == 0; });
  if (error) std::rethrow_exception(error);
}

ReplayPool::Work ReplayPool::work_done() const {
  std::lock_guard lk(mu_);
  return done_;
}

double ReplayPool::Work::sensitivity_cost() const {
  if (plain.samples == 0 || sensitivity.samples == 0 || plain.cpu_s <= 0)
    return std::numeric_limits<double>::quiet_NaN();
  return (sensitivity.cpu_s / double(sensitivity.samples)) / (plain.cpu_s / double(plain.samples));
}

ReplayRecordingModel::ReplayRecordingModel(const model::AlignedRecording& rec, ReplayPool& pool,
                                           model::ReplayOptions options)
    : rec_(rec), pool_(pool), options_(options) {}

namespace {
model::PoseCorrection pose_of(const EvalPoint& at) {
  model::PoseCorrection p;
  p.rotation_rad = {at.pose[0], at.pose[1], at.pose[2]};
  p.translation_mm = {at.pose[3], at.pose[4], at.pose[5]};
  p.centre_vol_mm = at.pose_centre_vol_mm;
  return p;
}
constexpr double kPoseStep[6] = {1e-4, 1e-4, 1e-4, 1e-3, 1e-3, 1e-3};  // rad, mm (fd only)
}  // namespace

void ReplayRecordingModel::set_channels(const Channels& c, const std::string& file) {
  channels_ = c;
  forget();
  if (c.torque && rec_.torque_sensor_Nmm.size() != rec_.t_s.size())
    throw InputError(file, "fit.channels", "\"torque\" only for recordings with a torque_Nmm channel beside force_N",
                     "recording " + rec_.id + " has none");
  if (c.spindle && rec_.spindle_torque_Nmm.t_s.empty())
    throw InputError(file, "fit.channels",
                     "\"spindle\" only for recordings with a spindle_torque_Nmm or spindle_power_W channel",
                     "recording " + rec_.id + " has none");
  spindle_Nmm_.clear();
  krpm_.clear();
  if (c.spindle) {
    // The viscous term acts on the speed's deviation from the recording's mean, so that
    // the idle offset (the load at the mean speed) stays determined when the speed never
    // changes, and the two are not correlated when it does.
    for (double t : rec_.t_s) spindle_Nmm_.push_back(rec_.spindle_torque_Nmm.at(t));
    krpm_ = rec_.spindle_krpm_deviation();
  }
}

void ReplayRecordingModel::fill_base(const model::ReplayResult& base, const model::Trajectory& tr,
                                     const model::PoseCorrection* pose, Prediction& out) const {
  const std::size_t n = size();
  BURRBENCH_CHECK(base.samples.size() == n, "replay returned one contact per force sample");
  out.force_sensor_N.resize(n);
  out.buried.resize(n);
  out.class_mask.resize(n);
  for (std::size_t k = 0; k < std::size_t(kLabels); ++k) out.removed_mm3[k] = base.removed_mm3[k];
  if (channels_.torque) out.torque_sensor_Nmm.resize(n);
  if (channels_.spindle) out.spindle_Nmm.resize(n);
  for (std::size_t j = 0; j < n; ++j) {
    const auto& c = base.samples[j].contact;
    out.force_sensor_N[j] = rec_.sensor_force_from_burr_force(c.force_N, pose);
    out.buried[j] = c.buried ? 1 : 0;
    out.class_mask[j] = c.class_mask;
    if (channels_.torque)
      out.torque_sensor_Nmm[j] = rec_.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, tr.centre_vol_mm[j], pose);
    if (channels_.spindle) out.spindle_Nmm[j] = model::spindle_torque_Nmm(c.moment_Nmm, tr.omega_vol_rad_s[j]);
  }
}

std::shared_ptr<const FixedGeometryTerms> ReplayRecordingModel::fixed_geometry_terms(
    const EvalPoint& at, const model::ReplayResult& base, const model::Trajectory& tr,
    const model::PoseCorrection* pose) const {
  auto out = std::make_shared<FixedGeometryTerms>();
  out->at = at.physics;
  std::uint32_t seen = 0;
  for (const auto& s : base.samples) seen |= s.contact.class_mask;
  for (int k = 1; k < kLabels; ++k)
    if (seen & (1u << k)) out->labels.push_back(std::uint8_t(k));
  const std::size_t nl = out->labels.size(), n = size();
  out->terms.resize(n * nl);
  const bool wrench = channels_.torque || channels_.spindle;
  for (std::size_t j = 0; j < n; ++j) {
    const auto& c = base.samples[j].contact;
    for (std::size_t i = 0; i < nl; ++i) {
      const std::size_t k = out->labels[i];
      auto& t = out->terms[j * nl + i];
      t.elastic_force = rec_.sensor_force_from_burr_force(c.dF_dC1[k], pose);
      t.elastic_N = glm::length(c.dF_dC1[k]);
      t.friction_force = rec_.sensor_force_from_burr_force(c.dFmu_dmu[k], pose);
      if (!wrench) continue;
      t.elastic_moment = rec_.sensor_torque_from_burr_wrench(c.dF_dC1[k], glm::dvec3(0), tr.centre_vol_mm[j], pose);
      t.friction_moment = rec_.sensor_torque_from_burr_wrench(c.dFmu_dmu[k], c.dTmu_dmu[k], tr.centre_vol_mm[j], pose);
      t.friction_spindle = model::spindle_torque_Nmm(c.dTmu_dmu[k], tr.omega_vol_rad_s[j]);
    }
  }
  return out;
}

namespace {

// The force columns within model::sensitivities_diverged's bound of the largest predicted
// force; the moment and spindle columns finite. The fallback differences with the model's
// difference steps (DiffSteps).
bool plausible_columns(const Prediction& p) {
  double fmax = 0;
  for (const auto& f : p.force_sensor_N) fmax = std::max(fmax, glm::length(f));
  if (model::sensitivities_diverged(p.columns, fmax)) return false;
  for (const auto& col : p.torque_columns)
    for (const auto& v : col)
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return false;
  for (const auto& col : p.spindle_columns)
    for (const double v : col)
      if (!std::isfinite(v)) return false;
  return true;
}

}  // namespace

namespace {
// A solve's last accepted point and the trials after it. The Jacobians are kept apart from
// the values alone, so that trial points do not push out the Jacobian a later solve (the
// second refine pass, the covariance) starts from. Four values: assess's contact checks
// and, without profiles, the covariance rules each evaluate every class with α at its
// bound (no erosion), one class after the other. Reference single start: 105 → 100
// replays (sensitivities), 849 → 739 (fd) against 3 of either kind.
constexpr std::size_t kRememberedJacobians = 2, kRememberedValues = 4;

// Everything of an EvalPoint a prediction depends on, as numbers.
std::vector<double> point_key(const EvalPoint& at) {
  std::vector<double> k;
  k.reserve(3 * kLabels + 14);
  for (const PerLabel* v : {&at.physics.alpha, &at.physics.c1, &at.physics.mu}) k.insert(k.end(), v->begin(), v->end());
  k.insert(k.end(), {at.lag_ms, at.depth_mm, double(at.geometry_terms), double(at.has_pose)});
  k.insert(k.end(), at.pose.begin(), at.pose.end());
  k.insert(k.end(), {at.pose_centre_vol_mm.x, at.pose_centre_vol_mm.y, at.pose_centre_vol_mm.z});
  return k;
}
}  // namespace

void ReplayRecordingModel::forget() {
  std::lock_guard lk(memory_mu_);
  memory_columns_.clear();
  memory_values_.clear();
}

void ReplayRecordingModel::predict(const EvalPoint& at, const std::vector<Column>& columns,
                                   Prediction& out) const {
  std::vector<double> key = point_key(at);
  {
    std::lock_guard lk(memory_mu_);
    for (const auto* kept : {&memory_values_, &memory_columns_})
      for (const Remembered& m : *kept) {
        if (!(m.key == key && (columns.empty() || m.columns == columns))) continue;
        out = *m.prediction;
        if (columns.empty()) {  // the values only, as a prediction without columns is
          out.columns.clear();
          out.torque_columns.clear();
          out.spindle_columns.clear();
        }
        out.replays = 0;
        ++remembered_;
        return;
      }
  }
  compute(at, columns, out);
  auto kept = std::make_shared<const Prediction>(out);
  std::lock_guard lk(memory_mu_);
  auto& list = columns.empty() ? memory_values_ : memory_columns_;
  list.push_front({std::move(key), columns, std::move(kept)});
  if (list.size() > (columns.empty() ? kRememberedValues : kRememberedJacobians)) list.pop_back();
}

void ReplayRecordingModel::compute(const EvalPoint& at, const std::vector<Column>& columns,
                                   Prediction& out) const {
  // Exact forward sensitivities (one replay) for the full Jacobian; the fixed-geometry
  // pre-fit (geometry_terms = false) and plain evaluations need no replay derivatives.
  std::uint64_t spent = 0;  // replays of a diverged sensitivity attempt
  if (derivatives_ == Derivatives::kSensitivities && at.geometry_terms && !columns.empty()) {
    predict_sensitivities(at, columns, out);
    if (plausible_columns(out)) return;
    // The tangent grew without bound (seen at R/l = 5 on a shallow plunge: columns of
    // 1e97): such a Jacobian would freeze its parameters. Difference the replay instead.
    ++diverged_;
    spent = out.replays;
    out = Prediction{};
  }
  const double lag_s = at.lag_ms * 1e-3;
  const model::PoseCorrection pose = pose_of(at);
  auto job = [&](const PhysicsValues& v, double lag, double depth,
                 const model::PoseCorrection* shifted = nullptr) {
    const model::PoseCorrection* p = shifted ? shifted : (at.has_pose ? &pose : nullptr);
    return ReplayPool::Job{&rec_.sample_id, rec_.radius_mm, to_model_params(v),
                           rec_.trajectory(lag, depth, p), options_, {}};
  };
  std::vector<ReplayPool::Job> jobs;
  std::vector<const model::PoseCorrection*> job_pose;  // per job: the pose it was replayed with
  std::deque<model::PoseCorrection> shifted_poses;     // the pose pairs' (stable addresses)
  auto add = [&](ReplayPool::Job j, const model::PoseCorrection* p) {
    jobs.push_back(std::move(j));
    job_pose.push_back(p);
  };
  const model::PoseCorrection* base_pose = at.has_pose ? &pose : nullptr;
  add(job(at.physics, lag_s, at.depth_mm), base_pose);
  // Which difference pairs are needed: ln α of a class (own column or coupling term of
  // its C1/μ), lag, depth.
  std::array<int, kLabels> alpha_pair;
  alpha_pair.fill(-1);
  int lag_pair = -1, depth_pair = -1;
  std::array<int, 6> pose_pair;
  pose_pair.fill(-1);
  for (const auto& c : columns) {
    const bool physics = c.kind == ColumnKind::kLogAlpha ||
                         ((c.kind == ColumnKind::kLogC1 || c.kind == ColumnKind::kLogMu) &&
                          at.geometry_terms);
    if (physics && alpha_pair[c.label] < 0 && std::isfinite(at.physics.alpha[c.label]) &&
        options_.erosion) {
      alpha_pair[c.label] = int(jobs.size());
      for (double s : {+1.0, -1.0}) {
        PhysicsValues v = at.physics;
        v.alpha[c.label] *= std::exp(s * steps_.log_alpha[c.label]);
        add(job(v, lag_s, at.depth_mm), base_pose);
      }
    }
    if (c.kind == ColumnKind::kLagMs && lag_pair < 0) {
      lag_pair = int(jobs.size());
      for (double s : {+1.0, -1.0})
        add(job(at.physics, lag_s + s * steps_.lag_ms * 1e-3, at.depth_mm), base_pose);
    }
    if (c.kind == ColumnKind::kDepthMm && depth_pair < 0) {
      depth_pair = int(jobs.size());
      for (double s : {+1.0, -1.0})
        add(job(at.physics, lag_s, at.depth_mm + s * steps_.depth_mm), base_pose);
    }
    if (c.kind == ColumnKind::kPose && pose_pair[c.label] < 0) {
      pose_pair[c.label] = int(jobs.size());
      for (double s : {+1.0, -1.0}) {
        model::PoseCorrection& q = shifted_poses.emplace_back(pose);
        if (c.label < 3) q.rotation_rad[c.label] += s * kPoseStep[c.label];
        else q.translation_mm[c.label - 3] += s * kPoseStep[c.label];
        add(job(at.physics, lag_s, at.depth_mm, &q), &q);
      }
    }
  }
  pool_.run(jobs);
  out.replays = jobs.size() + spent;
  const std::size_t n = size();
  const auto& base = jobs[0].result;
  fill_base(base, jobs[0].trajectory, base_pose, out);
  if (!at.geometry_terms) out.fixed = fixed_geometry_terms(at, base, jobs[0].trajectory, base_pose);
  // A column of every fitted channel: the force (sensor frame), and with the moment and
  // spindle channels their columns, from the same partials and difference pairs.
  struct Deriv {
    glm::dvec3 force{0}, moment{0};
    double spindle = 0;
    void subtract(const Deriv& d, double w) { force -= w * d.force, moment -= w * d.moment, spindle -= w * d.spindle; }
  };
  const bool wrench = channels_.torque || channels_.spindle;
  auto wrench_of = [&](std::size_t job_index, std::size_t j) {
    const auto& J = jobs[job_index];
    const model::ContactResult& c = J.result.samples[j].contact;
    const model::PoseCorrection* p = job_pose[job_index];
    return Deriv{rec_.sensor_force_from_burr_force(c.force_N, p),
                 wrench ? rec_.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, J.trajectory.centre_vol_mm[j], p)
                        : glm::dvec3(0),
                 wrench ? model::spindle_torque_Nmm(c.moment_Nmm, J.trajectory.omega_vol_rad_s[j]) : 0.0};
  };
  auto central = [&](int pair, double h, std::size_t j) {
    const Deriv a = wrench_of(std::size_t(pair), j);
    const Deriv b = wrench_of(std::size_t(pair) + 1, j);
    return Deriv{(a.force - b.force) / (2 * h), (a.moment - b.moment) / (2 * h), (a.spindle - b.spindle) / (2 * h)};
  };
  // At fixed geometry: dF and dT on the burr (volume frame) → every channel.
  const auto& tr0 = jobs[0].trajectory;
  auto fixed = [&](const glm::dvec3& dF, const glm::dvec3& dT, std::size_t j) {
    return Deriv{rec_.sensor_force_from_burr_force(dF, base_pose),
                 wrench ? rec_.sensor_torque_from_burr_wrench(dF, dT, tr0.centre_vol_mm[j], base_pose) : glm::dvec3(0),
                 wrench ? model::spindle_torque_Nmm(dT, tr0.omega_vol_rad_s[j]) : 0.0};
  };
  out.columns.clear();
  out.torque_columns.clear();
  out.spindle_columns.clear();
  for (const auto& c : columns) {
    std::vector<Deriv> col(n);
    const std::size_t k = c.label;
    for (std::size_t j = 0; j < n; ++j) {
      const auto& ct = base.samples[j].contact;
      const Deriv geo = alpha_pair[k] >= 0 ? central(alpha_pair[k], steps_.log_alpha[k], j) : Deriv{};
      const double coupling = at.geometry_terms ? 1.0 : 0.0;
      switch (c.kind) {
        case ColumnKind::kLogAlpha: col[j] = geo; break;
        case ColumnKind::kLogC1: {
          // ∂F/∂C1_k at fixed geometry: elastic partial plus friction's |F_e| scaling
          // (the couple T scales with |F_e| like the friction force).
          const double fe = glm::length(ct.elastic_N);
          const double scale = fe > 0 ? glm::dot(ct.dF_dC1[k], ct.elastic_N) / (fe * fe) : 0.0;
          const glm::dvec3 dF = at.physics.c1[k] * (ct.dF_dC1[k] + ct.friction_N * scale);
          const glm::dvec3 dT = at.physics.c1[k] * scale * ct.moment_Nmm;
          col[j] = fixed(dF, dT, j);
          col[j].subtract(geo, coupling);
          break;
        }
        case ColumnKind::kLogMu:
          col[j] = fixed(at.physics.mu[k] * ct.dFmu_dmu[k], at.physics.mu[k] * ct.dTmu_dmu[k], j);
          col[j].subtract(geo, coupling);
          break;
        case ColumnKind::kLagMs: col[j] = central(lag_pair, steps_.lag_ms, j); break;
        case ColumnKind::kDepthMm: col[j] = central(depth_pair, steps_.depth_mm, j); break;
        case ColumnKind::kPose: col[j] = central(pose_pair[k], kPoseStep[k], j); break;
      }
    }
    std::vector<glm::dvec3> f(n), m;
    std::vector<double> sp;
    for (std::size_t j = 0; j < n; ++j) f[j] = col[j].force;
    out.columns.push_back(std::move(f));
    if (!wrench) continue;
    for (std::size_t j = 0; j < n; ++j) {
      m.push_back(col[j].moment);
      sp.push_back(col[j].spindle);
    }
    out.torque_columns.push_back(std::move(m));
    out.spindle_columns.push_back(std::move(sp));
  }
}

void ReplayRecordingModel::predict_sensitivities(const EvalPoint& at, const std::vector<Column>& columns,
                                                 Prediction& out) const {
  const double lag_s = at.lag_ms * 1e-3;
  const model::PoseCorrection pose = pose_of(at);
  std::vector<model::Direction> dirs;
  std::vector<int> dir_of(columns.size(), -1);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    const auto& col = columns[c];
    model::Direction d;
    d.label = col.label;
    switch (col.kind) {
      case ColumnKind::kLogAlpha: d.kind = model::Direction::Kind::kLogAlpha; break;
      case ColumnKind::kLogC1: d.kind = model::Direction::Kind::kLogC1; break;
      case ColumnKind::kLogMu: d.kind = model::Direction::Kind::kLogMu; break;
      case ColumnKind::kLagMs:
        d.kind = model::Direction::Kind::kPath;
        d.dcentre_vol_mm = rec_.dcentre_dlag_ms(lag_s);
        break;
      case ColumnKind::kDepthMm:
        d.kind = model::Direction::Kind::kPath;
        d.dcentre_vol_mm.assign(size() + rec_.via_times.size(), -rec_.shaft_axis_vol);  // centre − depth·axis
        break;
      case ColumnKind::kPose: {
        d.kind = model::Direction::Kind::kPath;
        // At the uncorrected centres, the vias' too.
        for (const auto& c : rec_.trajectory(lag_s, at.depth_mm).path_centres_vol_mm())
          d.dcentre_vol_mm.push_back(pose.derivative(int(col.label), c));
        break;
      }
    }
    // Lag and depth move the uncorrected centre; the pose maps that move by its rotation.
    if ((col.kind == ColumnKind::kLagMs || col.kind == ColumnKind::kDepthMm) && at.has_pose)
      for (auto& v : d.dcentre_vol_mm) v = pose.apply(v + pose.centre_vol_mm) - pose.apply(pose.centre_vol_mm);
    dir_of[c] = int(dirs.size());
    dirs.push_back(std::move(d));
  }
  model::Sensitivities sens;
  std::vector<ReplayPool::Job> jobs;
  jobs.push_back(ReplayPool::Job{&rec_.sample_id, rec_.radius_mm, to_model_params(at.physics),
                                 rec_.trajectory(lag_s, at.depth_mm, at.has_pose ? &pose : nullptr),
                                 options_, {}});
  jobs[0].options.directions = &dirs;
  jobs[0].options.sensitivities = &sens;
  jobs[0].options.moment_sensitivities = channels_.torque || channels_.spindle;
  pool_.run(jobs);
  out.replays = 1;
  const std::size_t n = size();
  const auto& base = jobs[0].result;
  const auto& tr = jobs[0].trajectory;
  const model::PoseCorrection* p_at = at.has_pose ? &pose : nullptr;
  fill_base(base, tr, p_at, out);
  out.columns.clear();
  out.torque_columns.clear();
  out.spindle_columns.clear();
  // The sensor's origin in the corrected volume frame (the moment's lever).
  const glm::dvec3 origin_vol = [&] {
    const glm::dvec3 o = rec_.rig_to_vol.apply(rec_.sensor_origin_rig_mm);
    return p_at ? p_at->apply(o) : o;
  }();
  for (std::size_t c = 0; c < columns.size(); ++c) {
    std::vector<glm::dvec3> col(n);
    const std::size_t di = std::size_t(dir_of[c]);
    const auto& d = sens.dforce_N[di];
    // A turn of the pose (ω_k) also turns the rig's axes the sensor reads in, its origin
    // and the spin axis: e_k × (the vector) for each, at the corrected pose. The friction
    // turns with the spin axis ω̂ (F_μ = Σ_k μ_k G_k × ω̂); what the replay does not
    // differentiate is the couple's and the erosion's dependence on the axis
    // (docs/calibration.md "The pose correction, applied whole").
    const bool turn = columns[c].kind == ColumnKind::kPose && columns[c].label < 3;
    glm::dvec3 e(0);
    if (turn) e[columns[c].label] = 1;
    auto turned_friction = [&](std::size_t j) {
      const auto& ct = base.samples[j].contact;
      const double w = glm::length(tr.omega_vol_rad_s[j]);
      glm::dvec3 df(0);
      if (!(w > 0) || !ct.class_mask) return df;
      const glm::dvec3 de = glm::cross(e, tr.omega_vol_rad_s[j] / w);
      for (int k = 1; k < kLabels; ++k)
        if ((ct.class_mask >> k) & 1u) df += at.physics.mu[std::size_t(k)] * glm::cross(ct.friction_lever[std::size_t(k)], de);
      return df;
    };
    std::vector<glm::dvec3> axis_term(turn ? n : 0);
    for (std::size_t j = 0; j < axis_term.size(); ++j) axis_term[j] = turned_friction(j);
    for (std::size_t j = 0; j < n; ++j) {
      glm::dvec3 f = d[j];
      if (turn) f += axis_term[j] - glm::cross(e, base.samples[j].contact.force_N);
      col[j] = rec_.sensor_force_from_burr_force(f, p_at);
    }
    out.columns.push_back(std::move(col));
    if (!channels_.torque && !channels_.spindle) continue;
    // Moment about the sensor origin: s·Qᵀ·Rᵀ((p − o) × ∂F + (∂p − ∂o) × F + ∂T), and for a
    // turn − e × m; spindle −∂T·ω̂ (− T·(e × ω̂) for a turn).
    const auto& dT = sens.dmoment_Nmm[di];
    const auto& dp = dirs[di].dcentre_vol_mm;  // empty for the constants
    const glm::dvec3 dorigin = turn ? glm::cross(e, origin_vol - pose.centre_vol_mm) : glm::dvec3(0);
    std::vector<glm::dvec3> tcol;
    std::vector<double> scol;
    for (std::size_t j = 0; j < n; ++j) {
      const auto& ct = base.samples[j].contact;
      if (channels_.torque) {
        const glm::dvec3 dF = turn ? d[j] + axis_term[j] : d[j];
        glm::dvec3 m = rec_.sensor_torque_from_burr_wrench(dF, dT[j], tr.centre_vol_mm[j], p_at);
        glm::dvec3 extra(0);
        if (!dp.empty()) extra += glm::cross(dp[j], ct.force_N);
        if (turn) {
          const glm::dvec3 m_vol = glm::cross(tr.centre_vol_mm[j] - origin_vol, ct.force_N) + ct.moment_Nmm;
          extra -= glm::cross(dorigin, ct.force_N) + glm::cross(e, m_vol);
        }
        m += rec_.sensor_force_from_burr_force(extra, p_at);
        tcol.push_back(m);
      }
      if (channels_.spindle) {
        double sp = model::spindle_torque_Nmm(dT[j], tr.omega_vol_rad_s[j]);
        const double w = glm::length(tr.omega_vol_rad_s[j]);
        if (turn && w > 0) sp -= glm::dot(ct.moment_Nmm, glm::cross(e, tr.omega_vol_rad_s[j] / w));
        scol.push_back(sp);
      }
    }
    out.torque_columns.push_back(std::move(tcol));
    out.spindle_columns.push_back(std::move(scol));
  }
}

}  // namespace burrbench::calibration
