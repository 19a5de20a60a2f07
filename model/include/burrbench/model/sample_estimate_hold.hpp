#pragma once
// Sample–estimate–hold output stage (Ellis, Sarkar & Jenkins 1997; MODEL.md "Haptic
// output stage"). A zero-order hold sends the last model sample F_k over [t_k, t_k+T]:
// for a force that changes, its force–time integral lags by about T·Ḟ/2 each interval.
// SEH holds instead the estimated mean of the force over the coming interval, from the
// first-order (linear) extrapolation through the last two samples:
//   H_k = F_k + (F_k − F_k−1) · T_hold / (2·(t_k − t_k−1)),
// which is exact for a ramp. The first sample is held as is (no slope yet).
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::model {

class SampleEstimateHold {
 public:
  // Feed the model sample F at time t (strictly increasing); returns the value to hold
  // over [t, t + hold_s]. hold_s ≤ 0 → the last sample interval.
  glm::dvec3 push(double t_s, glm::dvec3 force_N, double hold_s = 0);
  void reset() { have_ = false; }

  // Whole series; the hold interval of sample k is t_k+1 − t_k (the last: the previous).
  static std::vector<glm::dvec3> filter(const std::vector<double>& t_s,
                                        const std::vector<glm::dvec3>& force_N);

 private:
  bool have_ = false;
  double t_prev_ = 0;
  glm::dvec3 f_prev_{0};
};

}  // namespace burrbench::model
