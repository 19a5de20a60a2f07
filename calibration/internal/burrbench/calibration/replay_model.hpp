#pragma once
// RecordingModel backed by the voxel replay (model::replay) of one aligned recording.
//
// Derivatives (docs/calibration.md "Derivatives"):
//  - C1, μ: the kernel's exact partials at fixed geometry (F_e linear in C1, F_μ linear in
//    μ and in |F_e|), plus the erosion-coupling term: the eroded geometry depends on the
//    class's μ·C1/α, so ∂F/∂ln C1_k and ∂F/∂ln μ_k gain −∂F/∂ln α_k (approximate when
//    several classes are in contact at once);
//  - ln α, lag, depth offset: central differences of whole replays with steps chosen from
//    a measured cost sweep (steps.hpp), never Ceres's 1e-6 relative default, which is
//    below the float resolution of χ and the voxel-scale texture of the force;
//  - bias: linear, exact (in the objective).
// The replays of one prediction (base + difference pairs) run on the shared ReplayPool.
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "burrbench/calibration/recording_model.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/reach.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::calibration {

// Worker threads, each with its own copy of the part of every sample its replays reach
// (a replay erodes its Volume, one replay per copy at a time; model/reach.hpp); replays
// restore their volume through the undo log. The samples must outlive the pool.
class ReplayPool {
 public:
  ReplayPool(const std::map<std::string, data_schema::SampleVolume>& samples, int threads);
  ~ReplayPool();
  ReplayPool(const ReplayPool&) = delete;
  ReplayPool& operator=(const ReplayPool&) = delete;

  struct Job {
    const std::string* sample_id;
    double radius_mm;
    model::ModelParams params;
    model::Trajectory trajectory;
    model::ReplayOptions options;
    model::ReplayResult result;  // out
  };
  // Runs every job (any thread may call; calls may overlap) and returns when all are done.
  // A free worker takes the queued job with the most work first (longest processing
  // time first): a long recording started last would leave the other worker idle while
  // it runs alone.
  void run(std::vector<Job>& jobs);
  int threads() const { return int(workers_.size()); }

  // What the pool's replays have cost so far, by kind: plain, or carrying sensitivities
  // (Job::options.directions set). The CPU time is the worker thread's own, so a busy
  // machine does not inflate it. From it a fit reports its replays in plain-replay
  // equivalents (docs/calibration.md "Derivatives").
  struct Tally {
    std::uint64_t replays = 0;
    std::uint64_t samples = 0;  // trajectory samples replayed
    double cpu_s = 0;
  };
  struct Work {
    Tally plain, sensitivity;
    // CPU per sample of a sensitivity replay over that of a plain one; NaN without both.
    double sensitivity_cost() const;
  };
  Work work_done() const;

 private:
  void work(std::size_t w);
  std::vector<model::ReachVolumes> volumes_;  // per worker
  std::vector<std::thread> workers_;
  mutable std::mutex mu_;
  std::condition_variable cv_, done_cv_;
  struct Queued {
    double work;  // plain-replay equivalents × samples
    std::function<void(std::size_t)> run;
  };
  std::deque<Queued> queue_;  // ordered by work, most first; equal work in arrival order
  bool stop_ = false;
  Work done_;  // under mu_
};

struct DiffSteps {
  PerLabel log_alpha = [] { PerLabel a; a.fill(0.1); return a; }();  // ln α, per class
  double lag_ms = 1.0;
  double depth_mm = 0.02;
};

class ReplayRecordingModel final : public RecordingModel {
 public:
  ReplayRecordingModel(const model::AlignedRecording& rec, ReplayPool& pool,
                       model::ReplayOptions options = {});
  const std::string& id() const override { return rec_.id; }
  std::size_t size() const override { return rec_.t_s.size(); }
  const std::vector<double>& t_s() const override { return rec_.t_s; }
  const std::vector<glm::dvec3>& measured_sensor_N() const override { return rec_.force_sensor_N; }
  void predict(const EvalPoint& at, const std::vector<Column>& columns,
               Prediction& out) const override;

  const model::AlignedRecording& recording() const { return rec_; }
  // Also predict the sensor's moment and the spindle's load (and, with sensitivities,
  // their columns). InputError when the recording lacks a channel asked for.
  void set_channels(const Channels& c, const std::string& file_for_messages);
  const std::vector<glm::dvec3>& measured_torque_Nmm() const override { return rec_.torque_sensor_Nmm; }
  const std::vector<double>& measured_spindle_Nmm() const override { return spindle_Nmm_; }
  const std::vector<double>& spindle_krpm() const override { return krpm_; }
  void set_steps(const DiffSteps& s) { steps_ = s; forget(); }
  void set_derivatives(Derivatives d) { derivatives_ = d; forget(); }
  const DiffSteps& steps() const { return steps_; }
  // Predictions served from the model's memory of its last ones (no replay).
  std::uint64_t remembered() const { return remembered_.load(); }
  // Jacobians whose forward sensitivities diverged (a non-finite value, or a column larger
  // than model::kMaxSensitivityRatio × the recording's largest predicted force per unit of
  // its parameter) and were therefore taken by finite differences at that point.
  std::uint64_t diverged_sensitivities() const { return diverged_.load(); }

 private:
  void compute(const EvalPoint& at, const std::vector<Column>& columns, Prediction& out) const;
  void predict_sensitivities(const EvalPoint& at, const std::vector<Column>& columns,
                             Prediction& out) const;
  void forget();
  // The base replay's predictions (force, and the moment and spindle load when asked).
  // `pose`: the registration's correction the replay was made with (null: none).
  void fill_base(const model::ReplayResult& base, const model::Trajectory& tr, const model::PoseCorrection* pose,
                 Prediction& out) const;
  // The kernel's fixed-geometry partials of the base replay (Prediction::fixed).
  std::shared_ptr<const FixedGeometryTerms> fixed_geometry_terms(const EvalPoint& at,
                                                                 const model::ReplayResult& base,
                                                                 const model::Trajectory& tr,
                                                                 const model::PoseCorrection* pose) const;
  const model::AlignedRecording& rec_;
  ReplayPool& pool_;
  Channels channels_;
  std::vector<double> spindle_Nmm_, krpm_;  // at the force samples
  model::ReplayOptions options_;
  DiffSteps steps_;
  Derivatives derivatives_ = Derivatives::kFiniteDifferences;
  mutable std::atomic<std::uint64_t> diverged_{0};
  // The last few predictions, by point and columns. A replay is deterministic, and each
  // solve of a calibration starts where the one before ended (refine after the search, the
  // second refine pass, the covariance at the optimum): the Jacobian there was already
  // replayed. One solve's own repeats are caught by its cost's cache (objective.cpp).
  // Those with columns and the values alone are kept apart (replay_model.cpp).
  struct Remembered {
    std::vector<double> key;
    std::vector<Column> columns;
    std::shared_ptr<const Prediction> prediction;
  };
  mutable std::mutex memory_mu_;
  mutable std::deque<Remembered> memory_columns_;  // with columns, most recent first
  mutable std::deque<Remembered> memory_values_;   // without columns, most recent first
  mutable std::atomic<std::uint64_t> remembered_{0};
};

model::ModelParams to_model_params(const PhysicsValues& v);

}  // namespace burrbench::calibration
