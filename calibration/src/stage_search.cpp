// Stages "difference steps", "global search" and "refine".
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/calibration/steps.hpp"
#include "burrbench/data_schema/error.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {

void choose_steps(Run& run) {
  if (run.opt.derivatives != Derivatives::kFiniteDifferences) return;
  run.stage("steps", "difference steps from cost sweeps at the start");
  const Layout& L = *run.layout;
  const Objective& obj = *run.obj;
  // Swept at the manifest's start after its cheap pre-fit (C1, μ, bias at held geometry).
  std::vector<double> x = L.initial();
  {
    const auto r = obj.prefit(x, run.w_all, {});
    if (r.usable) x = r.x;
  }
  auto record = [&](const StepSweep& s) {
    run.sweeps.push_back({{"parameter", s.name}, {"h", s.h}, {"curvature", s.curvature}, {"chosen", s.chosen}});
  };
  std::vector<std::size_t> lag_idx, depth_idx;
  for (const auto& r : L.recordings()) {
    if (r.lag >= 0) lag_idx.push_back(std::size_t(r.lag));
    if (r.depth >= 0) depth_idx.push_back(std::size_t(r.depth));
  }
  // α per class; a class whose cost does not curve keeps the default 0.1.
  for (const auto& p : L.physics())
    if (p.index >= 0 && p.kind == PhysKind::kAlpha) {
      auto s = sweep_step(obj, x, run.w_all, std::size_t(p.index), {0.4, 0.2, 0.1, 0.05}, -1);
      record(s);
      if (s.curvature.front() > 0) run.steps.log_alpha[p.label] = s.chosen;
    }
  if (!lag_idx.empty()) {
    auto s = sweep_step(obj, x, run.w_all, lag_idx[0], {2.0, 1.0, 0.5, 0.25}, 0);
    record(s);
    run.steps.lag_ms = s.chosen;
  }
  if (!depth_idx.empty()) {
    const double l = run.used_samples.begin()->second->voxel_mm;
    auto s = sweep_step(obj, x, run.w_all, depth_idx[0], {0.5 * l, 0.25 * l, 0.125 * l, 0.0625 * l}, 0);
    record(s);
    run.steps.depth_mm = s.chosen;
  }
  for (auto& m : run.owned) m->set_steps(run.steps);
}

namespace {

// The class stages of the global search (docs/calibration.md "Global search", "Starts
// staged by class"). The joint hypercube varies every class's constants at once, and the
// pre-fit screening ranks a start by its total cost: a start good in one class and poor in
// another is screened out, and the few solved starts can all share one wrong basin of a
// class (the session's plunges: 3 of 10 seeds, trabecular α +134 %). When the joint search's
// best end misfits — rms(residual/σ) above kLoneFindRms, where another optimum may fit far
// better — each class in turn gets a search of its own: its constants from a Latin
// hypercube, every other value from the best end so far. Its ends join the joint search's.
void search_by_class(Run& run, const MultistartOptions& mo, double residuals) {
  const Layout& L = *run.layout;
  std::vector<std::uint8_t> classes;  // with a free constant, in the layout's order
  for (const auto& p : L.physics())
    if (p.index >= 0 && std::find(classes.begin(), classes.end(), p.label) == classes.end())
      classes.push_back(p.label);
  if (classes.size() < 2 || run.search.ends.size() < 2 || !(residuals > 0)) return;
  const auto rms = [&] { return std::sqrt(2 * run.search.ends.front().cost / residuals); };
  if (!(rms() > kLoneFindRms)) return;
  const int n = run.starts;  // per class, as many as the joint search had
  for (const std::uint8_t label : classes) {
    const std::vector<double> best = run.search.ends.front().end;
    if (!(rms() > kLoneFindRms)) break;  // an earlier class's search reached the noise
    // The hypercube over every constant, of which only this class's are taken: still one
    // stratum per start in each of them. The best end itself is not a start again.
    const auto lhs = latin_hypercube_starts(L, best, n, run.exp.manifest.fit.seed + label);
    std::vector<std::vector<double>> points;
    for (std::size_t s = 1; s < lhs.size(); ++s) {
      std::vector<double> q = best;
      for (const auto& p : L.physics())
        if (p.index >= 0 && p.label == label) q[std::size_t(p.index)] = lhs[s][std::size_t(p.index)];
      points.push_back(std::move(q));
    }
    run.stage("global search", fmt::format("best end at rms(residual/σ) {:.3f} (> {:.2g}): {} starts for the "
                                           "constants of class {}, the others at the best end",
                                           rms(), kLoneFindRms, points.size(), run.present.at(label)));
    MultistartOutcome more = multistart(*run.obj, points, run.w_all, mo, 0.0);
    const int offset = int(run.search.ends.size());
    for (auto& e : more.ends) {
      e.index += offset;
      run.search.ends.push_back(std::move(e));
    }
    run.search.solved += more.solved;
    run.starts += int(points.size());
    sort_ends(run.search.ends);
  }
}

}  // namespace

