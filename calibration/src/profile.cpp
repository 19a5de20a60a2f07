#include "burrbench/calibration/profile.hpp"

#include <algorithm>
#include <cmath>

namespace burrbench::calibration {
namespace {

// Walks one side (sign ±1). The step grows from the predicted crossing of a quadratic
// profile, so a well-determined parameter closes in two or three points.
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
  std::vector<double> x = x_hat;
  double h = std::clamp(opt.first_step, 0.005, 1.0), h_prev = 0, d_prev = 0;
  const double lower_tol = std::max(0.05 * threshold, 1e-9 * std::abs(cost_hat));
  for (int k = 0; k < opt.max_points; ++k) {
    bool last = false;
    if (h >= room) {
      h = room;
      last = true;
    }
    x[i] = x_hat[i] + sign * h;
    SolveOptions so;
    so.max_iterations = opt.iterations;
    so.threads = 1;
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
    }
    if (d >= threshold) {
      // Crossing between the previous point and this one; √Δ is ~linear in the step for a
      // quadratic profile, so interpolate in √Δ.
      const double s0 = std::sqrt(std::max(0.0, d_prev)), s1 = std::sqrt(d), st = std::sqrt(threshold);
      const double f = s1 > s0 ? (st - s0) / (s1 - s0) : 1.0;
      side.closed = true;
      side.crossing = x_hat[i] + sign * (h_prev + std::clamp(f, 0.0, 1.0) * (h - h_prev));
      return side;
    }
    if (last) {
      side.at_bound = true;
      return side;
    }
    x = at;  // warm start for the next point
    const double grow = d > 0 ? 1.1 * std::sqrt(threshold / d) : 4.0;
    h_prev = h;
    d_prev = std::max(0.0, d);
    h *= std::clamp(grow, 1.3, 4.0);
  }
  return side;  // not closed within max_points: open
}

}  // namespace

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
