#pragma once
// Experiment manifest (TOML, format "burrbench.experiment"): which samples and recordings,
// the rig→volume registration, burr and sensor geometry, time segments, and what to fit.
// docs/formats.md lists every key. Paths in the file are relative to the manifest's
// folder; after read_manifest every path here is absolute.
//
// Matrices: TOML writes them row by row ([[r00,r01,r02],[r10,...],...]); glm is
// column-major, so TOML rotation[i][j] == glm matrix[j][i]. x_vol = R·x_rig + t.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::data_schema {

inline constexpr const char* kManifestFormat = "burrbench.experiment";
inline constexpr int kManifestVersionMajor = 1;
inline constexpr int kManifestVersionMinor = 0;

struct SampleRef {
  std::string id;
  std::filesystem::path path;  // absolute
};

struct BurrConfig {
  double radius_mm = 0;
  glm::dvec3 shaft_axis_rig{0, 0, 1};  // unit vector (normalised on read)
  int spin_sign = 1;                    // +1: ω along shaft_axis_rig; -1: against
  glm::dvec3 tool_offset_mm{0, 0, 0};   // burr centre minus stage-reported position, rig frame
};

enum class SensorMeasures { kForceOnSample, kForceOnBurr };

struct SensorConfig {
  glm::dmat3 rotation_sensor_to_rig{1.0};  // proper rotation: v_rig = R·v_sensor
  SensorMeasures measures = SensorMeasures::kForceOnSample;
  std::optional<double> sigma_N;           // absent → estimated from no-contact samples
  // The sensor's origin (the point its moments are taken about), rig frame, mm
  // (MODEL.md "Moments"): absent in older manifests = the rig origin.
  glm::dvec3 origin_rig_mm{0, 0, 0};
  std::optional<double> sigma_Nmm;         // moment noise; absent → estimated like sigma_N
};

struct SpindleConfig {                     // [spindle]: the drive's load channel
  std::optional<double> sigma_Nmm;         // load-torque noise; absent → estimated
};

// Rig → volume, x_vol = rotation·x_rig + translation_mm; either given directly or as
// ≥ 3 non-collinear fiducial pairs (then rotation/translation stay identity/zero here and
// the model's registration code fits them).
// Given directly, the transform is named by its direction: `vol_from_rig` (x_vol = R·x_rig
// + t; the bare keys rotation/translation_mm mean this too) or `rig_from_vol` (as most lab
// tools export it; inverted on read). Here it is always stored as vol_from_rig.
struct Registration {
  glm::dmat3 rotation{1.0};
  glm::dvec3 translation_mm{0, 0, 0};
  std::string given_as = "vol_from_rig";  // how the file stated it (vol_from_rig | rig_from_vol)
  std::vector<glm::dvec3> fiducials_rig_mm, fiducials_vol_mm;
  // Localisation accuracy of the beads (RMS, mm): the fit is refused above 3× it, and it
  // sets the predicted target registration error (TRE). Absent: 0.1 mm.
  std::optional<double> fiducial_error_mm{};
  bool from_fiducials() const { return !fiducials_rig_mm.empty(); }
};

enum class RecordingRole { kCalibrate, kValidate };

struct Segment {
  double start_s = 0;  // seconds from the recording's first sample
  double end_s = 0;
  bool use = true;     // false: skip this span
  std::string label;
  // Overrides the recording's role for this span: one recording may calibrate on its
  // plunge and sweep and validate on its polish (docs/calibration.md "Roles").
  std::optional<RecordingRole> role{};
};

struct RecordingRef {
  std::string id;
  std::filesystem::path path;  // absolute
  std::string sample;          // a SampleRef id
  RecordingRole role = RecordingRole::kCalibrate;
  double lag_ms = 0;           // initial / fixed position→force lag
  // Constant spindle speed (signed rpm) for a recording without a spindle_rpm channel.
  std::optional<double> spindle_rpm;
  // Recording metadata the manifest may contradict on purpose (e.g. "burr_radius_mm" of a
  // burr re-measured since): without a waiver a disagreement is refused.
  std::vector<std::string> waive;
  Registration registration;
  std::vector<Segment> segments;  // empty: the whole recording
};

// One fitted constant. Free: lower < initial < upper. Fixed: initial is used as is
// (alpha may be +inf = no erosion); lower/upper default to initial when absent.
struct ParamSpec {
  double initial = 0, lower = 0, upper = 0;
  bool fixed = false;
};

struct ClassFitSpec {
  std::string key;        // as written in [fit.classes.<key>]: a class name or an id
  std::uint8_t label = 0; // resolved against the samples' class tables
  ParamSpec alpha;        // N/mm²
  ParamSpec c1;           // N/mm²
  ParamSpec mu;           // dimensionless
};

enum class LossKind { kNone, kHuber, kCauchy };
enum class BuriedPolicy { kExclude, kDownweight };

struct NuisanceSpec {
  bool bias = true;
  bool lag = true;
  std::array<double, 2> lag_bounds_ms{-20.0, 20.0};
  bool depth_offset = false;
  // Registration pose correction per sample mounting registered by fiducials (6 values,
  // prior from the fiducial fit; docs/calibration.md "Registration").
  bool pose = true;
};

struct FitSpec {
  LossKind loss = LossKind::kHuber;
  double loss_scale = 3.0;  // in units of σ
  BuriedPolicy buried = BuriedPolicy::kExclude;
  std::uint64_t seed = 1;
  int multistart = 16;  // starts of the global search (docs/calibration.md)
  // The precision a lab needs, as the relative half-width of the 95 % profile interval
  // ([fit.precision] alpha, c1, mu; absent: none asked). A constant whose interval is
  // wider gets the verdict "imprecise" instead of "identifiable".
  std::optional<double> precision_alpha, precision_c1, precision_mu;
  std::vector<ClassFitSpec> classes;
  NuisanceSpec nuisance;
  // [fit] channels: which measured channels the fit uses besides the force (always):
  // "torque" (the sensor's moments, with a moment bias per recording) and "spindle" (the
  // drive's load torque, with an idle offset and a viscous term per recording).
  bool fit_torque = false, fit_spindle = false;
};

struct ExperimentManifest {
  std::filesystem::path file;  // absolute path of the manifest itself ("" if built in code)
  std::string name, description;
  std::vector<SampleRef> samples;
  BurrConfig burr;
  SensorConfig sensor;
  SpindleConfig spindle;
  std::vector<RecordingRef> recordings;
  FitSpec fit;

  const SampleRef* sample(const std::string& id) const;
  const RecordingRef* recording(const std::string& id) const;
};

const char* to_string(SensorMeasures m);
const char* to_string(RecordingRole r);
const char* to_string(LossKind l);
const char* to_string(BuriedPolicy b);

// Structural checks (ids unique, references, bounds, rotations, fiducials, files exist).
void validate(const ExperimentManifest& m, const std::string& file_for_messages);
// Parses, resolves paths, validates, resolves class keys against the samples' class tables.
ExperimentManifest read_manifest(const std::filesystem::path& path);
// The same from TOML text (e.g. a fuzz target); paths resolve against as_path's folder
// and messages name as_path.
ExperimentManifest parse_manifest(std::string_view toml_text, const std::filesystem::path& as_path);
// Writes paths relative to the manifest's folder.
void write_manifest(const std::filesystem::path& path, const ExperimentManifest& m);

}  // namespace burrbench::data_schema
