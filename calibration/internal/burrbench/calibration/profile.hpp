#pragma once
// Profile likelihood of one physics parameter (docs/calibration.md "Profiles"): ln θ is
// stepped away from the optimum on each side and every other free parameter re-optimised,
// until the cost has risen by the threshold (χ²₁(0.95)/2 × residual variance, in cost
// units) or the bound is reached. The crossing gives the interval, which may be open on
// one or both sides; the shape gives the verdict.
#include <atomic>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include "burrbench/calibration/objective.hpp"

namespace burrbench::calibration {

inline constexpr double kChi2_1_95 = 3.841458820694124;  // χ²₁ 95 % quantile

struct ProfilePoint {
  double x = 0;           // ln θ
  double delta_cost = 0;  // cost − cost at the optimum (cost units)
  std::vector<double> at; // the re-optimised parameters there
};

struct ProfileSide {
  std::vector<ProfilePoint> points;  // moving away from the optimum
  bool closed = false;               // the cost crossed the threshold
  bool at_bound = false;             // stopped at the parameter's bound without crossing
  double crossing = 0;               // ln θ of the crossing (closed only)
};

struct Profile {
  std::size_t entry = 0;
  double x_hat = 0, threshold = 0;
  ProfileSide lower, upper;
  // A point cheaper than the optimum by more than `lower_tolerance`: the fit stopped in a
  // local minimum; `lower_at` is where to restart.
  bool found_lower = false;
  std::vector<double> lower_at;
  double lower_cost = 0;
};

struct ProfileOptions {
  int iterations = 10;  // re-optimisation per point (stops earlier on convergence) (warm-started from the previous point)
  int max_points = 8;   // per side
  double first_step = 0.1;  // ln θ; the caller passes ≈ 1.96 × the covariance SE
  // Per x entry: the valley's slope dx_j/dx_entry at the optimum (the covariance's column
  // of `entry` over its variance; empty = none). Each point's re-optimisation starts on
  // that line, so the correlated parameters (C1 with α, lag with α, …) start where the
  // linearised profile puts them instead of where the previous point left them.
  std::vector<double> valley;
  int threads = 1;  // Ceres threads per re-optimisation (see SolveOptions::threads)
  // Shared by the profiles of one fit (null: none). A walk that finds a point cheaper
  // than the optimum (Profile::found_lower) sets it, and every walk sharing it stops at
  // its next point: the caller refits from that point and profiles again, so the rest of
  // these profiles would be thrown away. Leave it null when no refit follows.
  std::atomic<bool>* cheaper_found = nullptr;
};

// How a profile point is re-optimised (iterations, threads, tolerance in the threshold's
// unit); `hold` is left to the caller. Also the solve of the texture probes
// (docs/calibration.md "Profiles on a textured cost"), which must stop as a point does.
SolveOptions profile_point_solve(const ProfileOptions& opt, double threshold, double cost_hat);

// The cost's texture at an optimum (docs/calibration.md "Profiles on a textured cost"):
// refits from its 95 % ellipsoid, stopped as a profile point stops. The median excess is
// the allowance added to the profile threshold.
inline constexpr std::size_t kTextureProbes = 4;
struct TextureProbe {
  std::vector<std::vector<double>> starts;  // where each probe started
  std::vector<double> excess;       // each probe's end cost − the optimum's (∞: failed)
  double allowance = 0;             // median of the excesses (negatives as 0)
  std::vector<double> cheapest_at;  // the cheapest end and its cost
  double cheapest_cost = INFINITY;
};
// `cov`: the covariance at x_hat with `held` held (no probe without it); `threshold`: the
// χ² threshold, which sets the probes' tolerance as it does a point's.
TextureProbe probe_texture(const Objective& obj, const std::vector<double>& x_hat, double cost_hat,
                           const SampleWeights& w, const std::vector<bool>& held, const CovarianceOutcome& cov,
                           double threshold, int threads);

// `cost_hat`: the cost at x_hat; `hold`: entries held during the re-optimisations besides
// `entry` (e.g. parameters already known to be non-identifiable). Thread-safe for
// concurrent calls on one Objective.
Profile profile_parameter(const Objective& obj, const std::vector<double>& x_hat, double cost_hat,
                          const SampleWeights& w, std::size_t entry, double threshold,
                          const std::vector<bool>& hold, const ProfileOptions& opt);

}  // namespace burrbench::calibration
