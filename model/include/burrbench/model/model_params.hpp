#pragma once
// Model constants per class label, in the flat form the kernel indexes by voxel label.
// Units (MODEL.md): α and C1 in N/mm² (α = mJ/mm³ of full-density bone), μ dimensionless.
#include <array>
#include <cmath>
#include <cstdint>

#include <map>
#include <string>

#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::model {

// Labels 0..kMaxClasses − 1 (0 = empty); a larger label → InputError. The count is
// data_schema's (sample_volume.hpp), so the prediction file's per-class records match.
inline constexpr int kMaxClasses = data_schema::kModelClassLabels;

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

// A parameter set must give constants for every class label present in each sample (a
// missing class would make that bone inert: α = ∞, C1 = μ = 0) and, where both name a
// class, the same name for the same label. Else InputError(params_file, "classes", …).
void check_covers(const data_schema::ParameterSet& p,
                  const std::map<std::string, data_schema::SampleVolume>& samples,
                  const std::string& params_file);

}  // namespace burrbench::model
