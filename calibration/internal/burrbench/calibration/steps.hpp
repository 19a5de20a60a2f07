#pragma once
// Central-difference steps from a measured cost sweep. For a ladder h₀ > h₁ > … the
// curvature c(h) = (C(x+h) + C(x−h) − 2C(x))/h² is measured; the chosen step is the
// smallest one whose curvature is positive and within 30 % of the next coarser step's:
// below it the differences are dominated by float χ resolution and voxel-scale texture,
// above it by the parameter's own non-linearity.
#include <string>
#include <vector>

#include "burrbench/calibration/objective.hpp"

namespace burrbench::calibration {

struct StepSweep {
  std::string name;
  std::vector<double> h, curvature;  // as measured
  double chosen = 0;
  int replays = 0;
};

// `only`: recording whose cost is swept (-1: all recordings).
StepSweep sweep_step(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                     std::size_t entry, const std::vector<double>& ladder, int only);

}  // namespace burrbench::calibration
