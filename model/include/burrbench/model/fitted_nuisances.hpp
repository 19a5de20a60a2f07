#pragma once
// What a fit (fit.json) says about each recording and about the constants' uncertainty,
// in the form the prediction applies: the per-recording nuisances (bias, lag, depth
// offset, moment bias, spindle idle/viscous, registration pose correction) and the
// covariance of the fitted constants in ln θ with the sensitivity directions that carry
// it to a prediction band.
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/model/model_params.hpp"
#include "burrbench/model/registration.hpp"
#include "burrbench/model/sensitivity.hpp"

namespace burrbench::model {

// One recording's fitted nuisances; each absent when the fit did not estimate it (a
// held-out recording has none).
struct FittedNuisances {
  std::optional<double> lag_ms, depth_offset_mm;
  std::optional<glm::dvec3> force_bias_N, torque_bias_Nmm;
  std::optional<double> spindle_idle_Nmm;
  double spindle_viscous_Nmm_per_krpm = 0;  // per 1000 rpm of deviation from the mean speed
  double spindle_lag_ms = 0;  // the drive's load logged this much later than the force
  std::optional<PoseCorrection> pose;       // fit.json settings.registration.<id>.pose_correction
};
// InputError (naming fit.json) on a malformed pose correction.
FittedNuisances fitted_nuisances(const data_schema::FitResult& fit, const std::string& recording_id);

// The fitted constants that have a covariance, as sensitivity directions, with their
// covariance in ln θ (fit.json's is in natural units: C_ln = C / (θ_a θ_b)), evaluated at
// the parameter set's values. Empty without a covariance.
struct BandCovariance {
  std::vector<Direction> directions;
  std::vector<double> cov_ln;  // directions.size()², row-major
};
BandCovariance band_covariance(const data_schema::FitResult& fit, const data_schema::ParameterSet& params);

}  // namespace burrbench::model
