#include <algorithm>
#include <cmath>

#include "burrbench/model/sensitivity.hpp"

namespace burrbench::model {

bool sensitivities_diverged(const std::vector<std::vector<glm::dvec3>>& columns, double max_force_N) {
  const double bound = kMaxSensitivityRatio * std::max(1e-3, max_force_N);
  for (const auto& col : columns)
    for (const auto& v : col)
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z) || glm::length(v) > bound) return true;
  return false;
}

}  // namespace burrbench::model
