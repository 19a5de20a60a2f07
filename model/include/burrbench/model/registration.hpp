#pragma once
// Rigid transform rig → volume (x_vol = R·x_rig + t) and its fit to fiducial pairs.
// The fit is Horn's closed-form quaternion method (least squares, always a proper
// rotation, never a reflection); GLM has no eigen/SVD routine, so a small Jacobi
// eigen-solver lives in registration.cpp.
#include <array>

#include <glm/glm.hpp>
#include <string>
#include <vector>

namespace burrbench::model {

// A fiducial fit is refused when its RMS residual exceeds this many fiducial localisation
// errors (the expected RMS is FLE·√(1 − 2/N) < FLE; docs/replay.md "Registration").
inline constexpr double kFiducialLimitFactor = 3.0;
// FLE assumed when the manifest gives no `fiducial_error_mm` (about a CT voxel).
inline constexpr double kDefaultFiducialErrorMm = 0.1;

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

// A small correction of a registration, about a centre (the fiducials' centroid, volume
// frame): p' = c + R(ω)·(p − c) + τ, R(ω) the rotation by the vector ω (rad, Rodrigues).
// The calibration fits it as a nuisance per sample mounting (docs/calibration.md).
// The correction is a rigid motion of the whole rig as the volume sees it: with it, every
// rig quantity mapped into the volume frame moves too — burr centres (apply), the burr's
// spin axis and the directions the sensor's force and moment are read in (rotate,
// unrotate), the sensor's origin (apply).
struct PoseCorrection {
  glm::dvec3 rotation_rad{0}, translation_mm{0}, centre_vol_mm{0};
  glm::dvec3 apply(const glm::dvec3& p) const;
  glm::dvec3 rotate(const glm::dvec3& v) const;    // R(ω)·v (a direction: no centre, no τ)
  glm::dvec3 unrotate(const glm::dvec3& v) const;  // R(ω)ᵀ·v
  // ∂p'/∂θ_k at p for θ = (ωx, ωy, ωz, τx, τy, τz): e_k × (p' − c) for the rotations (exact
  // at ω = 0, first order in ω), e_k for the translations.
  glm::dvec3 derivative(int k, const glm::dvec3& p) const;
};

// Covariance information of a rigid fit to N fiducials with isotropic localisation error
// FLE (RMS, 3-D), about their centroid: translation N/σ²·I, rotation (Σᵢ |xᵢ|²I − xᵢxᵢᵀ)/σ²,
// σ² = FLE²/3 per axis; no cross terms about the centroid. Row-major 6×6 (ω, τ).
std::array<double, 36> fiducial_fit_information(const std::vector<glm::dvec3>& fiducials_vol_mm,
                                                double fle_mm);

struct RegistrationFit {
  RigidTransform transform;         // rig → volume
  double rms_mm = 0;                // RMS fiducial registration error after the fit
  double max_mm = 0;                // worst fiducial
  std::vector<double> residual_mm;  // |R·rig_i + t − vol_i| per pair
};

// Wahba's problem, solved with Horn's (1987) quaternion: the proper rotation R maximising
// Σ w_i b_iᵀ R a_i (i.e. R a_i ≈ b_i in least squares), from the weighted cross-covariance
// S[r][c] = Σ w_i a_i[r] b_i[c].
glm::dmat3 optimal_rotation(const std::array<std::array<double, 3>, 3>& S);

// Least-squares rigid fit of `to ≈ R·from + t`. Needs ≥ 3 pairs, equal counts, finite
// values, and points not (nearly) collinear in either set (the rotation about their
// line is then undetermined): otherwise InputError(file, field, ...).
RegistrationFit fit_rigid(const std::vector<glm::dvec3>& from_rig_mm,
                          const std::vector<glm::dvec3>& to_vol_mm,
                          const std::string& file_for_messages = {},
                          const std::string& field = "registration.fiducials");

// Fitzpatrick, West & Maurer (IEEE TMI 17:694, 1998): the expected target registration
// error at `target` of a point-based rigid registration from these fiducials (same frame),
// for an isotropic fiducial localisation error FLE (RMS, mm):
//   TRE²(r) ≈ FLE²/N · (1 + ⅓ Σ_k d_k²/f_k²),
// d_k the target's distance from the k-th principal axis of the fiducial configuration,
// f_k the fiducials' RMS distance from it. Returns the RMS TRE (mm).
double predicted_tre_mm(const std::vector<glm::dvec3>& fiducials_mm, double fle_mm,
                        const glm::dvec3& target_mm);

// A fiducial fit's RMS above `limit_mm` is absurd (mis-paired or mistyped fiducials):
// InputError naming the worst fiducial, and the two rows that look swapped when exchanging
// them brings the RMS under the limit.
void check_fiducial_fit(const RegistrationFit& fit, const std::vector<glm::dvec3>& from_rig_mm,
                        const std::vector<glm::dvec3>& to_vol_mm, double limit_mm,
                        const std::string& file, const std::string& field);

// InputError unless R is orthonormal (‖RᵀR − I‖ ≤ 1e-6) with det +1.
void check_rotation(const glm::dmat3& R, const std::string& file, const std::string& field);

}  // namespace burrbench::model
