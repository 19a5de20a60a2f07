#pragma once
// From an experiment (manifest + recordings + samples) to what the replay engine and the
// calibration consume: per recording, the burr's trajectory in the VOLUME frame at the
// force timestamps, the measured force in the SENSOR frame at the same instants, and the
// map from a predicted force on the burr to what the sensor should read.
//
// Frames and signs (docs/replay.md):
//   x_vol = R_reg·(x_stage_rig + tool_offset_rig) + t_reg        (registration rig → volume)
//   ω_vol = 2π·rpm/60 · spin_sign · R_reg·shaft_axis_rig          (rpm may be signed)
//   F_sensor_pred = s · R_sensor→rigᵀ · R_regᵀ · F_on_burr_vol,   s = −1 if the sensor
//                   measures the force on the sample (= −F_on_burr), +1 if on the burr.
// Lag: the force recorded at t is caused by the burr position at t − lag; positions and
// rpm are interpolated linearly at t − lag (clamped to the first/last stage sample).
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <glm/glm.hpp>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/fitted_nuisances.hpp"
#include "burrbench/model/registration.hpp"
#include "burrbench/model/replay.hpp"

namespace burrbench::model {

// A time series sampled at strictly increasing instants (seconds on the recording's clock:
// 0 = first force sample). Linear interpolation, clamped outside [t.front(), t.back()].
template <class T>
struct Series {
  std::vector<double> t_s;
  std::vector<T> value;
  T at(double t) const;
  // d at/dt: the slope of the segment holding t; at a sample instant the mean of the two
  // neighbouring slopes (what a central difference sees); 0 where at() is clamped.
  T slope(double t) const;
};
extern template struct Series<double>;
extern template struct Series<glm::dvec3>;

// How a recording was registered, for the outputs (replay, calibrate, validate print it;
// prediction and fit.json store it). TRE: Fitzpatrick's predicted target registration
// error at the burr centre, RMS and largest over the stage samples (fiducials only).
struct RegistrationSummary {
  std::string method = "vol_from_rig";  // fiducials | vol_from_rig | rig_from_vol
  std::size_t fiducials = 0;
  double rms_mm = NAN, max_mm = NAN;    // residuals at the fiducials
  int worst = -1;                       // fiducial with the largest residual
  double fle_mm = NAN;                  // fiducial localisation error used
  bool fle_given = false;               // from the manifest (else the default)
  double tre_path_rms_mm = NAN, tre_path_max_mm = NAN;
  std::string text() const;             // one line
};

// One recording, aligned and mapped to the volume frame; everything needed to rebuild
// its trajectory for any lag / depth offset without file I/O.
struct AlignedRecording {
  std::string id;
  std::string sample_id;
  std::filesystem::path file;
  std::int64_t t0_ns = 0;  // host time of the first force sample

  std::vector<double> t_s;                 // force timestamps (s from t0), strictly increasing
  std::vector<glm::dvec3> force_sensor_N;  // measured, sensor frame, as recorded
  // Measured moment, sensor frame, N·mm, at the force samples: empty when the force
  // stream has no torque_Nmm channel.
  std::vector<glm::dvec3> torque_sensor_Nmm;
  // The spindle drive's load torque (N·mm, positive braking) from spindle_torque_Nmm or
  // spindle_power_W (converted through the speed); empty when not logged.
  Series<double> spindle_torque_Nmm;
  std::vector<std::uint8_t> use;           // 1: inside a used segment (all 1 without segments)
  // The same split by role (a segment's `role`, default the recording's): use = either.
  std::vector<std::uint8_t> use_calibrate, use_validate;
  std::size_t dropped_force_samples = 0;   // stale or non-increasing timestamps
  std::string force_stream;                // the name of the stream holding force_N
  // What the session logged about itself, for the report's data-quality table: the
  // recording's notes, its events (gap, reconnect, fault, …; times in s from t0, before
  // the first force sample negative) and the stale rows of each stream.
  std::string notes;
  struct SessionEvent {
    double t_s = 0;
    std::string kind, stream, detail;
  };
  std::vector<SessionEvent> events;
  std::map<std::string, std::size_t> stale_rows;
  // Stretches where the stage did not measure the burr's position: at the manifest's lag,
  // t − lag falls in an interval between fresh position samples longer than
  // kPositionGapFactor × their median interval, or beyond the first or last one by more
  // than that. The replay goes on along the straight line across (erosion must follow
  // the path), but their force samples are taken out of use, use_calibrate and
  // use_validate: a force paired with a guessed position would be fitted and scored as if
  // the burr had been there. docs/replay.md "Alignment and lag".
  struct PositionGap {
    double from_s = 0, to_s = 0;    // its first and last force sample (s, recording clock)
    double gap_s = 0;               // the stage's interval (beyond an end: how far beyond)
    std::size_t force_samples = 0;  // force samples in it (all taken out of use)
  };
  std::vector<PositionGap> position_gaps;
  double position_period_s = 0;  // median interval of the fresh position samples
  std::size_t unmeasured_position_samples() const;
  // One warning line naming the recording, the gaps and the samples left out ("" if none).
  std::string position_gap_text() const;
  // Stretches without a force sample while the stage kept moving: consecutive force samples
  // further apart than kPositionGapFactor × their median interval (a sensor that dropped
  // out, a FIFO overrun), or stage samples that long before the first force sample (a
  // sensor that started late). A straight line from one force sample's centre to the next
  // would erode the bone where the burr never went (a stroke back and forth becomes a
  // point), and a replay from the first force sample would miss the bone cut before it,
  // so the trajectory passes through the stage's path at these times: the missing samples'
  // times, at the force stream's median interval (Trajectory::vias).
  struct ViaTime {
    std::size_t after = 0;  // the force sample before it (Trajectory::Via::kBeforeFirst)
    double t_s = 0;         // recording clock
  };
  std::vector<ViaTime> via_times;
  // Those stretches, each from the force sample before it (for a late start: the first
  // via) to the one after it, in s on the recording's clock (the report's quality events).
  struct Silence {
    double from_s = 0, to_s = 0;
  };
  std::vector<Silence> silences() const;

