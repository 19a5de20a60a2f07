#include "burrbench/calibration/fixed_geometry_model.hpp"

#include <stdexcept>

namespace burrbench::calibration {

FixedGeometryModel::FixedGeometryModel(const RecordingModel& recording, Prediction at_replay)
    : recording_(recording), replay_(std::move(at_replay)) {
  if (!replay_.fixed) throw std::logic_error("FixedGeometryModel: the prediction has no fixed-geometry terms");
  const auto& F = *replay_.fixed;
  const std::size_t nl = F.labels.size(), n = size();
  elastic_N_.assign(n, 0.0);
  for (std::size_t j = 0; j < n; ++j)
    for (std::size_t i = 0; i < nl; ++i) elastic_N_[j] += F.at.c1[F.labels[i]] * F.terms[j * nl + i].elastic_N;
}

void FixedGeometryModel::predict(const EvalPoint& at, const std::vector<Column>& columns,
                                 Prediction& out) const {
  const auto& F = *replay_.fixed;
  const std::size_t nl = F.labels.size(), n = size();
  const bool torque = !replay_.torque_sensor_Nmm.empty(), spindle = !replay_.spindle_Nmm.empty();
  // Which class entry (or none) each column belongs to.
  std::vector<int> entry(columns.size(), -1);
  for (std::size_t c = 0; c < columns.size(); ++c) {
    if (columns[c].kind != ColumnKind::kLogC1 && columns[c].kind != ColumnKind::kLogMu)
      throw std::logic_error("FixedGeometryModel: the geometry is held; only ln C1 and ln μ columns exist");
    for (std::size_t i = 0; i < nl; ++i)
      if (F.labels[i] == columns[c].label) entry[c] = int(i);
  }
  out = Prediction{};
  out.buried = replay_.buried;
  out.class_mask = replay_.class_mask;
  out.removed_mm3 = replay_.removed_mm3;
  out.force_sensor_N.assign(n, glm::dvec3(0));
  if (torque) out.torque_sensor_Nmm.assign(n, glm::dvec3(0));
  if (spindle) out.spindle_Nmm.assign(n, 0.0);
  out.columns.assign(columns.size(), std::vector<glm::dvec3>(n, glm::dvec3(0)));
  if (torque) out.torque_columns.assign(columns.size(), std::vector<glm::dvec3>(n, glm::dvec3(0)));
  if (spindle) out.spindle_columns.assign(columns.size(), std::vector<double>(n, 0.0));
  const auto& c1 = at.physics.c1;
  const auto& mu = at.physics.mu;
  for (std::size_t j = 0; j < n; ++j) {
    const auto* t = F.terms.data() + j * nl;
    // |F_e| at these C1's, relative to the replay's: the friction's scale.
    double fe = 0;
    glm::dvec3 fe_force(0), fe_moment(0), mu_force(0), mu_moment(0);
    double mu_spindle = 0;
    for (std::size_t i = 0; i < nl; ++i) {
      const std::size_t k = F.labels[i];
      fe += c1[k] * t[i].elastic_N;
      fe_force += c1[k] * t[i].elastic_force;
      fe_moment += c1[k] * t[i].elastic_moment;
      mu_force += mu[k] * t[i].friction_force;
      mu_moment += mu[k] * t[i].friction_moment;
      mu_spindle += mu[k] * t[i].friction_spindle;
    }
    const double fe0 = elastic_N_[j];
    const double scale = fe0 > 0 ? fe / fe0 : 0.0;
    out.force_sensor_N[j] = fe_force + scale * mu_force;
    if (torque) out.torque_sensor_Nmm[j] = fe_moment + scale * mu_moment;
    if (spindle) out.spindle_Nmm[j] = scale * mu_spindle;
    for (std::size_t c = 0; c < columns.size(); ++c) {
      if (entry[c] < 0) continue;  // a class this replay never touched
      const auto& ti = t[entry[c]];
      const std::size_t k = columns[c].label;
      if (columns[c].kind == ColumnKind::kLogC1) {
        const double dscale = fe0 > 0 ? c1[k] * ti.elastic_N / fe0 : 0.0;
        out.columns[c][j] = c1[k] * ti.elastic_force + dscale * mu_force;
        if (torque) out.torque_columns[c][j] = c1[k] * ti.elastic_moment + dscale * mu_moment;
        if (spindle) out.spindle_columns[c][j] = dscale * mu_spindle;
      } else {
        out.columns[c][j] = scale * mu[k] * ti.friction_force;
        if (torque) out.torque_columns[c][j] = scale * mu[k] * ti.friction_moment;
        if (spindle) out.spindle_columns[c][j] = scale * mu[k] * ti.friction_spindle;
      }
    }
  }
}

}  // namespace burrbench::calibration
