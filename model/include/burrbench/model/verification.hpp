#pragma once
// Solution verification (ASME V&V 40): how much the replayed force and the removed bone
// change with the voxel size and the replay step, and a Richardson estimate of the
// discretization error left at the sample's own voxel size l and step Δt.
//
// Every recording is replayed with the same constants at (l, Δt), (l/2, Δt), (2l, Δt) and
// (l, Δt/2); l/2 splits every voxel into 8 and 2l merges blocks of 8
// (data_schema::import::split_voxels / merge_voxels). docs/calibration.md, "Solution
// verification".
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/progress.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::model {

// Richardson extrapolation from three levels refined by 2: d_coarse = f(2h) − f(h),
// d_fine = f(h) − f(h/2) (or their RMS norms). When the changes shrink (|d_coarse| >
// |d_fine| > 0, same sign for scalars) the observed order is p = log2(d_coarse/d_fine),
// used clamped to [0.5, 4], and the error left at h is |d_fine|·2^p/(2^p − 1). Otherwise
// the order is not observed and the error at h is taken as the larger change.
struct RichardsonEstimate {
  double order = NAN;  // observed p (NaN when not observed)
  double error = 0;    // estimated |f(h) − f(0)|
};
RichardsonEstimate richardson(double d_coarse, double d_fine);

// One recording replayed at one resolution.
struct LevelReplay {
  std::string level;          // "l" | "l/2" | "2l" | "dt/2"
  double voxel_mm = 0, step_s = 0;
  double rms_change_N = 0;    // against (l, Δt): RMS over used samples and the 3 axes
  double max_change_N = 0;    // against (l, Δt): largest |ΔF| over used samples
  double peak_N = 0;          // largest |F| over used samples
  std::array<double, kMaxClasses> removed_mm3{};
  double wall_s = 0;
};

struct RecordingConvergence {
  std::string id;
  std::size_t samples = 0;               // used samples compared
  std::vector<LevelReplay> levels;       // l, l/2, 2l, dt/2 in that order
  RichardsonEstimate voxel;              // force, per axis (N): from 2l, l, l/2
  double step_error_N = 0;               // at Δt, first order assumed: 2·RMS(F_Δt − F_Δt/2)
  double error_N = 0;                    // √(voxel² + step²): the force's discretization error
  std::array<RichardsonEstimate, kMaxClasses> removed{};  // removed volume per class, mm³
};

// The part of a sample the replays used: the voxels within reach of its recordings' burr
// (VerifyOptions::crop), or all of them.
struct SampleReach {
  std::string sample_id;
  std::array<std::size_t, 3> dims{}, replayed_dims{};  // x, y, z voxels at l
};

struct ConvergenceStudy {
  std::vector<RecordingConvergence> recordings;
  std::vector<SampleReach> reach;  // per sample, in order of first use
  Quadrature quadrature = Quadrature::kLens;    // of the replays
  std::map<std::uint8_t, std::string> classes;  // labels present in the samples
  double sigma_N = NAN;                         // sensor noise per axis
  std::string sigma_source;
  double largest_error_N = 0;                   // over the recordings
  std::string worst_recording;
  bool below_noise() const { return largest_error_N < sigma_N; }
  std::string verdict() const;                  // one sentence for the report and the CLI
};

struct VerifyOptions {
  double step_s = 0;                  // base step Δt; 0 = the replay's default (half the median sample period)
  std::optional<double> sigma_N;      // absent: the manifest's sensor.sigma_N, else estimated
  // Replays run at once (each recording at each level is independent; at most one at
  // l/2, whose volume holds 8× the voxels). The study does not depend on it.
  int threads = 1;
  // Replay each sample's part within reach of its recordings' burr (its radius and 4 voxels
  // round every centre), not all of it: the same bone where the burr goes, to rounding
  // (the voxel centres are computed from another origin), at a fraction of the memory.
  bool crop = true;
  Quadrature quadrature = Quadrature::kLens;  // of every replay (quadrature.hpp)
  // false: forces only (the contact force's own convergence, without erosion's geometry;
  // docs/model.md "Where the cube quadrature's error comes from").
  bool erosion = true;
};

// Replays every recording four times. InputError as for the replay.
ConvergenceStudy verify_convergence(const Experiment& e, const ModelParams& params,
                                    const VerifyOptions& options = {}, Progress* progress = nullptr);

nlohmann::json to_json(const ConvergenceStudy& s);

// Sensor noise per axis from samples without contact: 1.4826·MAD about each recording's
// per-axis median (the median absorbs a bias). `no_contact[r]`: recording r's measured
// forces at samples without predicted contact; a recording with fewer than 10 is skipped.
// nullopt below 10 samples in all; `samples_used` counts those that entered.
std::optional<double> no_contact_sigma_N(const std::vector<std::vector<glm::dvec3>>& no_contact,
                                         std::size_t& samples_used);
// The same for a one-component channel (the spindle's load).
std::optional<double> no_contact_sigma(const std::vector<std::vector<double>>& no_contact,
                                       std::size_t& samples_used);

}  // namespace burrbench::model
