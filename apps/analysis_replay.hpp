#pragma once
// Fills an analysis input (analysis/'s format) from the prediction of an experiment with
// FIXED parameters (no fitting): what `validate` does, what `calibrate` writes at its
// optimum and what `report` does for an older calibrate directory that has only fit.json.
// The prediction itself — the fit's nuisances (bias, lag, depth offset, pose) or the tare,
// the band, the removed bone — comes from model::predict_experiment, the one path from
// model to prediction; this only repackages it (metadata, one series per role). It lives
// in apps/ because it joins model/ and analysis/: analysis/ only reads files and links
// data_schema alone.
#include <filesystem>
#include <string>

#include "burrbench/analysis/analysis_input.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::apps {
using analysis::AnalysisInput;

struct ReplayInputOptions {
  // For a channel without a fitted offset (validate; held-out recordings of a fit): add to
  // the prediction the measured mean over the samples where the model predicts no contact
  // (a tare; the sensor bias is not a model constant). Needs ≥ 10 such samples.
  bool tare = true;
  std::string context_of_use;
  Progress* progress = nullptr;
  std::string params_file = "parameter set";  // named in errors about the parameter set
  // The fit whose covariance gives the prediction band (validate --fit); without it, the
  // `fit` argument's (a calibrate directory), else no band.
  const data_schema::FitResult* band_fit = nullptr;
  // Filled with the prediction the analysis input came from (the verbs write it as
  // prediction.h5), when given.
  model::ExperimentPrediction* prediction = nullptr;
  int threads = 2;  // recordings replayed at once (the result does not depend on it)
  // Print on stderr the warnings about the data (two recordings that removed the same bone,
  // the alignment's: model::alignment_warnings); the report's limitations name them
  // either way, and calibrate's summary has already said them.
  bool warn = true;
};

AnalysisInput replay_experiment(const std::filesystem::path& manifest,
                                const data_schema::ParameterSet& params,
                                const data_schema::FitResult* fit, const ReplayInputOptions& opt);

// An older calibrate directory (fit.json, usually params.toml, no analysis.json): its
// experiment (whose SHA-256 must still match) replayed with params.toml, or the fit's
// estimates, and the fitted nuisances; the directory's files count among the inputs.
AnalysisInput replay_calibrate_directory(const std::filesystem::path& dir, const std::string& context_of_use,
                                        model::ExperimentPrediction* prediction = nullptr, int threads = 2);

}  // namespace burrbench::apps
