#pragma once
// Contact evaluation (MODEL.md "Forces") and erosion (MODEL.md "Erosion") for a spherical
// burr in a Volume. Forces are on the burr, in the volume frame, in N.
#include <array>
#include <cstdint>
#include <memory>

#include <glm/glm.hpp>

#include "burrbench/model/model_params.hpp"
#include "burrbench/model/quadrature.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::model {

// |M₁| < kBuriedMoment·M·R → the contact normal is ill-defined ("buried"). In flat bone
// this happens for immersion b ≳ 1.7 R (see docs/model.md).
inline constexpr double kBuriedMoment = 0.05;

namespace detail { struct Scratch; }

// The kernel's working space: the lens table of the current (R, l) and the voxels its first
// pass collects for the second. Held by whoever runs the kernel (a replay, a loop of
// steps), not by the Volume, so a Volume is plain data that copies as such and many threads
// may evaluate one volume, each with its own scratch. Reusing one saves rebuilding the table
// and regrowing the voxel list; the results do not depend on it.
class KernelScratch {
 public:
  KernelScratch();
  ~KernelScratch();
  KernelScratch(KernelScratch&&) noexcept;
  KernelScratch& operator=(KernelScratch&&) noexcept;
  detail::Scratch& get() { return *s_; }

 private:
  std::unique_ptr<detail::Scratch> s_;
};

struct ContactResult {
  glm::dvec3 force_N{0};  // total force on the burr, volume frame
  glm::dvec3 elastic_N{0}, friction_N{0};
  double depth_b_mm = 0;
  glm::dvec3 normal{0};         // n̂ = −M₁/|M₁| (0 when there is no bone or M₁ = 0)
  double bone_volume_mm3 = 0;   // M
  double contact_radius_mm = 0; // a = √(2Rb − b²)
  double power_W_mJ_per_s = 0;  // Σ W_i (friction power), N·mm/s
  // Friction couple on the burr about its centre p, volume frame, N·mm (MODEL.md "Moments"):
  // T = Σ (rᵢ/dᵢ) vᵢ × dF_μ,i. Its spin component is the braking torque: T·ω̂ = −Σ W_i/|ω|.
  // The elastic force acts through p and adds no moment about it.
  glm::dvec3 moment_Nmm{0};
  std::uint8_t class_mask = 0;  // bit k set: class k in contact
  bool buried = false;          // normal ill-defined (|M₁| < kBuriedMoment·M·R)
  // Exact partials at fixed geometry, per class label k:
  //   F_e = Σ_k C1_k · dF_dC1[k];  F_μ = Σ_k μ_k · dFmu_dmu[k]  (F_μ also scales with
  //   |F_e|, i.e. linearly with the C1's: dF_μ/dC1_k = F_μ · |dF_dC1[k]| / |F_e|).
  std::array<glm::dvec3, kMaxClasses> dF_dC1{};
  std::array<glm::dvec3, kMaxClasses> dFmu_dmu{};
  // T = Σ_k μ_k · dTmu_dmu[k] (T, like F_μ, also scales with |F_e|).
  std::array<glm::dvec3, kMaxClasses> dTmu_dmu{};
  // Friction before the cross product with the spin axis: dFmu_dmu[k] = friction_lever[k] × ω̂
  // (Σ over class k's contact voxels of χΔσP·v/|v|). How the friction turns with the spin
  // axis: the registration's pose correction turns the axis (calibration's Jacobian).
  std::array<glm::dvec3, kMaxClasses> friction_lever{};
};

ContactResult evaluate(const Volume&, KernelScratch&, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                       double radius_mm, const ModelParams&, Quadrature = Quadrature::kLens);
// One evaluation on a scratch of its own (tests, the Python module, one-off looks).
ContactResult evaluate(const Volume&, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                       double radius_mm, const ModelParams&, Quadrature = Quadrature::kLens);

// evaluate, then erode over dt_s with the friction power at this position (forward
// Euler). Removed volume (mm³) and friction energy (mJ, = Σ W_i·dt, before clamping χ at 0)
// are ADDED per class label to the arrays.
ContactResult step(Volume&, KernelScratch&, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                   double radius_mm, const ModelParams&, double dt_s,
                   std::array<double, kMaxClasses>& removed_mm3,
                   std::array<double, kMaxClasses>* energy_mJ = nullptr,
                   Quadrature = Quadrature::kLens);
// One step on a scratch of its own.
ContactResult step(Volume&, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                   double radius_mm, const ModelParams&, double dt_s,
                   std::array<double, kMaxClasses>& removed_mm3,
                   std::array<double, kMaxClasses>* energy_mJ = nullptr,
                   Quadrature = Quadrature::kLens);

}  // namespace burrbench::model