  Series<glm::dvec3> stage_rig_mm;  // stage-reported position (fresh samples only)
  Series<double> spindle_rpm;       // signed: negative = reverse spin

  RigidTransform rig_to_vol;                    // from the manifest or fitted to fiducials
  std::optional<RegistrationFit> fiducial_fit;  // set when fitted (RMS in fiducial_fit->rms_mm)
  RegistrationSummary registration;
  glm::dvec3 tool_offset_rig_mm{0};
  glm::dvec3 shaft_axis_vol{0, 0, 1};  // unit
  int spin_sign = 1;
  double radius_mm = 0;
  glm::dmat3 sensor_to_rig{1.0};
  double sensor_sign = -1;  // −1: sensor measures force on the sample
  glm::dvec3 sensor_origin_rig_mm{0};  // the point the sensor takes moments about
  double lag_s = 0;         // the manifest's lag_ms / 1000

  // Burr centre (volume frame) for a stage position. depth_offset_mm moves the burr
  // along −shaft_axis_vol (towards the burr tip: deeper for a feed along the shaft).
  glm::dvec3 centre_vol_mm(const glm::dvec3& stage_rig_mm, double depth_offset_mm = 0) const;
  glm::dvec3 omega_vol_rad_s(double rpm) const;

  // The trajectory at the force timestamps, and through the stage's path at via_times, for
  // a lag (s) and depth offset (mm): cheap re-interpolation, no file I/O. Use this in fits.
  // With `pose` (the registration's pose nuisance), every centre is corrected by it and
  // the spin axis turned with it.
  Trajectory trajectory(double lag_s, double depth_offset_mm = 0,
                        const PoseCorrection* pose = nullptr) const;
  Trajectory trajectory() const { return trajectory(lag_s, 0); }
  // ∂(burr centre, volume frame)/∂lag in mm per ms at each force sample and then at each
  // via (Direction::dcentre_vol_mm's order), for the replay's
  // forward sensitivities (Series::slope of the stage path; ω's dependence on the lag
  // through the rpm is not included). ∂centre/∂depth_offset is −shaft_axis_vol.
  std::vector<glm::dvec3> dcentre_dlag_ms(double lag_s) const;
  // |spindle speed| at each force sample minus its mean over the recording, in 1000 rpm:
  // what the drive's viscous load term acts on (so the idle offset is the load at the
  // mean speed) — the fit's nuisance and the report's offset use this one definition.
  std::vector<double> spindle_krpm_deviation() const;

