#pragma once
// Rigid transform rig → volume (x_vol = R·x_rig + t) and its fit to fiducial pairs.
// The fit is Horn's closed-form quaternion method (least squares, always a proper
// rotation, never a reflection); GLM has no eigen/SVD routine, so a small Jacobi
// eigen-solver lives in registration.cpp.
#include <glm/glm.hpp>
#include <string>
#include <vector>

namespace burrbench::model {

struct RigidTransform {
  glm::dmat3 R{1.0};      // proper rotation (glm is column-major: R[col][row])
  glm::dvec3 t{0, 0, 0};  // mm

  glm::dvec3 apply(const glm::dvec3& x) const { return R * x + t; }
  glm::dvec3 rotate(const glm::dvec3& v) const { return R * v; }
  RigidTransform inverse() const {
    const glm::dmat3 Rt = glm::transpose(R);
    return {Rt, -(Rt * t)};
  }
};

struct RegistrationFit {
  RigidTransform transform;         // rig → volume
  double rms_mm = 0;                // RMS fiducial registration error after the fit
  double max_mm = 0;                // worst fiducial
  std::vector<double> residual_mm;  // |R·rig_i + t − vol_i| per pair
};

// Least-squares rigid fit of `to ≈ R·from + t`. Needs ≥ 3 pairs, equal counts, finite
// values, and points not (nearly) collinear in either set (the rotation about their
// line is then undetermined): otherwise InputError(file, field, ...).
RegistrationFit fit_rigid(const std::vector<glm::dvec3>& from_rig_mm,
                          const std::vector<glm::dvec3>& to_vol_mm,
                          const std::string& file_for_messages = {},
                          const std::string& field = "registration.fiducials");

// InputError unless R is orthonormal (‖RᵀR − I‖ ≤ 1e-6) with det +1.
void check_rotation(const glm::dmat3& R, const std::string& file, const std::string& field);

}  // namespace burrbench::model
