#include "burrbench/calibration/profile.hpp"

#include <algorithm>
#include <cmath>

namespace burrbench::calibration {
namespace {

// Walks one side (sign ±1). The step grows from the predicted crossing of a quadratic
// profile, so a well-determined parameter closes in one or two points; a step that
// overshoots the threshold by more than 4× is bisected (in √Δ) before the crossing is
// interpolated, since a profile is quadratic only near its minimum. A point just inside
// (Δ ≥ 0.9 × threshold, before any point beyond) closes the side by extrapolating √Δ
// linearly from the last point inside: at most 5.4 % further than that point.
constexpr double kNearThreshold = 0.9;
ProfileSide walk(const Objective& obj, const std::vector<double>& x_hat, double cost_hat,
                 const SampleWeights& w, std::size_t i, double threshold, double sign,
                 const std::vector<bool>& hold_in, const ProfileOptions& opt, Profile& prof) {
  const Layout& L = obj.layout();
  ProfileSide side;
  const double bound = sign > 0 ? L.upper(i) : L.lower(i);
  const double room = std::abs(bound - x_hat[i]);
  std::vector<bool> hold = hold_in;
  if (hold.empty()) hold.assign(L.size(), false);
  hold[i] = true;
  // Cheaper by less than a quarter of the threshold is the same optimum for every verdict
  // (flat valleys wobble by that much); more than that restarts the fit from there.
  const double lower_tol = std::max(0.25 * threshold, 1e-9 * std::abs(cost_hat));
  // Bracket: [h_in, Δ_in] below the threshold (starts at the optimum), [h_out, Δ_out] above.
  double h_in = 0, d_in = 0, h_out = -1, d_out = 0;
  std::vector<double> x_in = x_hat;
  auto crossing = [&] {
    const double s0 = std::sqrt(std::max(0.0, d_in)), s1 = std::sqrt(d_out), st = std::sqrt(threshold);
    const double f = s1 > s0 ? std::clamp((st - s0) / (s1 - s0), 0.0, 1.0) : 1.0;
    return h_in + f * (h_out - h_in);
  };
  double h = std::clamp(opt.first_step, 0.001, 1.0);
  for (int k = 0; k < opt.max_points; ++k) {
    if (opt.cheaper_found && opt.cheaper_found->load()) return side;  // a refit follows
    bool last = false;
    if (h >= room) {
      h = room;
      last = true;
    }
    // Warm start from the last point inside the threshold, moved along the valley.
    std::vector<double> x = x_in;
    const double move = x_hat[i] + sign * h - x_in[i];
    if (opt.valley.size() == x.size())
      for (std::size_t j = 0; j < x.size(); ++j)
        if (j != i && !hold[j] && opt.valley[j] != 0)
          x[j] = std::clamp(x[j] + opt.valley[j] * move, L.lower(j), L.upper(j));
    x[i] = x_hat[i] + sign * h;
    SolveOptions so = profile_point_solve(opt, threshold, cost_hat);
    so.hold = hold;
    // (The solver keeps its start within 1e-6 of the range inside the bounds, so a point on
    // the bound is profiled a hair inside it.)
    const SolveOutcome r = obj.solve(x, w, so);
    const std::vector<double> at = r.usable ? r.x : x;
    const double d = (r.usable ? r.final_cost : INFINITY) - cost_hat;
    side.points.push_back({x[i], d, at});
    if (d < -lower_tol && (!prof.found_lower || cost_hat + d < prof.lower_cost)) {
      prof.found_lower = true;
      prof.lower_at = at;
      prof.lower_cost = cost_hat + d;
      if (opt.cheaper_found) *opt.cheaper_found = true;
    }
    if (d >= threshold) {
      h_out = h;
      d_out = d;
      if (d_out <= 4 * threshold) break;
      h = crossing();  // overshoot: look closer to the predicted crossing
      continue;
    }
    if (h_out < 0 && !last && d >= kNearThreshold * threshold) {
      const double s0 = std::sqrt(std::max(0.0, d_in)), s1 = std::sqrt(d), st = std::sqrt(threshold);
      const double f = s1 > s0 ? (st - s0) / (s1 - s0) : 1.0;
      side.closed = true;
      side.crossing = x_hat[i] + sign * (h_in + f * (h - h_in));
      return side;
    }
    h_in = h;
    d_in = std::max(0.0, d);
    x_in = at;
    if (h_out > 0) {  // bracketed
      if (d_out <= 4 * threshold || d_in >= 0.25 * threshold) break;
      h = crossing();
      continue;
    }
    if (last) {
      side.at_bound = true;
      return side;
    }
    const double grow = d > 0 ? 1.1 * std::sqrt(threshold / d) : 4.0;
    h *= std::clamp(grow, 1.3, 4.0);
  }
  if (h_out > 0) {
    side.closed = true;
    side.crossing = x_hat[i] + sign * crossing();
  }
  return side;  // not closed within max_points: open
}

}  // namespace

SolveOptions profile_point_solve(const ProfileOptions& opt, double threshold, double cost_hat) {
  SolveOptions so;
  so.max_iterations = opt.iterations;
  so.threads = opt.threads;
  // A point's cost matters to about 1 % of the threshold (the crossing is interpolated
  // between points), not to the 1e-7 relative of a fit. Tighter costs wall time and does
  // not remove the texture (docs/calibration.md "Profiles on a textured cost").
  so.function_tolerance = std::max(so.function_tolerance, 0.01 * threshold / std::max(1.0, std::abs(cost_hat)));
  return so;
}

Profile profile_parameter(const Objective& obj, const std::vector<double>& x_hat, double cost_hat,
                          const SampleWeights& w, std::size_t entry, double threshold,
                          const std::vector<bool>& hold, const ProfileOptions& opt) {
  Profile p;
  p.entry = entry;
  p.x_hat = x_hat[entry];
  p.threshold = threshold;
  p.lower = walk(obj, x_hat, cost_hat, w, entry, threshold, -1.0, hold, opt, p);
  p.upper = walk(obj, x_hat, cost_hat, w, entry, threshold, +1.0, hold, opt, p);
  return p;
}

}  // namespace burrbench::calibration
