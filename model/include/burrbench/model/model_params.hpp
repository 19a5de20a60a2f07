#pragma once
// Model constants per class label, in the flat form the kernel indexes by voxel label.
// Units (MODEL.md): α and C1 in N/mm² (α = mJ/mm³ of full-density bone), μ dimensionless.
#include <array>
#include <cmath>
#include <cstdint>

#include "burrbench/data_schema/parameter_set.hpp"

namespace burrbench::model {

inline constexpr int kMaxClasses = 8;  // labels 0..7 (0 = empty); a larger label → InputError

struct ClassConstants {
  double alpha_N_per_mm2 = INFINITY;  // ∞ (or any non-finite / ≤ 0 is rejected): no erosion
  double c1_N_per_mm2 = 0;
  double mu = 0;
};

struct ModelParams {
  std::array<ClassConstants, kMaxClasses> by_label{};  // index = class label; [0] unused
  // Labels ≥ kMaxClasses or 0, negative/NaN constants → InputError (file "parameter set").
  static ModelParams from(const data_schema::ParameterSet& p);
};

}  // namespace burrbench::model
