#pragma once
// What `burrbench replay` predicts for every recording of an experiment, beside what was
// measured. Stored as HDF5 (format "burrbench.prediction"); docs/formats.md lists every
// field with unit and frame.
#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <glm/glm.hpp>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::data_schema {

inline constexpr const char* kPredictionFormat = "burrbench.prediction";
// 2.0: provenance in the /provenance group and fixed-length strings, as the other HDF5
// formats (1.0 kept provenance as a JSON attribute; such files are refused by version).
inline constexpr int kPredictionVersionMajor = 2;
// 2.1: the registration per recording; 2.2: the wrench; 2.3: what the prediction applied
// (bias, lag, depth offset, tare), the samples each role counts, the band, the energy and
// the removed bone per sample (issue 14: one hand-off from model to report); 2.4: the
// contact quadrature of each recording's replay, the spin speed per sample and the run's
// context (issues 56 and 58: the report reads this file alone).
inline constexpr int kPredictionVersionMinor = 4;
// Class labels whose removed volume is recorded: the model's (0..kModelClassLabels − 1).
inline constexpr std::size_t kPredictionClasses = kModelClassLabels;

// One replayed recording, n = number of force samples; every per-sample vector has n
// entries. Index k is the force sample at t_s[k].
struct PredictedRecording {
  std::string recording_id;                     // the manifest's id (no '/')
  std::vector<double> t_s;                      // s from the first force sample, increasing
  std::vector<glm::dvec3> force_burr_vol_N;     // predicted force on the burr, volume frame
  std::vector<glm::dvec3> force_sensor_pred_N;  // sensor should read, sensor frame, force_bias_N added
  std::vector<glm::dvec3> force_sensor_meas_N;  // what it read, sensor frame
  std::vector<glm::dvec3> centre_vol_mm;  // burr centre used (after lag, registration, offset)
  std::vector<glm::dvec3> normal_vol;     // contact normal (unit, or 0 without contact)
  std::vector<double> depth_b_mm;         // immersion depth b
  std::vector<std::uint8_t> class_mask;   // bit k: class label k in contact
  std::vector<std::uint8_t> buried;       // 1: contact normal ill-defined (MODEL.md)
  std::vector<std::uint8_t> use;          // 1: inside a used segment
  // 2.2: the wrench (MODEL.md "Moments"); each empty (a 2.0/2.1 file, or nothing
  // measured) or one value per sample. N·mm.
  std::vector<glm::dvec3> moment_burr_vol_Nmm;     // friction couple T on the burr about its centre, volume frame
  std::vector<glm::dvec3> torque_sensor_pred_Nmm;  // the sensor's moment about its origin, sensor frame, torque_bias_Nmm added
  std::vector<glm::dvec3> torque_sensor_meas_Nmm;  // what it read (empty: no torque channel)
  std::vector<double> spindle_torque_pred_Nmm;     // load torque on the spindle, −T·ω̂, spindle_offset_Nmm added
  std::vector<double> spindle_torque_meas_Nmm;     // what the drive reported (empty: none)
  std::array<double, kPredictionClasses> removed_mm3{};  // eroded bone by class label
  std::int64_t steps = 0;                                // internal replay steps
  // 2.1: the registration the replay used (issue 17): "fiducials" (fitted from beads) or
  // how the transform was given (vol_from_rig | rig_from_vol); for fiducials the RMS and
  // largest residual at the beads, the localisation error assumed and Fitzpatrick's
  // predicted TRE along the path (mm; NaN otherwise, or in 2.0 files).
  std::string registration_method;
  double registration_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double registration_max_mm = std::numeric_limits<double>::quiet_NaN();
  double fiducial_error_mm = std::numeric_limits<double>::quiet_NaN();
  double tre_path_rms_mm = std::numeric_limits<double>::quiet_NaN();
  double tre_path_max_mm = std::numeric_limits<double>::quiet_NaN();
  // 2.3 (older files: role "", the vectors empty, offsets 0, sources "none", lag NaN).
  // The manifest's role, and per sample whether it counts in the fit's (used_calibrate)
  // or the release gate's (used_validate) residuals: inside a used segment of that role
  // and not a buried sample the manifest excludes. A recording whose segments carry both
  // roles has 1s in both.
  std::string role;
  // 2.4: the contact kernel's quadrature, "lens" or "cube" (docs/model.md; older files: "lens").
  std::string quadrature = "lens";
  std::vector<std::uint8_t> used_calibrate, used_validate;
  // What was added to the predicted channels: the fitted nuisance ("fit"), the tare —
  // the measured mean over samples with no predicted contact ("tare") — or nothing
  // ("none"). The spindle's offset varies with the speed (idle + viscous·Δkrpm).
  glm::dvec3 force_bias_N{0.0};
  std::string force_bias_source = "none";
  glm::dvec3 torque_bias_Nmm{0.0};
  std::string torque_bias_source = "none";
  std::vector<double> spindle_offset_Nmm;  // empty or one per sample
  std::string spindle_offset_source = "none";
  // The lag and the depth offset the trajectory was built with (the fit's, or the
  // manifest's lag and 0).
  double lag_ms = std::numeric_limits<double>::quiet_NaN();
  double depth_offset_mm = 0;
  // Half-width of the 95 % band of force_sensor_pred_N from the fitted constants'
  // covariance (delta method); empty without one. N, sensor frame.
  std::vector<glm::dvec3> band95_N;
  // The replay's friction work ∫ΣW dt per class label (mJ = N·mm): by the energy
  // balance it equals α·removed_mm3.
  std::array<double, kPredictionClasses> friction_energy_mJ{};
  // 2.4: the burr's spin speed |ω| per sample (rad/s), when the spindle's load was logged.
  std::vector<double> spin_rad_s;
  std::size_t samples() const { return t_s.size(); }
};

