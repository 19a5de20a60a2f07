#pragma once
// The prediction a report is made from: model::predict_experiment (the one path from model
// to prediction: the fit's nuisances — lag, biases, depth offset, pose, spindle terms — or
// the tare, the band, the removed bone) plus the run's context that the report states
// beside the series (data_schema::Prediction::context: the experiment, the constants, the
// settings, every file, the sessions' logs and the data-quality findings). Computed once,
// here, at prediction time, and stored in prediction.h5: `burrbench report DIR` needs
// neither the sample nor the recordings. It lives in apps/ because the findings join
// model/, calibration/ (zero drift, sensor frame, friction direction) and analysis/ (lag).
#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/progress.hpp"

namespace burrbench::apps {

struct ReportPredictionOptions {
  std::string made_by = "validate";  // the command: "calibrate" | "validate"
  // The fit whose nuisances the replay applies and whose covariance gives the band
  // (calibrate at its optimum; validate --fit). Null: the manifest's lag, no band.
  const data_schema::FitResult* fit = nullptr;
  // For a channel without a fitted offset: add the measured mean over the samples where
  // the model predicts no contact (a tare; the sensor bias is not a model constant).
  bool tare = true;
  std::string context_of_use;
  Progress* progress = nullptr;
  std::string params_file = "parameter set";  // named in errors about the parameter set
  int threads = 2;  // recordings replayed at once (the result does not depend on it)
  // Print the findings on stderr as warnings (calibrate's summary has already said them).
  bool warn = true;
};

// The prediction with its context and provenance (the experiment's files, hashed as read),
// ready to be written (data_schema::write_prediction) and reported (analysis::write_report).
data_schema::Prediction predict_for_report(const std::filesystem::path& manifest,
                                           const data_schema::ParameterSet& params,
                                           const ReportPredictionOptions& opt);

}  // namespace burrbench::apps
