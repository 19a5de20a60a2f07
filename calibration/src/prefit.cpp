// Objective::prefit: the cheap fixed-geometry pre-fit that warms (and screens) every start.
//
// At held lag, depth and pose, a replay's geometry depends on the constants only through
// the erosion rate μ·C1/α of each class. Holding that geometry makes the prediction exact
// and cheap in C1, μ and the linear nuisances (FixedGeometryModel): the pre-fit solves
// there to convergence, moves each α with its class's C1·μ so that the geometry stays
// (follow_geometry), and replays once to confirm: two or three replays per recording
// instead of one per Levenberg–Marquardt trial point (14 on the reference experiment).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "burrbench/calibration/objective.hpp"
#include "burrbench/calibration/fixed_geometry_model.hpp"

namespace burrbench::calibration {
namespace {

// `to` with each free α_k moved along with C1_k·μ_k from `from`. A voxel of class k loses
// bone at a rate ∝ μ_k·|F_e|/α_k (MODEL.md "Erosion"), so with one class in contact the
// replay's geometry at `to` is exactly that at `from`, and the held-geometry prediction
// exact there; where classes share the contact, |F_e| mixes their C1's and it is close.
std::vector<double> follow_geometry(const Layout& L, const std::vector<double>& from,
                                    std::vector<double> to) {
  const PhysicsValues a = L.physics_values(from.data()), b = L.physics_values(to.data());
  for (const auto& p : L.physics()) {
    if (p.index < 0 || p.kind != PhysKind::kAlpha) continue;
    const std::size_t i = std::size_t(p.index), k = p.label;
    const double ratio = (b.c1[k] * b.mu[k]) / (a.c1[k] * a.mu[k]);
    if (!(ratio > 0) || !std::isfinite(ratio)) continue;
    to[i] = L.is_log(i) ? to[i] + std::log(ratio) : to[i] * ratio;
    to[i] = std::clamp(to[i], L.lower(i), L.upper(i));
  }
  return to;
}

}  // namespace

SolveOutcome Objective::prefit(const std::vector<double>& x0, const SampleWeights& w,
                               const PrefitOptions& options) const {
  const auto t0 = std::chrono::steady_clock::now();
  const Layout& L = layout_;
  // What moves the geometry is held: α, lag, depth offset and pose.
  std::vector<bool> hold(L.size(), false);
  for (const auto& p : L.physics())
    if (p.index >= 0 && p.kind == PhysKind::kAlpha) hold[std::size_t(p.index)] = true;
  for (const auto& r : L.recordings()) {
    if (r.lag >= 0) hold[std::size_t(r.lag)] = true;
    if (r.spindle_lag >= 0) hold[std::size_t(r.spindle_lag)] = true;
    if (r.depth >= 0) hold[std::size_t(r.depth)] = true;
    if (r.pose >= 0)
      for (int k = 0; k < 6; ++k) hold[std::size_t(r.pose + k)] = true;
  }
  SolveOutcome out;
  std::vector<double> x = inside_bounds(x0);
  out.x = x;
  out.final_cost = std::numeric_limits<double>::infinity();
  int replays = 0;
  for (;;) {
    std::vector<Prediction> at_x = predict_all(x, -1, false);
    ++replays;
    bool fixed = true;
    for (const auto& p : at_x) fixed = fixed && p.fixed != nullptr;
    if (!fixed) {  // no geometry to hold: every trial point replayed
      SolveOptions pre;
      pre.max_iterations = options.fallback_iterations;
      pre.geometry_terms = false;
      pre.threads = options.threads;
      pre.hold = hold;
      return solve(x0, w, pre);
    }
    std::vector<FixedGeometryModel> held;
    held.reserve(at_x.size());
    for (std::size_t r = 0; r < at_x.size(); ++r) held.emplace_back(*models_[r], std::move(at_x[r]));
    std::vector<const RecordingModel*> ptrs;
    for (const auto& m : held) ptrs.push_back(&m);
    const Objective at_geometry(L, ptrs, settings_);
    // Exact at x itself: the replayed cost.
    const double cost = at_geometry.evaluate(x, w).cost;
    if (replays == 1) out.initial_cost = cost;
    // The geometry moved enough to lose the gain (both classes sharing the contact, or an
    // α stopped at its bound by follow_geometry): keep the point before.
    if (!(cost < out.final_cost)) {
      out.termination = fmt::format("pre-fit: {} replays; the last did not lower the cost", replays);
      break;
    }
    out.x = x;
    out.final_cost = cost;
    out.usable = true;
    if (replays >= options.replays) {
      out.termination = fmt::format("pre-fit: {} replays (the most allowed)", replays);
      break;
    }
    SolveOptions so;
    so.max_iterations = 50;
    so.threads = 1;  // milliseconds per evaluation and no replay: not worth a thread
    so.hold = hold;
    so.geometry_terms = false;
    so.normal_equations = true;
    const SolveOutcome r = at_geometry.solve(x, w, so);
    out.iterations += r.iterations;
    // Nothing left to gain at this geometry (the step would not pay for its replay).
    if (!r.usable || !(r.final_cost < cost * (1 - 1e-4))) {
      out.termination = fmt::format("pre-fit: {} replays; converged at held geometry", replays);
      break;
    }
    x = follow_geometry(L, x, r.x);
  }
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace burrbench::calibration
