#pragma once
// The force/torque sensor's mounting from a few static loads (docs/rig.md "Sensor pose"):
// known forces applied at known points of the rig (weights hung from hooks, or pulled
// sideways over a pulley), each read as a bias-free mean wrench. A reading is the load in
// the sensor's axes: F_s = Qᵀ f, M_s = Qᵀ((a − o) × f), with Q the rotation sensor → rig
// and o the sensor origin (rig frame). Q and o are estimated by alternating Wahba's
// problem (Horn's quaternion, forces and lever-scaled moments together) with the linear
// least squares for o, to convergence.
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::model {

struct StaticLoad {
  glm::dvec3 force_rig_N{0};       // the applied load, rig frame
  glm::dvec3 point_rig_mm{0};      // where it acts, rig frame
  glm::dvec3 force_sensor_N{0};    // the mean reading with the load, minus the unloaded one
  glm::dvec3 moment_sensor_Nmm{0};
};

struct SensorPoseFit {
  glm::dmat3 rotation_sensor_to_rig{1.0};  // v_rig = Q·v_sensor
  glm::dvec3 origin_rig_mm{0};
  // The direction along which the origin is not determined (all loads parallel to it:
  // moving o along a force does not change its moment); 0 when every direction is.
  // Along it o is left at its least-norm value.
  glm::dvec3 unobservable_rig{0};
  std::vector<double> force_residual_N, moment_residual_Nmm;  // per load
  double force_rms_N = 0, moment_rms_Nmm = 0;
  int iterations = 0;
};

// ≥ 2 loads, finite, not all zero; loads whose directions and moments leave the rotation
// undetermined (every load and reading on one line) are refused. InputError naming
// `file` and the field.
SensorPoseFit estimate_sensor_pose(const std::vector<StaticLoad>& loads, const std::string& file);

}  // namespace burrbench::model
