#pragma once
// The calibration driver's state and its stages (internal). calibrate() in calibrate.cpp
// runs them in order; each stage reads what the earlier ones left in the Run.
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/calibration/calibrate.hpp"
#include "burrbench/calibration/multistart.hpp"
#include "burrbench/calibration/objective.hpp"
#include "burrbench/calibration/profile.hpp"
#include "burrbench/calibration/replay_model.hpp"
#include "burrbench/calibration/uncertainty.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::calibration::detail {

namespace ds = data_schema;

// The fit's summary over the three force axes together (docs/report.md "Metrics": the
// `_xyz` names): RMSE over every axis of every sample and R² = 1 − ΣSSE/ΣSST with each
// axis's SST about its own mean. The report's per-axis rows reproduce both.
struct Metrics {
  double rmse_xyz_N = NAN, r2_xyz = NAN;
  std::uint64_t samples = 0;
  nlohmann::json json() const;
};

// The same recordings replayed on the samples with their voxels merged by 2: the
// coarse-to-fine search and the discretization check.
struct CoarseLevel {
  std::map<std::string, ds::SampleVolume> samples;
  std::unique_ptr<ReplayPool> pool;
  std::vector<std::unique_ptr<ReplayRecordingModel>> owned;
  std::unique_ptr<Objective> obj;
  double voxel_mm = 0;       // the coarse voxel (the largest over the samples)
  double fine_voxel_mm = 0;
};

struct Run {
  Run(const CalibrateOptions& o, const std::filesystem::path& manifest)
      : opt(o), manifest_path(manifest), mfile(manifest.string()), exp(model::load_experiment(manifest)) {}
  // When the fit started (UTC, ISO 8601): fit.json settings.started_utc, which the report
  // shows beside the time the acceptance criteria were fixed.
  std::string started_utc = make_provenance({}).created_utc;
  const CalibrateOptions& opt;
  std::filesystem::path manifest_path;
  std::string mfile;
  model::Experiment exp;

  // select
  std::vector<const model::AlignedRecording*> recs;  // recordings with calibrating samples
  std::map<std::uint8_t, std::string> present;        // class label → name
  std::unique_ptr<Layout> layout;
  std::map<std::string, const ds::SampleVolume*> used_samples;  // in exp.samples
  std::unique_ptr<ReplayPool> pool;
  std::vector<std::unique_ptr<ReplayRecordingModel>> owned;
  std::vector<const RecordingModel*> models;
  SampleWeights w_all;       // calibrating samples
  SampleWeights w_validate;  // validating samples of the same recordings (may be all 0)
  ObjectiveSettings settings;
  std::string sigma_source = "manifest (sensor.sigma_N)";
  std::string sigma_torque_source, sigma_spindle_source;  // when those channels are fitted
  std::unique_ptr<Objective> obj;
  std::uint64_t replays_before = 0;
  nlohmann::json stages = nlohmann::json::array();  // {"stage", "wall_s", "replays"} in order

  // search
  DiffSteps steps;
  nlohmann::json sweeps = nlohmann::json::array();
  int starts = 1;
  MultistartOutcome search;
  double search_function_tolerance = 0;  // the starts' local solves (fit.json settings.global_search)
  SolveOutcome fit;
  std::vector<double> x;
  int restarts = 0;  // refits from a profile point cheaper than the optimum

  // assess
  Evaluation ev;
  double threshold = 0;              // profile threshold, cost units: chi2_threshold + texture.allowance
  double chi2_threshold = 0;         // χ²₁(0.95)/2 × residual_scale
  TextureProbe texture;              // probed before the profiles (empty without them)
  double inflation = 1;              // noise-model factor (ar1_inflation, or 1)
  double residual_scale = 1;         // residual variance × inflation: the profile threshold's unit
  std::vector<Profile> profiles;     // free physics parameters that were profiled
  UncertaintyReport unc;
  std::vector<std::string> verdict;  // per x entry (physics only)
  std::map<std::size_t, std::string> imprecise_reason;  // x entry → why "imprecise"
  std::vector<std::string> warnings;
  SearchTally tally;  // the search's ends against the optimum and its intervals
  // The cost the search's ends are measured against: the optimum's, or, when the search held
  // the registration's pose (stage_search.cpp), its own best end's — the refinement frees
  // the pose and lowers the cost below every end, which no start could have reached.
  double search_reference_cost = 0;
  // Why the optimum is not confirmed (optimum_doubts): its constants are "unconfirmed".
  std::vector<std::string> doubts;

