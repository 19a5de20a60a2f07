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
#include <vector>

#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema {

inline constexpr const char* kPredictionFormat = "burrbench.prediction";
// 2.0: provenance in the /provenance group and fixed-length strings, as the other HDF5
// formats (1.0 kept provenance as a JSON attribute; such files are refused by version).
inline constexpr int kPredictionVersionMajor = 2;
inline constexpr int kPredictionVersionMinor = 2;  // 2.1: the registration per recording; 2.2: the wrench
// Class labels 0..7 whose removed volume is recorded (the model's label range).
inline constexpr std::size_t kPredictionClasses = 8;

// One replayed recording, n = number of force samples; every per-sample vector has n
// entries. Index k is the force sample at t_s[k].
struct PredictedRecording {
  std::string recording_id;                     // the manifest's id (no '/')
  std::vector<double> t_s;                      // s from the first force sample, increasing
  std::vector<glm::dvec3> force_burr_vol_N;     // predicted force on the burr, volume frame
  std::vector<glm::dvec3> force_sensor_pred_N;  // sensor should read (no bias), sensor frame
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
  std::vector<glm::dvec3> torque_sensor_pred_Nmm;  // the sensor's moment about its origin, sensor frame
  std::vector<glm::dvec3> torque_sensor_meas_Nmm;  // what it read (empty: no torque channel)
  std::vector<double> spindle_torque_pred_Nmm;     // load torque on the spindle, −T·ω̂
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
  std::size_t samples() const { return t_s.size(); }
};

struct Prediction {
  std::vector<PredictedRecording> recordings;  // replay order (kept in the file)
  Provenance provenance;
};

// Throws InputError naming file and field on any defect: lengths, non-finite values,
// flags other than 0/1, t_s not increasing, duplicate or invalid recording ids.
void validate(const Prediction& p, const std::string& file_for_messages);
void write_prediction(const std::filesystem::path& path, const Prediction& p);
// Validates format name, major version, layout, units and values; all datasets together
// ≤ 4 GiB, checked from the headers before reading.
Prediction read_prediction(const std::filesystem::path& path);

}  // namespace burrbench::data_schema
