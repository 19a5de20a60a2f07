#pragma once
// Result of a calibration (JSON, format "burrbench.fit"). NaN is not representable in
// JSON: a NaN (e.g. the estimate of a non-identifiable parameter) is stored as null and
// read back as NaN; ±∞ (alpha fixed at "no erosion") is stored as the string "inf"/"-inf".
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema {

inline constexpr const char* kFitFormat = "burrbench.fit";
inline constexpr int kFitVersionMajor = 1;
inline constexpr int kFitVersionMinor = 3;  // 1.1: held value, verdict, profile, multistart; 1.2: discretization check;
                                            // 1.3: channel_information

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct FitParameter {
  std::uint8_t class_id = 0;
  std::string class_name;
  std::string name;  // "alpha" | "c1" | "mu"
  std::string unit;  // "N/mm^2" for alpha and c1, "1" for mu
  double estimate = kNaN, std_error = kNaN, ci95_low = kNaN, ci95_high = kNaN;
  double bootstrap_ci95_low = kNaN, bootstrap_ci95_high = kNaN;  // NaN: not computed
  bool fixed = false;
  bool identifiable = true;
  std::string reason;  // why not identifiable ("" when identifiable)
  // 1.1: the value the fit held at its optimum (also when not identifiable; NaN only when
  // unknown, e.g. a 1.0 file), the profile-likelihood verdict, its interval (NaN = open on
  // that side) and the profile's points [{"value", "delta_cost", "x": {...}}] (docs/calibration.md).
  double held = kNaN;
  std::string verdict{};  // identifiable | imprecise (identifiable, but its interval is wider
                        // than [fit.precision] asks; `reason` says by how much) |
                        // practically_non_identifiable | non_identifiable | at_bound |
                        // conditional_on_bound | unconfirmed (its profile closes, but
                        // the optimum is in doubt: reached by one start, a cheaper
                        // profile point, a misfit far above the noise) | fixed
                        // ("" in 1.0 files)
  double profile_ci95_low = kNaN, profile_ci95_high = kNaN;
  nlohmann::json profile = nlohmann::json::array();
  // 1.2: the discretization check (docs/calibration.md): the estimate refitted on the
  // sample with its voxels merged by 2 (NaN: not checked), the estimated discretization
  // error of ln θ at the fit's voxel size (|ln θ_2l − ln θ_l|: first order, Richardson),
  // whether it exceeds half the 95 % interval's half-width in ln θ ("limited by
  // discretization error"), and the 95 % interval widened by it on both sides.
  double coarse_estimate = kNaN;
  double discretization_error_log = kNaN;
  bool limited_by_discretization = false;
  double ci95_with_discretization_low = kNaN, ci95_with_discretization_high = kNaN;
};

// A unit as a message writes it after a value: " N/mm^2", or nothing for the
// dimensionless "1" ("mu = 0.4", not "mu = 0.4 1").
std::string unit_suffix(std::string_view unit);

// One parameter as the calibration left it, one or more lines: the value it holds, the
// intervals that support it (profile first: the verdict comes from it; an open side reads
// "open") and, when it is not a confident value, why. `calibrate`'s summary and `inspect`
// print the same; coarse_voxel_mm names the discretization check's voxel when known.
std::string describe_fit_parameter(const FitParameter& p, double coarse_voxel_mm = kNaN);

struct FitNuisance {
  std::string recording_id;
  std::string name;  // "bias_x" | "bias_y" | "bias_z" | "lag" | "depth_offset"
  std::string unit;  // "N", "ms", "mm"
  double estimate = kNaN, std_error = kNaN, ci95_low = kNaN, ci95_high = kNaN;
  bool fixed = false;
};

// A square matrix with named rows/columns, stored row-major (n×n values).
struct NamedMatrix {
  std::vector<std::string> names;
  std::vector<double> matrix;
  std::size_t size() const { return names.size(); }
  double at(std::size_t r, std::size_t c) const { return matrix[r * names.size() + c]; }
};

struct ResidualsSummary {
  std::uint64_t samples_used = 0, samples_buried = 0, samples_excluded = 0;
  double sigma_N = kNaN;
  double rms_normalised = kNaN;
};

struct SolverSummary {
  std::uint64_t iterations = 0;
  double initial_cost = kNaN, final_cost = kNaN;
  double wall_s = 0;
  std::uint64_t replays = 0;
  std::string termination;  // Ceres termination type / message
  std::uint64_t multistart = 1;
  // Per pipeline stage, in order: {"stage", "wall_s", "replays"} (format 1.1, optional on
  // reading): where the time went.
  nlohmann::json stages = nlohmann::json::array();
};

struct CrossValidationFold {
  std::string held_out;  // recording id (or segment label) left out
  nlohmann::json metrics = nlohmann::json::object();
};

struct FitResult {
  std::vector<FitParameter> parameters;
  std::vector<FitNuisance> nuisance;
  NamedMatrix covariance, correlation;
  ResidualsSummary residuals_summary;
  SolverSummary solver;
  std::vector<CrossValidationFold> cross_validation;
  nlohmann::json metrics = nlohmann::json::object();   // analysis fills it
  nlohmann::json settings = nlohmann::json::object();  // loss, buried policy, ...
  // 1.1: every multistart end point [{"start": {...}, "end": {...}, "cost", "termination",
  // "iterations"}] sorted by cost (the waterfall), and how many reached the best optimum.
  nlohmann::json multistart = nlohmann::json::array();
  // 1.3: with channels besides the force, what they add (calibration::channel_information:
  // channels, method, parameters[{class_id, class_name, name, se_log_all, se_log_force,
  // ci95_factor_all, ci95_factor_force}], correlations[{class_id, class_name, pair, all,
  // force}]); null otherwise.
  nlohmann::json channel_information;
  Provenance provenance;
  std::string experiment_path, experiment_sha256;

  const FitParameter* parameter(std::uint8_t class_id, const std::string& name) const;
};

void validate(const FitResult& f, const std::string& file_for_messages);
// The file's JSON (what write_fit writes, NaN as null); not validated.
nlohmann::json fit_to_json(const FitResult& f);
void write_fit(const std::filesystem::path& path, const FitResult& f);
FitResult read_fit(const std::filesystem::path& path);  // validates

// The values the fit held as a parameter set (what a simulator release consumes): the
// estimate, or the held value flagged in `not_identifiable` when the parameter is not
// identifiable; InputError if a class lacks a finite value of c1 or mu.
ParameterSet parameter_set_from(const FitResult& f, const std::string& file_for_messages);

}  // namespace burrbench::data_schema