  // What the sensor should read for a force on the burr in the volume frame. With `pose`
  // (the registration's correction) the rig, and the sensor with it, is turned by it.
  glm::dvec3 sensor_force_from_burr_force(const glm::dvec3& force_on_burr_vol_N,
                                          const PoseCorrection* pose = nullptr) const;
  // What its moment channel should read for the burr's wrench (MODEL.md "Moments"): the
  // force F acting through the burr centre p plus the couple T about p, taken about the
  // sensor origin o and with the force's sign convention: s·Qᵀ((p − o) × F + T), N·mm,
  // sensor frame (s = −1 for a sensor under the sample). With `pose`, the sensor's origin
  // o and its axes move with the corrected rig (centre_vol_mm is the corrected centre).
  glm::dvec3 sensor_torque_from_burr_wrench(const glm::dvec3& force_on_burr_vol_N,
                                            const glm::dvec3& moment_on_burr_vol_Nmm,
                                            const glm::dvec3& centre_vol_mm,
                                            const PoseCorrection* pose = nullptr) const;
};

// A position stream's interval longer than this many times its median interval is a gap
// (a stage at 1 kHz: 5 ms, four samples missing in a row): docs/replay.md.
inline constexpr double kPositionGapFactor = 5.0;

// Canonical channels, alignment, segments, registration. `file_for_messages` names the
// recording file in errors (InputError: missing channels, empty streams, ...).
AlignedRecording align_recording(const data_schema::ExperimentManifest& m,
                                 const data_schema::RecordingRef& ref,
                                 const data_schema::Recording& rec,
                                 const std::string& file_for_messages);

// The whole experiment: manifest, every sample (by id) and every recording, aligned.
struct Experiment {
  data_schema::ExperimentManifest manifest;
  std::map<std::string, data_schema::SampleVolume> samples;
  std::vector<AlignedRecording> recordings;  // manifest order
  // Every file read, hashed as it was read (read_hashed): the manifest (as given), then the
  // samples and the recordings in manifest order. Outputs record these SHA-256s, and
  // data_schema::check_unchanged tells before they are written whether a file changed since.
  std::vector<InputFile> inputs;
  // The SHA-256 taken when `path` (spelled as in `inputs`) was read; InvariantError if not read.
  const std::string& sha256_of(const std::filesystem::path& path) const;
};
Experiment load_experiment(const std::filesystem::path& manifest_path);

// InputError (naming the manifest and the later listing) when two listings of one file use
// a sample for the same role. A file may be listed more than once (once per role, or in
// `replay` to compare two registrations), but where samples are pooled (the fit, the
// metrics of `validate`) such a sample would count twice: twice the weight in the fit,
// intervals narrower than the data support (by up to √2), pooled metrics weighted twice,
// and no overlap warning (a file listed again is one drilling).
void check_each_sample_used_once_per_role(const Experiment& e);

// How deep in bone the burr was where its recording's path begins: the first lead-in via
// (a stage that started before the sensor), else the first force sample, at the manifest's
// lag. The replay starts from the sample as scanned, so a burr already in bone there had
// cut its way in before the recording began (or the registration puts it too deep), and
// the forces near that hole are predicted against bone that is gone.
struct StartInBone {
  double t_s = 0;           // the path's first point, recording clock (a lead-in: < 0)
  double depth_b_mm = 0;    // the burr's immersion depth b there (MODEL.md), bone as scanned
  double tolerance_mm = 0;  // one voxel edge, or the registration's largest TRE along the
                            // path if larger: an immersion a surface touch can show
  // The warning line when depth_b_mm > tolerance_mm ("" otherwise).
  std::string text(const AlignedRecording& r) const;
};
StartInBone start_in_bone(const Experiment& e, const AlignedRecording& r);

// The warnings of the alignment, in manifest order: every recording's position gaps
// (AlignedRecording::position_gap_text) and a path that begins in bone (StartInBone). What
// `replay`, `verify`, `calibrate`, `validate`, `report` and the Python module print.
std::vector<std::string> alignment_warnings(const Experiment& e);

// ---- replay of an experiment and its prediction file (format "burrbench.prediction") ----

// The replay's result for one recording: the prediction file's record (data_schema owns
// the format) plus the replay's wall time, which is not stored (not reproducible).
struct RecordingPrediction : data_schema::PredictedRecording {
  double wall_s = 0;
  // The band's sensitivities diverged (sensitivities_diverged): band95_N is left empty
  // rather than drawn from them.
  bool band_diverged = false;
  // The friction part of force_sensor_pred_N (sensor frame, N, no bias): what the check of
  // friction against its predicted direction regresses on. Not stored in the file.
  std::vector<glm::dvec3> friction_sensor_pred_N;
};

// The spindle's load torque for a couple T on the burr spinning at ω: −T·ω̂ (N·mm; 0 when
// ω = 0). Positive when the cutting brakes the spin.
double spindle_torque_Nmm(const glm::dvec3& moment_on_burr_vol_Nmm, const glm::dvec3& omega_vol_rad_s);

// How a replay becomes a prediction (issue 14: the one path from model to report, used
// by `replay`, `validate`, `calibrate` at its optimum, `report` of an older calibrate
// directory and the Python module).
struct PredictOptions {
  ReplayOptions replay;  // step and erosion (directions and sensitivities are set here)
  // The fit whose nuisances are applied per recording: lag, depth offset and pose build the
  // trajectory, bias and spindle terms are added to the predicted channels. Null: the
  // manifest's lag, no offset, no correction.
  const data_schema::FitResult* fit = nullptr;
  // For a channel without a fitted offset: add the tare, the measured mean over samples
  // with no predicted contact (≥ 10 of them; the spindle's as idle + slope·Δkrpm over the
  // spinning ones). Off: nothing is added (a plain replay).
  bool tare = false;
  // Covariance of the constants in ln θ: gives band95_N (null or empty: no band).
  const BandCovariance* band = nullptr;
  // The manifest's buried policy: excluded buried samples do not count as used.
  bool exclude_buried = false;
  // Fill the removed-bone maps (the maps take, per voxel, the largest removal by any
  // recording). Whenever the replay erodes, each recording replays a fresh copy of the
  // scanned part it reaches and the pairs that removed the same bone are listed
  // (ExperimentPrediction::overlaps), maps or not.
  bool removed_bone = false;
  // Progress of the experiment's replays: the fraction is the experiment's, each line
  // names its recording.
  Progress* progress = nullptr;
  // predict_experiment replays this many recordings at once (1..kMaxThreads). The result
  // does not depend on it (each recording starts from its sample as scanned); each further
  // worker holds a copy of the part of each sample its replays reach (reach.hpp).
  int threads = 1;
};

// The most replays any command runs at once (--threads): each worker holds a copy of what
// it replays of the scanned volumes, so a mistyped 1000 would exhaust memory before it saved any time.
inline constexpr int kMaxThreads = 64;

// The burr's path in the volume frame that predict() replays: the recording's trajectory
// with the options' fitted lag, depth offset and pose (else the manifest's lag).
Trajectory prediction_trajectory(const AlignedRecording& r, const PredictOptions& options);

// Replays one aligned recording from the given (start-state) volume and applies the
// options' nuisances, offsets and band. The volume is restored when `restore`, else left
// eroded.
RecordingPrediction predict(const AlignedRecording& r, Volume& volume, const ModelParams& params,
                            const PredictOptions& options = {}, Progress* progress = nullptr,
                            bool restore = true);

// Two recordings of one sample that removed the same bone. Each recording is replayed
// from its sample as scanned, so whichever was drilled second was predicted against bone
// the other had already removed: its force, and constants fitted to it, are biased.
struct RemovedOverlap {
  std::string sample_id;
  std::string first, second;     // recording ids, in manifest order
  double shared_mm3 = 0;         // Σ over voxels of min(first's removal, second's) · l³
  double removed_first_mm3 = 0;  // each one's whole removal from the sample
  double removed_second_mm3 = 0;
  // One line that names the pair, the shared bone and what to do (a warning on stderr,
  // a limitation in the report, a Python warning).
  std::string text() const;
};
// An overlap is reported above this share of the smaller of the two removals: adjacent
// holes share only the partly eroded voxels of their rims, well below it (docs/replay.md).
inline constexpr double kOverlapShare = 0.01;

// The prediction of a whole experiment: per recording (manifest order), with
// PredictOptions::removed_bone per sample the removed bone and, whenever the replay
// erodes, the pairs of recordings that removed the same bone.
struct ExperimentPrediction {
  std::vector<RecordingPrediction> recordings;
  std::vector<data_schema::RemovedBone> removed;  // manifest's sample order
  std::vector<RemovedOverlap> overlaps;           // sample, then manifest order
};

// Every recording of the experiment, each replayed from its sample as scanned (recordings
// of one sample are taken to drill separate spots; when the replay erodes, pairs that did
// not are listed in `overlaps`: a recording file listed twice is one drilling, not a pair),
// with the manifest's role on each, PredictOptions::threads of them at once.
ExperimentPrediction predict_experiment(const Experiment& e, const ModelParams& params,
                                        const PredictOptions& options = {});

// Writes the data_schema prediction file (format "burrbench.prediction"), with the run's
// context (data_schema::Prediction::context; null: none, as a plain replay).
void write_prediction(const std::filesystem::path& path, const ExperimentPrediction& p,
                      const Provenance& provenance, const nlohmann::json& context = nullptr);
void write_prediction_csv(const std::filesystem::path& path,
                          const std::vector<RecordingPrediction>& p);

}  // namespace burrbench::model