  // coarse level (coarse-to-fine, discretization check); built on first use
  std::unique_ptr<CoarseLevel> coarse;
  double coarse_voxel_mm = NAN;      // voxel of the discretization check's refit (NaN: not done)
  std::string coarse_termination;    // how that refit ended
  std::uint64_t coarse_iterations = 0;
  double coarse_cost = NAN;          // coarse-to-fine: the coarse optimum's cost
  double coarse_cost_rise = NAN;     // discretization check: refit's cost at 2l − the optimum's at l
  bool coarse_grid_explains = false;  // that rise is significant against the misfit at l

  // depth check: fit.json settings.depth_check (empty: not run)
  nlohmann::json depth = nlohmann::json::object();

  // resampling
  ds::FitResult out;
  Metrics calibration_metrics, validation_metrics;

  void say(const std::string& s) const {
    if (opt.progress) opt.progress->update(-1, s);
  }
  // The next stage: its line is always shown, and the updates after it name it.
  void stage(const std::string& name, const std::string& detail) const {
    if (opt.cancel) opt.cancel->check();
    if (opt.progress) opt.progress->stage(name, detail);
  }
};

Metrics metrics(const Objective& obj, const Evaluation& ev, const std::vector<double>& x,
                const SampleWeights& w);

// The layout's physics parameter a fit.json entry stands for (nullptr: none).
const PhysicsParam* physics_of(const Layout& L, const ds::FitParameter& fp);
// The 95 % interval a check after the fit compares with, side by side: the profile's where
// that side is closed, else the covariance's (NaN: none).
std::pair<double, double> check_interval(const ds::FitParameter& fp);

// A percentage for a message: "0.047", "0.50", "13.6" ("+" first with `sign`). One fixed
// decimal would print a ±0.05 % interval as ±0.0 %.
std::string percent(double pct, bool sign = false);

// rms(residual/σ) above which an optimum does not confirm its constants (docs/calibration.md
// "Verdicts that follow the evidence"): the residual variance is more than twice the noise's.
inline constexpr double kUnconfirmedRms = 1.5;
// A lone find (reached by one start) is confirmed by the noise floor when it fits to within
// this rms(residual/σ): no other optimum can then fit much better than the noise allows.
inline constexpr double kLoneFindRms = 1.2;
// The cost expected at the true constants when the model and the noise levels are right:
// half the used residuals less the free entries (a χ² with that many degrees of freedom).
double noise_floor_cost(const Run& run);
// Evidence against the optimum, each a phrase: reached by at most one start (of several
// solved), a profile point still cheaper after the restarts (`cheaper_left`), a misfit far
// above the noise. Empty: nothing speaks against it.
std::vector<std::string> optimum_doubts(const Run& run, const SearchTally& t, const std::string& cheaper_left);

// A pose correction whose Mahalanobis² against its fiducial prior exceeds this (χ²₆(0.999))
// is a finding: the data disagree with the fiducials (docs/calibration.md "Registration").
inline constexpr double kPosePriorLimit = 22.458;
// fit.json settings.registration (every recording's registration, the pose correction
// applied, its TRE and prior check); appends its summary lines to `text` and its findings
// to run.warnings.
nlohmann::json registration_report(Run& run, std::string& text);

void select_recordings(Run& run);   // recordings, classes, layout, pool, weights, σ
CoarseLevel& coarse_level(Run& run);  // built on first use (after choose_steps)
// A replay-backed model of one recording with the run's derivatives, steps and channels.
std::unique_ptr<ReplayRecordingModel> make_model(const Run& run, const model::AlignedRecording& r, ReplayPool& pool);
void coarse_search(Run& run);       // coarse-to-fine: global search and refine at 2l
void choose_steps(Run& run);        // difference steps (finite differences only)
void global_search(Run& run);       // multistart from a Latin hypercube
void refine(Run& run);              // the best start to convergence
void assess(Run& run);              // profiles, verdicts, covariance (restarts refine if cheaper)
void discretization_check(Run& run);  // refit at 2l: discretization error of each estimate
void depth_check(Run& run);         // refit with the depth offsets nothing corrects free
void bootstrap(Run& run);
void cross_validate(Run& run);
void score_validation(Run& run);    // validate-role segments with their recording's nuisances
CalibrationOutput results(Run& run);
// After the results: replays every recording at the optimum and names, in fit.json's
// warnings, the summary and CalibrationOutput::overlaps, two of one sample that removed the
// same bone (model::predict_experiment, as the analysis replays them).
void name_overlaps(const Run& run, CalibrationOutput& res);

}  // namespace burrbench::calibration::detail