// 2.3: the bone every recording of one sample removed, projected along the volume z axis
// (per voxel the largest removal by any recording: recordings drill separate spots).
struct RemovedBone {
  std::string sample_id;
  double voxel_mm = 0;
  std::size_t nx = 0, ny = 0;
  std::vector<float> removed_depth_mm;     // nx·ny, x fastest: removed thickness per column
  std::vector<std::uint8_t> removed_class;  // nx·ny: class label of most removed bone (0 none)
  double removed_volume_mm3 = 0;
};

struct Prediction {
  std::vector<PredictedRecording> recordings;  // replay order (kept in the file)
  std::vector<RemovedBone> removed;            // 2.3: one per sample, or empty
  Provenance provenance;
  // 2.4, /context: what the report states about the run beyond the series, as the command
  // that made the prediction knew it (docs/formats.md "The prediction's context"): which
  // command ("made_by"), the experiment, the constants, the replay's and the calibration's
  // settings, the data-quality findings, the solution-verification study, and per
  // recording and sample its file, notes, segments and session log. An object, or null
  // (a plain `replay`, or an older file).
  nlohmann::json context;
};

// Throws InputError naming file and field on any defect: lengths, non-finite values,
// flags other than 0/1, t_s not increasing, duplicate or invalid recording ids.
void validate(const Prediction& p, const std::string& file_for_messages);
void write_prediction(const std::filesystem::path& path, const Prediction& p);
// Unit of every per-sample dataset of a recording (as its @unit in the file) and of the
// recording's numeric attributes (removed_mm3, friction_energy_mJ, lag_ms, …), by name:
// the one table the writer, the reader and the Python module's in-memory replay share.
std::vector<std::pair<std::string, std::string>> prediction_units();
// Validates format name, major version, layout, units and values; all datasets together
// ≤ 4 GiB, checked from the headers before reading.
Prediction read_prediction(const std::filesystem::path& path);
// The same from an HDF5 file image in memory; `name` stands for the file in messages.
Prediction read_prediction_image(std::string_view image, const std::string& name);

}  // namespace burrbench::data_schema
