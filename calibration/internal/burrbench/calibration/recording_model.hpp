#pragma once
// What the calibration needs from one recording: the measured sensor force at every
// force sample and a way to predict it (and its derivatives) for given parameters.
// ReplayRecordingModel (replay_model.hpp) implements it with the voxel model; tests can
// implement it with a closed-form model to check the solver machinery alone.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/calibration/derivatives.hpp"
#include "burrbench/calibration/parameters.hpp"

namespace burrbench::calibration {

// A derivative the solver asks for: d(predicted sensor force)/d(column).
enum class ColumnKind { kLogAlpha, kLogC1, kLogMu, kLagMs, kDepthMm, kPose };
struct Column {
  ColumnKind kind = ColumnKind::kLogC1;
  std::uint8_t label = 0;  // class label for the physics columns; 0..5 (ωx ωy ωz τx τy τz) for kPose
  bool operator==(const Column&) const = default;
};

struct EvalPoint {
  PhysicsValues physics;
  double lag_ms = 0;
  double depth_mm = 0;
  // false: C1/μ columns at fixed geometry only (no erosion-coupling term; cheaper, used
  // by the starting-value scan).
  bool geometry_terms = true;
  // Registration pose correction of the recording's mounting (ω rad, τ mm, about the centre).
  bool has_pose = false;
  std::array<double, 6> pose{};
  glm::dvec3 pose_centre_vol_mm{0};
};

// At fixed geometry (the voxels' χ history of one replay held), every predicted channel
// is exact in the C1's and μ's (MODEL.md "Forces"): F_e = Σ_k C1_k·E_k with every E_k
// along n̂, so |F_e| = Σ_k C1_k·|E_k|, and the friction force, its couple and the spindle
// load are Σ_k μ_k·(per unit μ_k) scaled by |F_e|. These are the per-sample, per-class
// ingredients, in the sensor frame; FixedGeometryModel (fixed_geometry_model.hpp) predicts
// from them at other C1's and μ's without a replay.
struct FixedGeometryTerms {
  std::vector<std::uint8_t> labels;  // the classes with terms, in the order of each sample's entries
  PhysicsValues at;                  // the constants the replay ran with
  struct Class {
    glm::dvec3 elastic_force{0}, elastic_moment{0};  // per unit C1_k (N/(N/mm²), N·mm/(N/mm²))
    double elastic_N = 0;                             // |E_k|, burr frame
    glm::dvec3 friction_force{0}, friction_moment{0};  // per unit μ_k at the replay's |F_e|
    double friction_spindle = 0;
  };
  std::vector<Class> terms;  // sample j, class i at [j·labels.size() + i]
};

struct Prediction {
  std::vector<glm::dvec3> force_sensor_N;        // predicted sensor reading without bias
  std::vector<std::uint8_t> buried;              // 1: normal ill-defined at this sample
  std::vector<std::uint8_t> class_mask;          // bit k: class k in contact
  PerLabel removed_mm3{};                        // bone removed per class over the replay
  std::vector<std::vector<glm::dvec3>> columns;  // one per requested Column, per sample
  std::uint64_t replays = 0;                     // replays this prediction cost
  // With the torque / spindle channels (RecordingModel::set_channels): the sensor's
  // predicted moment (N·mm, sensor frame, no bias) and the spindle's cutting load (N·mm,
  // no idle terms), with their columns in the order of `columns`.
  std::vector<glm::dvec3> torque_sensor_Nmm;
  std::vector<double> spindle_Nmm;
  std::vector<std::vector<glm::dvec3>> torque_columns;
  std::vector<std::vector<double>> spindle_columns;
  // Set for a prediction at EvalPoint::geometry_terms = false by models that have a
  // geometry (ReplayRecordingModel); null otherwise.
  std::shared_ptr<const FixedGeometryTerms> fixed;
};

class RecordingModel {
 public:
  virtual ~RecordingModel() = default;
  virtual const std::string& id() const = 0;
  virtual std::size_t size() const = 0;                          // force samples
  virtual const std::vector<double>& t_s() const = 0;            // from the first sample
  virtual const std::vector<glm::dvec3>& measured_sensor_N() const = 0;
  // Called concurrently for different models, and for one model by solves that run side
  // by side (the multistart's): must be safe for both.
  virtual void predict(const EvalPoint& at, const std::vector<Column>& columns,
                       Prediction& out) const = 0;
  // The other measured channels (empty when the recording has none): the sensor's moment
  // (N·mm, sensor frame), the spindle's load torque (N·mm) and its speed in 1000 rpm minus
  // the recording's mean (the viscous term's regressor), at the force samples.
  virtual const std::vector<glm::dvec3>& measured_torque_Nmm() const { return no_vectors_; }
  virtual const std::vector<double>& measured_spindle_Nmm() const { return no_values_; }
  virtual const std::vector<double>& spindle_krpm() const { return no_values_; }

 private:
  inline static const std::vector<glm::dvec3> no_vectors_{};
  inline static const std::vector<double> no_values_{};
};

}  // namespace burrbench::calibration
