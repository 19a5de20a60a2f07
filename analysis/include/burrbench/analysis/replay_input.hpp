#pragma once
// Fills an analysis input by replaying an experiment with FIXED parameters (no fitting):
// what `validate` does, and what `report` does for a calibrate output directory that has
// only fit.json (the fit's nuisances — bias, lag, depth offset — are applied then).
#include <filesystem>
#include <string>

#include "burrbench/analysis/analysis_input.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"

namespace burrbench::analysis {

struct ReplayInputOptions {
  // For recordings without a fitted bias (validate; held-out recordings of a fit): subtract from the measured force its mean over the samples where the
  // model predicts no contact (a tare; the sensor bias is not a model constant). Needs
  // ≥ 10 such samples, else no tare.
  bool tare = true;
  std::string context_of_use;
  Progress* progress = nullptr;
  std::string params_file = "parameter set";  // named in errors about the parameter set
  // The fit whose covariance gives the prediction band (validate --fit); without it, the
  // `fit` argument's (a calibrate directory), else no band.
  const data_schema::FitResult* band_fit = nullptr;
};

AnalysisInput replay_experiment(const std::filesystem::path& manifest,
                                const data_schema::ParameterSet& params,
                                const data_schema::FitResult* fit, const ReplayInputOptions& opt);

}  // namespace burrbench::analysis
