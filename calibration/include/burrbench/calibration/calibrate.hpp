#pragma once
// `burrbench calibrate`: an experiment manifest in, a fit result and a parameter set out.
// docs/calibration.md describes the objective, derivatives, global search, profiles,
// verdicts, uncertainty, bootstrap, cross-validation and their limits.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/calibration/derivatives.hpp"
#include "burrbench/data_schema/cancel.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::calibration {

struct CalibrateOptions {
  int threads = 2;              // replay workers (each holds its own copy of every sample)
  // The contact quadrature of every replay (model/quadrature.hpp; fit.json settings.quadrature).
  model::Quadrature quadrature = model::Quadrature::kLens;
  int max_iterations = 30;      // refinement of the best start
  int starts = 0;               // global search starts; 0: the manifest's fit.multistart
  int solve_starts = 4;         // starts with the lowest pre-fit cost that are solved locally
  int start_iterations = 12;    // local iterations of each solved start
  bool profiles = true;         // profile likelihood of every free physics parameter
  // Widen the intervals (covariance and profile threshold) by the AR(1) factor of the
  // residuals' lag-1 autocorrelation (ar1_inflation); false: residuals assumed white.
  bool noise_inflation = true;
  // Refit on the sample with voxels merged by 2 and report how far each estimate moves
  // (its discretization error; "limited by discretization error" when it exceeds half
  // the 95 % interval).
  bool discretization_check = true;
  // Refit with a depth offset free for each calibrating recording whose depth nothing
  // corrects, and say when the data want one and it moves a constant outside its interval
  // (a given registration off in depth, a burr radius that is not the burr's).
  bool depth_check = true;
  // Global search and first refinement on the sample with voxels merged by 2 (cheaper
  // replays), then refinement, profiles and intervals at the sample's own voxel size.
  bool coarse_to_fine = false;
  int profile_points = 8;       // per side, at most
  Derivatives derivatives = Derivatives::kSensitivities;
  int bootstrap = 0;            // block-bootstrap replicates (0: none)
  double bootstrap_block_s = 1.0;  // bootstrap blocks: used spans cut to at most this long
  bool cross_validate = true;   // leave-one-recording (or segment) out
  Progress* progress = nullptr;
  // Requested: every replay stops within 64 samples and calibrate throws Cancelled
  // (the Python module's interrupt; the CLI ends on a signal instead).
  const CancelToken* cancel = nullptr;
};

// InputError naming the command-line option when a value is out of its range.
void validate(const CalibrateOptions& options);

struct CalibrationOutput {
  data_schema::FitResult fit;
  data_schema::ParameterSet params;  // the values held at the optimum (flags: not_identifiable)
  std::string summary;               // human-readable, several lines
  // Recordings of one sample that removed the same bone at the optimum (also among fit.json's
  // warnings and the summary's): the fit took each as drilled into bone as scanned.
  std::vector<model::RemovedOverlap> overlaps;
};

// InputError on a bad manifest, recordings or samples (missing files, unknown classes,
// no used samples, ...) or bad options. Deterministic: same inputs → same numbers.
CalibrationOutput calibrate(const std::filesystem::path& manifest, const CalibrateOptions& options);

}  // namespace burrbench::calibration
