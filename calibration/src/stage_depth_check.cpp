// Stage "depth check": a registration given as exact, or a burr whose radius is not
// [burr] radius_mm, puts the burr a few µm off in depth, and the contact force is stiff in
// depth (docs/calibration.md "Registration is a measurement"). The constants then bend to
// it with intervals that hold only for a depth known exactly. So, for the calibrating
// recordings whose depth nothing corrects (no depth offset fitted, no pose correction), the
// fit is repeated from the optimum with a depth offset free for each. The line is said when
// both hold:
//  - the cost falls by more than ½·χ²_k(0.999) in the profile's units (residual variance ×
//    the noise model's inflation; k offsets): the data want an offset (a likelihood ratio),
//  - and a constant that was called identifiable moves outside its 95 % interval.
// Either alone is not enough: with no offset in the data the refit still moves each
// constant by its correlation with the offset, and a significant offset that moves no
// constant beyond its interval changes nothing a user reads.
#include <algorithm>
#include <cmath>

#include <boost/math/distributions/chi_squared.hpp>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "pipeline.hpp"

namespace burrbench::calibration::detail {

void depth_check(Run& run) {
  if (!run.opt.depth_check) return;
  const Layout& L = *run.layout;
  std::vector<std::size_t> targets;
  std::vector<std::string> ids;
  for (std::size_t q = 0; q < L.recordings().size(); ++q)
    if (L.recordings()[q].depth < 0 && L.recordings()[q].pose < 0) {
      targets.push_back(q);
      ids.push_back(L.recordings()[q].recording_id);
    }
  if (targets.empty()) return;
  run.stage("depth check", fmt::format("refitting with a depth offset free for {}", fmt::join(ids, ", ")));
  Layout freed = L;
  std::vector<double> x0 = run.x;
  for (std::size_t q : targets) {
    freed.add_depth_offset(q);
    x0.push_back(0.0);
  }
  const double k = double(targets.size());
  const double unit = run.residual_scale;  // residual variance × inflation, as the profile threshold
  const double threshold = 0.5 * boost::math::quantile(boost::math::chi_squared(k), 0.999) * unit;
  const Objective obj(freed, run.models, run.settings);
  SolveOptions so;
  // The check needs the cost to a tenth of its threshold, not to Ceres's 10⁻⁷ of the cost:
  // on the reference experiment, with no offset in the data, the solve ends after 2
  // iterations instead of 11.
  so.function_tolerance = std::max(so.function_tolerance, 0.1 * threshold / std::max(run.ev.cost, 1e-300));
  so.max_iterations = run.opt.max_iterations;
  so.threads = run.opt.threads;
  so.progress = run.opt.progress;
  so.hold = run.unc.held;
  so.hold.resize(freed.size(), false);
  const SolveOutcome fit = obj.solve(x0, run.w_all, so);
  run.replays_before += obj.replays();

  auto& dc = run.depth;
  dc = nlohmann::json::object();
  dc["recordings"] = ids;
  dc["said"] = false;
  dc["refit_termination"] = fit.termination;
  dc["refit_iterations"] = fit.iterations;
  if (!fit.usable) {
    run.warnings.push_back("depth check: the refit with a depth offset free failed; nothing is said of the depth");
    return;
  }
  const double drop = run.ev.cost - fit.final_cost;
  nlohmann::json offsets = nlohmann::json::object();
  std::vector<std::string> offset_text;
  for (std::size_t q : targets) {
    const double d = fit.x[std::size_t(freed.recordings()[q].depth)];
    offsets[L.recordings()[q].recording_id] = d;
    offset_text.push_back(fmt::format("{:+.3f}", d));
  }
  dc["offsets_mm"] = offsets;
  dc["cost"] = run.ev.cost;
  dc["refit_cost"] = fit.final_cost;
  dc["threshold_cost"] = threshold;
  dc["significant"] = drop > threshold;

  // Constants called identifiable that the refit moves outside their 95 % intervals
  // (profile where closed, else covariance).
  std::vector<std::string> moved;
  nlohmann::json moved_json = nlohmann::json::array();
  for (const auto& fp : run.out.parameters) {
    const PhysicsParam* p = physics_of(L, fp);
    if (!p || p->index < 0 || fp.fixed || !fp.identifiable) continue;
    const auto [lo, hi] = check_interval(fp);
    const double e = std::exp(fit.x[std::size_t(p->index)]);
    if (!(e < lo || e > hi)) continue;
    moved.push_back(fmt::format("{} {} {:.4g} → {:.4g}{} (95 % {:.4g}–{:.4g})", fp.class_name, fp.name, fp.estimate, e,
                                data_schema::unit_suffix(fp.unit), lo, hi));
    moved_json.push_back({{"class", fp.class_name}, {"name", fp.name}, {"estimate", fp.estimate},
                          {"refit_estimate", e}, {"ci95_low", lo}, {"ci95_high", hi}});
  }
  dc["moved"] = moved_json;
  if (drop <= threshold || moved.empty()) return;
  const double n = double(run.ev.residuals_used);
  run.warnings.push_back(fmt::format(
      "depth check: a depth offset along the shaft fitted to {} ({} mm) lowers the cost by {:.4g} (rms(residual/σ) "
      "{:.3f} → {:.3f}; significant, p < 0.001) and moves {}, outside the intervals, which hold only for a depth "
      "known exactly. A registration given as exact that is off in depth, or a burr whose radius is not "
      "[burr] radius_mm ({:.4g} mm), reads so: measure the burr, check the registration, or set "
      "[fit.nuisance] depth_offset = true",
      fmt::join(ids, ", "), fmt::join(offset_text, ", "), drop, std::sqrt(2 * run.ev.cost / n),
      std::sqrt(2 * std::max(fit.final_cost, 0.0) / n), fmt::join(moved, ", "), run.exp.manifest.burr.radius_mm));
  dc["said"] = true;
}

}  // namespace burrbench::calibration::detail
