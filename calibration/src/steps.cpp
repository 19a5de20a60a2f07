#include "burrbench/calibration/steps.hpp"

#include <cmath>

namespace burrbench::calibration {

StepSweep sweep_step(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                     std::size_t entry, const std::vector<double>& ladder, int only) {
  StepSweep s;
  s.name = obj.layout().name(entry);
  const double c0 = obj.evaluate(x, w, only).cost;
  for (double h : ladder) {
    std::vector<double> xp = x, xm = x;
    xp[entry] += h;
    xm[entry] -= h;
    const double cp = obj.evaluate(xp, w, only).cost, cm = obj.evaluate(xm, w, only).cost;
    s.h.push_back(h);
    s.curvature.push_back((cp + cm - 2 * c0) / (h * h));
  }
  s.replays = int(1 + 2 * ladder.size());
  s.chosen = ladder.front();
  for (std::size_t i = 1; i < ladder.size(); ++i) {
    const double c = s.curvature[i], prev = s.curvature[i - 1];
    if (!(c > 0) || !(prev > 0) || std::abs(c - prev) > 0.3 * prev) break;
    s.chosen = ladder[i];
  }
  return s;
}

}  // namespace burrbench::calibration
