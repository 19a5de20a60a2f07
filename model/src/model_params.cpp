#include "burrbench/model/model_params.hpp"

#include <string>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::model {

ModelParams ModelParams::from(const data_schema::ParameterSet& p) {
  ModelParams out;
  const std::string file = "parameter set";
  for (const auto& [label, c] : p.classes) {
    const std::string field = "classes." + std::to_string(int(label));
    if (label == 0 || label >= kMaxClasses)
      throw InputError(file, field, "class label 1.." + std::to_string(kMaxClasses - 1),
                       std::to_string(int(label)));
    // α = +∞ is the documented "no erosion"; anything else must be a positive number.
    if (!(c.alpha_N_per_mm2 > 0))
      throw InputError(file, field + ".alpha", "alpha > 0 N/mm² (inf = no erosion)",
                       std::to_string(c.alpha_N_per_mm2));
    if (!(c.c1_N_per_mm2 >= 0) || !std::isfinite(c.c1_N_per_mm2))
      throw InputError(file, field + ".c1", "finite c1 >= 0 N/mm²",
                       std::to_string(c.c1_N_per_mm2));
    if (!(c.mu >= 0) || !std::isfinite(c.mu))
      throw InputError(file, field + ".mu", "finite mu >= 0", std::to_string(c.mu));
    out.by_label[label] = {c.alpha_N_per_mm2, c.c1_N_per_mm2, c.mu};
  }
  return out;
}

}  // namespace burrbench::model
