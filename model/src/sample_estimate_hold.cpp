#include "burrbench/model/sample_estimate_hold.hpp"

#include <string>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::model {

glm::dvec3 SampleEstimateHold::push(double t_s, glm::dvec3 force_N, double hold_s) {
  glm::dvec3 held = force_N;
  if (have_) {
    const double T = t_s - t_prev_;
    if (!(T > 0))
      throw InputError("sample-estimate-hold", "t_s", "strictly increasing sample times");
    const double hold = hold_s > 0 ? hold_s : T;
    // Mean over [t, t+hold] of the line through the last two samples.
    held = force_N + (force_N - f_prev_) * (0.5 * hold / T);
  }
  have_ = true;
  t_prev_ = t_s;
  f_prev_ = force_N;
  return held;
}

std::vector<glm::dvec3> SampleEstimateHold::filter(const std::vector<double>& t_s,
                                                   const std::vector<glm::dvec3>& force_N) {
  if (t_s.size() != force_N.size())
    throw InputError("sample-estimate-hold", "force_N", "one force per time");
  SampleEstimateHold seh;
  std::vector<glm::dvec3> out(t_s.size());
  for (std::size_t k = 0; k < t_s.size(); ++k) {
    const double hold = k + 1 < t_s.size() ? t_s[k + 1] - t_s[k] : 0;
    out[k] = seh.push(t_s[k], force_N[k], hold);
  }
  return out;
}

}  // namespace burrbench::model
