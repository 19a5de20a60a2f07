#include "burrbench/model/model_params.hpp"

#include <set>
#include <string>

#include <fmt/format.h>

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

void check_covers(const data_schema::ParameterSet& p,
                  const std::map<std::string, data_schema::SampleVolume>& samples,
                  const std::string& params_file) {
  for (const auto& [id, s] : samples) {
    std::set<std::uint8_t> present(s.labels.begin(), s.labels.end());
    present.erase(0);
    for (const std::uint8_t label : present) {
      const auto sn = s.classes.find(label);
      const std::string sname = sn == s.classes.end() ? "" : sn->second;
      const auto c = p.classes.find(label);
      if (c == p.classes.end())
        throw InputError(params_file, "classes",
                         fmt::format("a class with id = {}{}, present in sample {}", int(label),
                                     sname.empty() ? "" : " (" + sname + ")", id),
                         "none (that bone would be inert)");
      if (!sname.empty() && !c->second.name.empty() && c->second.name != sname) {
        // Say which id the sample gives this name, if any: the usual mistake is a swap.
        std::string other;
        for (const auto& [l, n] : s.classes)
          if (n == c->second.name) other = fmt::format("; sample {} gives {} id = {}", id, n, int(l));
        throw InputError(params_file, "classes." + c->second.name + ".id",
                         fmt::format("the class sample {} names {} to have id = {}{}", id, sname, int(label), other),
                         fmt::format("{} with id = {}", c->second.name, int(label)));
      }
    }
  }
}

}  // namespace burrbench::model
