#pragma once
// Forward sensitivities of a replay (docs/model.md "Sensitivities"): the exact derivative of
// the replayed force in several directions θ_j at once — ln α_k, ln C1_k, ln μ_k of a class,
// or a shift of the burr's path (lag, depth offset, registration pose). The replay carries
// ∂χ/∂θ_j for every voxel that erosion has touched (sparse; zero where χ clamps at 0) and
// differentiates the contact kernel in χ, in the burr centre and in the constants.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/model/model_params.hpp"

namespace burrbench::model {

struct Direction {  // one parameter θ_j the replay is differentiated in
  enum class Kind { kLogAlpha, kLogC1, kLogMu, kPath };
  Kind kind = Kind::kLogC1;
  std::uint8_t label = 0;  // class label for kLogAlpha / kLogC1 / kLogMu
  // kPath: ∂p/∂θ of the burr centre (volume frame, mm per unit θ) at every trajectory
  // sample, then at every via (Trajectory::path_centres_vol_mm's order); between points it
  // is interpolated linearly like the centre itself.
  std::vector<glm::dvec3> dcentre_vol_mm;
};

struct Sensitivities {  // filled by replay when directions are given
  std::vector<std::vector<glm::dvec3>> dforce_N;  // [direction][sample]: ∂F/∂θ_j (burr force, volume frame)
  // [direction][sample]: ∂T/∂θ_j of the friction couple (N·mm, volume frame); filled only
  // when ReplayOptions::moment_sensitivities is set (it costs a few more sums per voxel).
  std::vector<std::vector<glm::dvec3>> dmoment_Nmm;
  std::vector<std::array<double, kMaxClasses>> dremoved_mm3;  // [direction]: ∂(removed volume per class)/∂θ_j
  std::size_t tangent_voxels = 0;  // voxels that carried a tangent (bench, docs)
  // Directions the tangent pass carried; the others follow exactly from them (docs/model.md
  // "Directions that follow from others"). Bench, docs.
  std::size_t carried_directions = 0;
};

inline constexpr std::size_t kMaxDirections = 64;

// Sensitivities that grew without bound: the explicit erosion step's tangent is unstable
// where erosion is fast against the step (seen at R/l = 5: columns of 1e97 N). True for a
// non-finite value, or a column above kMaxSensitivityRatio × `max_force_N` (taken as at
// least 1 mN) per unit of its parameter; legitimate columns stay within a few times the
// force (docs/calibration.md "When the sensitivities diverge").
inline constexpr double kMaxSensitivityRatio = 1e6;
bool sensitivities_diverged(const std::vector<std::vector<glm::dvec3>>& columns, double max_force_N);

}  // namespace burrbench::model
