#pragma once
// A recording predicted at fixed geometry: the χ history of one replay held, other C1's
// and μ's evaluated exactly from that replay's per-class terms (FixedGeometryTerms)
// without replaying. The pre-fit (Objective::prefit) solves on it: α, lag, depth and pose are
// held there, so only the ln C1, ln μ columns (and the objective's linear nuisances) are
// ever asked for.
#include <vector>

#include "burrbench/calibration/recording_model.hpp"

namespace burrbench::calibration {

class FixedGeometryModel final : public RecordingModel {
 public:
  // `at_replay`: a replay's prediction with its fixed-geometry terms (Prediction::fixed).
  FixedGeometryModel(const RecordingModel& recording, Prediction at_replay);
  const std::string& id() const override { return recording_.id(); }
  std::size_t size() const override { return recording_.size(); }
  const std::vector<double>& t_s() const override { return recording_.t_s(); }
  const std::vector<glm::dvec3>& measured_sensor_N() const override { return recording_.measured_sensor_N(); }
  const std::vector<glm::dvec3>& measured_torque_Nmm() const override { return recording_.measured_torque_Nmm(); }
  const std::vector<double>& measured_spindle_Nmm() const override { return recording_.measured_spindle_Nmm(); }
  const std::vector<double>& spindle_krpm() const override { return recording_.spindle_krpm(); }
  // Only `at.physics` is read (the geometry is the replay's). std::logic_error for a
  // column other than ln C1 or ln μ.
  void predict(const EvalPoint& at, const std::vector<Column>& columns, Prediction& out) const override;

 private:
  const RecordingModel& recording_;
  Prediction replay_;
  std::vector<double> elastic_N_;  // |F_e| of the replay per sample
};

}  // namespace burrbench::calibration