void global_search(Run& run) {
  const Layout& L = *run.layout;
  const bool any_free = std::any_of(L.physics().begin(), L.physics().end(),
                                    [](const PhysicsParam& p) { return p.index >= 0; });
  run.starts = run.opt.starts > 0 ? run.opt.starts : run.exp.manifest.fit.multistart;
  if (!any_free) run.starts = 1;
  const auto points = latin_hypercube_starts(L, L.initial(), run.starts, run.exp.manifest.fit.seed);
  run.stage("global search", fmt::format("{} starts (Latin hypercube in ln θ)", points.size()));
  MultistartOptions mo;
  mo.iterations = run.opt.start_iterations;
  mo.solved = run.opt.solve_starts;
  mo.concurrent = run.opt.threads;
  mo.progress = run.opt.progress;
  // A start's solve may stop once an iteration gains less than a tenth of the profile
  // threshold (χ²₁(0.95)/2 at unit residual variance) relative to the cost expected at
  // the optimum (half the used residuals): "reached by k of N" counts ends within the
  // threshold, and the refinement polishes the best one. A lone start is the fit itself:
  // stopping it early only hands the same iterations to the refinement.
  double residuals = 0;
  for (const auto& rec : run.w_all)
    residuals += double(std::count_if(rec.begin(), rec.end(), [](double w) { return w > 0; }));
  residuals *= double(L.channels().rows_per_sample());
  if (residuals > 0 && points.size() > 1)
    mo.function_tolerance = std::max(mo.function_tolerance, 0.1 * (0.5 * kChi2_1_95) / (0.5 * residuals));
  run.search_function_tolerance = mo.function_tolerance;
  // The constants' basin first, at the registration as given: a pose correction free in
  // the starts' short solves absorbs what wrong constants misfit (tens of µm against a
  // 5 µm prior) and leads them into basins of their own. The refinement frees it.
  if (!L.mountings().empty()) {
    mo.hold.assign(L.size(), false);
    for (const auto& m : L.mountings())
      for (int k = 0; k < 6; ++k) mo.hold[std::size_t(m.offset + k)] = true;
  }
  run.search = multistart(*run.obj, points, run.w_all, mo, 0.0);
  if (run.search.ends.empty() || !run.search.ends.front().usable)
    throw InputError(run.mfile, "fit", "a start from which the solver can evaluate the cost",
                     "every start failed");
  search_by_class(run, mo, residuals);
}

void refine(Run& run) {
  run.stage("refine", "the best point so far to convergence");
  SolveOptions so;
  so.max_iterations = run.opt.max_iterations;
  so.progress = run.opt.progress;
  so.threads = run.opt.threads;
  const std::vector<double> from = run.x.empty() ? run.search.ends.front().end : run.x;
  auto fit = run.obj->solve(from, run.w_all, so);
  // A second pass with a fresh trust region: the first can stop early in the long α–μ
  // valley once its region has shrunk. When the first took no step, it ended where it
  // began, with the same fresh region: the second would only repeat it.
  if (fit.steps_taken > 0) {
    SolveOptions again = so;
    again.max_iterations = std::max(5, run.opt.max_iterations / 3);
    auto second = run.obj->solve(fit.x, run.w_all, again);
    if (second.usable && second.final_cost <= fit.final_cost) {
      second.initial_cost = fit.initial_cost;
      second.iterations += fit.iterations;
      second.steps_taken += fit.steps_taken;
      fit = second;
    }
  }
  run.fit = fit;
  run.x = fit.x;
}

}  // namespace burrbench::calibration::detail
