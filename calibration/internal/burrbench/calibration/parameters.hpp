#pragma once
// The fitted parameters and how they are laid out for Ceres.
//
// Physics (α, C1, μ per bone class) is positive and spans decades, so the solver works
// on x = ln θ with bounds ln(lower)..ln(upper); a fixed parameter is not a Ceres block
// at all (its natural value is used as is, α = +∞ meaning "no erosion"). Nuisances live
// per recording in natural units: sensor bias (N, sensor frame, 3 values), position→force
// lag (ms) and depth offset along the burr shaft axis (mm).
#include <array>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/model/model_params.hpp"

namespace burrbench::calibration {

inline constexpr int kLabels = model::kMaxClasses;  // the model's class labels
using PerLabel = std::array<double, kLabels>;

enum class PhysKind { kAlpha, kC1, kMu };
const char* to_string(PhysKind k);  // "alpha" | "c1" | "mu"
const char* unit_of(PhysKind k);    // "N/mm^2" | "1"

struct PhysicsParam {
  std::uint8_t label = 0;
  std::string class_name;
  PhysKind kind = PhysKind::kAlpha;
  data_schema::ParamSpec spec;
  int index = -1;  // position in the free vector x, -1 when fixed
};

// Natural-unit values of every class constant, by label (α = ∞: no erosion).
struct PhysicsValues {
  PerLabel alpha, c1, mu;
  PhysicsValues() {
    alpha.fill(std::numeric_limits<double>::infinity());
    c1.fill(0);
    mu.fill(0);
  }
  double& at(PhysKind k, std::uint8_t label) {
    return k == PhysKind::kAlpha ? alpha[label] : k == PhysKind::kC1 ? c1[label] : mu[label];
  }
  double at(PhysKind k, std::uint8_t label) const {
    return const_cast<PhysicsValues*>(this)->at(k, label);
  }
};

struct RecordingNuisance {
  std::string recording_id;
  int bias = -1, lag = -1, depth = -1;  // offsets in x (bias: 3 consecutive), -1 = fixed
  int pose = -1;  // registration pose correction of its mounting: 6 consecutive (ω rad, τ mm), shared
  int torque_bias = -1;  // moment bias, N·mm, sensor frame: 3 consecutive (torque channel fitted)
  int spindle = -1;      // spindle idle torque (N·mm) and viscous term (N·mm per 1000 rpm): 2 consecutive
  // The drive's load logged this much later than the force (ms; its own lag on top of the
  // force's): the predicted load at t − spindle_lag answers the load logged at t.
  int spindle_lag = -1;
  int mounting = -1;                    // index into Layout::mountings(), -1 = none
  double lag_fixed_ms = 0;              // value used when the lag is fixed (and start value)
  std::array<double, 2> lag_bounds_ms{-20, 20};
  double depth_bound_mm = 0;            // |offset| ≤ this
};

// A sample mounting registered by fiducials: its recordings share one pose correction
// (3 small rotations about the fiducials' centroid, 3 translations; volume frame) whose
// Gaussian prior is the fiducial fit's covariance (docs/calibration.md "Registration").
struct Mounting {
  std::string name;                  // the sample id (and the fiducial set) it stands for
  int offset = -1;                   // first of its 6 entries in x
  glm::dvec3 centre_vol_mm{0};       // rotation centre: the fiducials' centroid
  std::array<double, 36> sqrt_information{};  // L (row-major, upper), LᵀL = prior information
};

// The measured channels a fit uses besides the force ([fit] channels).
struct Channels {
  bool torque = false, spindle = false;
  int rows_per_sample() const { return 3 + (torque ? 3 : 0) + (spindle ? 1 : 0); }
};

// Every parameter of one calibration and its place in the free vector x.
class Layout {
 public:
  // `classes`: label → (name, spec) for every class present in the samples.
  // `depth_bound_mm`: bound on |depth offset| (used when the manifest frees it).
  Layout(const std::vector<std::pair<std::uint8_t, std::pair<std::string,
                                                              data_schema::ClassFitSpec>>>& classes,
         const std::vector<std::pair<std::string, double>>& recordings_lag_ms,
         const data_schema::NuisanceSpec& nuisance, double depth_bound_mm, Channels channels = {});
  const Channels& channels() const { return channels_; }

  const std::vector<PhysicsParam>& physics() const { return physics_; }
  // The physics parameter at x entry `entry` (nullptr: a nuisance).
  const PhysicsParam* physics_at(std::size_t entry) const;
  const std::vector<RecordingNuisance>& recordings() const { return recordings_; }
  std::size_t size() const { return n_; }  // free values
  std::vector<std::uint8_t> labels() const;

  // Adds a mounting's pose block (6 entries, start 0, bounds ±0.05 rad / ±1 mm) shared by
  // the given recordings (indices into recordings()).
  void add_mounting(Mounting m, const std::vector<std::size_t>& recordings);
  const std::vector<Mounting>& mountings() const { return mountings_; }
  // Frees the depth offset of recording `recording` (an index into recordings(), whose
  // depth is fixed) as a new last entry of x, start 0, bounds ±depth_bound_mm. x's other
  // entries keep their places, so a point of this layout extends by one value.
  void add_depth_offset(std::size_t recording);

  std::vector<double> initial() const;     // start values of x (scaled)
  double lower(std::size_t i) const { return lower_[i]; }
  double upper(std::size_t i) const { return upper_[i]; }
  PhysicsValues physics_values(const double* x) const;  // natural units
  // Free-vector names: "compact.alpha", "plunge.bias_x", "plunge.lag", ...
  const std::string& name(std::size_t i) const { return names_[i]; }
  // Scaled → natural and the derivative d natural / d scaled (for the delta method).
  double natural(std::size_t i, double x) const;
  double dnatural(std::size_t i, double x) const;
  bool is_log(std::size_t i) const { return log_[i]; }
  // Block sizes in x order (1 each, 3 for a bias, 2 for the spindle's idle terms).
  struct Block { std::size_t offset, size; };
  const std::vector<Block>& blocks() const { return blocks_; }

 private:
  std::vector<PhysicsParam> physics_;
  std::vector<RecordingNuisance> recordings_;
  std::vector<Mounting> mountings_;
  Channels channels_;
  std::size_t n_ = 0;
  std::vector<double> init_, lower_, upper_;
  std::vector<bool> log_;
  std::vector<std::string> names_;
  std::vector<Block> blocks_;
};

// A bounded nuisance that ended at a bound: a recording's lag or depth offset, or a
// mounting's pose correction. The data want a value beyond it, so the force was fitted
// against a path held off by the rest and the constants can miss the truth by more than
// their intervals say (those hold the nuisance at its bound). docs/calibration.md "A
// nuisance at its bound".
struct NuisanceAtBound {
  std::size_t index = 0;  // in x
  bool upper = false;
  std::string text;       // the warning line
};
inline constexpr double kNuisanceBoundShare = 1e-3;  // of its range: closer is at the bound
std::vector<NuisanceAtBound> nuisances_at_bounds(const Layout& L, const std::vector<double>& x);

}  // namespace burrbench::calibration
