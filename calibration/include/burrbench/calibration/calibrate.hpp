#pragma once
// `burrbench calibrate`: an experiment manifest in, a fit result and a parameter set out.
// docs/calibration.md describes the objective, derivative scheme, starting values,
// uncertainty, identifiability rules, bootstrap, cross-validation and their limits.
#include <cstdint>
#include <filesystem>
#include <string>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"

namespace burrbench::calibration {

struct CalibrateOptions {
  int threads = 2;              // replay workers (each holds its own copy of every sample)
  int max_iterations = 30;      // main Ceres solve
  int bootstrap = 0;            // block-bootstrap replicates (0: none)
  double bootstrap_block_s = 1.0;  // bootstrap blocks: used spans cut to at most this long
  bool cross_validate = true;   // leave-one-recording (or segment) out
  Progress* progress = nullptr;
};

struct CalibrationOutput {
  data_schema::FitResult fit;
  data_schema::ParameterSet params;  // estimates (identifiable or not: see `notes`)
  std::string summary;               // human-readable, several lines
};

// InputError on a bad manifest, recordings or samples (missing files, unknown classes,
// no used samples, ...). Deterministic: same inputs → same numbers.
CalibrationOutput calibrate(const std::filesystem::path& manifest, const CalibrateOptions& options);

}  // namespace burrbench::calibration
