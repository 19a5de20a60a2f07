#pragma once
// What the report shows, in memory: the inputs it is given (ReportInputs: the prediction
// with its context, the fit, the criteria, the verification study) and the per-role view
// of them its sections read (ReportData, built by report_data()). Forces and moments are
// in the SENSOR frame, as the sensor reports them. Nothing here is a file format: the one
// hand-off from model to report is the prediction file (data_schema/prediction.hpp).
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "burrbench/analysis/criteria.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::analysis {

// One class's share of a recording's cutting energy (MODEL.md energy balance): the work
// of erosion α·V_removed equals the friction work ∫ΣW dt the replay integrated for it.
struct ClassEnergy {
  int class_label = 0;
  std::string class_name;
  double alpha_N_per_mm2 = 0;
  double removed_mm3 = 0;
  double friction_energy_mJ = 0;  // ∫ΣW dt over the class's voxels, N·mm = mJ
};

struct SegmentSpan {
  std::string label;
  double start_s = 0, end_s = 0;  // seconds from the recording's first sample
};

// 1.2: what the session logged about itself (model::AlignedRecording) and what the
// replay found: the report's data-quality table.
struct DataQuality {
  struct Event {
    double t_s = 0;  // from the first force sample
    std::string kind, stream, detail;
  };
  std::size_t dropped_force_samples = 0;  // stale or non-increasing timestamps
  std::size_t buried_samples = 0;         // the burr was buried (excluded or down-weighted)
  std::map<std::string, std::size_t> stale_rows;  // per stream
  std::vector<Event> events;              // gap, reconnect, fault, tare, …
};

struct RecordingSeries {
  std::string id, sample_id;
  std::string role;               // "calibrate" | "validate"; id@validate for the second role
  std::string path, sha256, notes;
  std::string registration;  // how the recording was registered: method, RMS, predicted TRE
  std::vector<SegmentSpan> segments;  // empty = whole recording
  // Series: time from the first sample, measured and predicted force
  // (sensor frame), and whether the sample counted in the fit/metrics (0 = buried,
  // excluded or outside a used segment).
  std::vector<double> t_s;
  std::vector<glm::dvec3> measured_N, predicted_N;
  std::vector<std::uint8_t> used;
  // The sensor's moment (N·mm, sensor frame), measured and predicted
  // with the fitted moment bias or the tare added (both empty when not logged); the
  // spindle's load torque (N·mm, positive braking), measured and predicted with the
  // fitted idle and viscous terms or the tare added, that added offset on its own, and
  // the spin speed |ω| (rad/s) (all four empty when not logged).
  std::vector<glm::dvec3> torque_measured_Nmm, torque_predicted_Nmm;
  std::vector<double> spindle_measured_Nmm, spindle_predicted_Nmm, spindle_offset_Nmm,
      spin_rad_s;
  // Where the spindle's offset came from: "fit" (idle and viscous nuisances),
  // "tare" (the mean load of samples with no predicted contact) or "none" (neither: too
  // few samples without contact, so the offset is 0 and the measured energy not usable).
  std::string spindle_offset_source;
  DataQuality quality;
  // What the replay applied (data_schema::PredictedRecording): the lag and depth offset
  // the trajectory was built with, the force bias added and where it came from ("fit",
  // "tare" or "none").
  double lag_ms = 0, depth_offset_mm = 0;
  glm::dvec3 force_bias_N{0.0};
  std::string force_bias_source = "none";
  // Half-width of the 95 % band of the predicted force (sensor frame, N)
  // from the fitted constants' covariance (delta method through the sensitivities);
  // empty without a fit.
  std::vector<glm::dvec3> band95_N;
  // Per bone class touched, α·removed and the replay's friction work (empty before).
  std::vector<ClassEnergy> energy;
  bool has_torque() const { return !torque_measured_Nmm.empty(); }
  bool has_spindle() const { return !spindle_measured_Nmm.empty(); }
};

struct SampleInfo {
  std::string id, path, sha256;
  double voxel_mm = 0;
  // Removed bone projected along the volume z axis: thickness of bone removed in each
  // (x, y) column, mm (nx × ny, x fastest). Empty when not computed.
  std::size_t nx = 0, ny = 0;
  std::vector<float> removed_depth_mm;
  double removed_volume_mm3 = 0;
  // Per (x, y) column the class label of most removed bone (0 = none), and the
  // sample's class names by label (the removed-bone map's class colours).
  std::vector<std::uint8_t> removed_class;
  std::map<int, std::string> classes;
};

struct ParameterRow {  // the constants a replay used (validate) — fit.json has intervals
  int class_label = 0;
  std::string class_name;
  double alpha_N_per_mm2 = 0, c1_N_per_mm2 = 0, mu = 0;
};

struct ReportData {
  std::string mode;  // "calibrate" | "validate"
  std::string experiment_name, experiment_description, experiment_path, experiment_sha256;
  std::string context_of_use;
  std::string params_path, params_sha256;  // validate: the fixed parameters
  std::string criteria_path, criteria_sha256;
  std::uint64_t seed = 0;
  nlohmann::json model = nlohmann::json::object();        // name, version, replay settings
  nlohmann::json calibration = nlohmann::json::object();  // method and settings
  std::vector<std::string> limitations;
  std::vector<ParameterRow> parameters;
  std::vector<SampleInfo> samples;
  std::vector<RecordingSeries> recordings;
  Provenance provenance;
  // The solution-verification study (model::to_json(ConvergenceStudy)) when the run
  // made one (validate does by default); null otherwise.
  nlohmann::json verification;
};

// What write_report is given, all in memory: `validate` and `calibrate` build it from their
// replay, `burrbench report DIR` from DIR's prediction.h5, fit.json and criteria.toml.
struct ReportInputs {
  data_schema::Prediction prediction;  // with its context (Prediction::context)
  std::string prediction_file;         // names it in messages ("…/prediction.h5")
  std::optional<data_schema::FitResult> fit;
  std::optional<Criteria> criteria;
  std::string criteria_path, criteria_sha256;  // the file the criteria were read from
  // The solution-verification study (model::to_json(ConvergenceStudy)), or null.
  nlohmann::json verification;
};

// The sections' view of the inputs: a recording whose segments carry both roles appears
// once per role (the second as id@validate), each with its own used samples. InputError
// naming the prediction file and the context's field on a defect.
ReportData report_data(const ReportInputs& in);

// Residuals CSV beside the report: recording_id, t_s, used, e = measured − predicted.
void write_residuals_csv(const std::filesystem::path& path, const ReportData& in);

}  // namespace burrbench::analysis
