// The coarse level (samples with voxels merged by 2) and its two uses:
//  - stage "coarse search" (coarse-to-fine): the global search and the refinement run at
//    2l, where a replay is several times cheaper; the fine level starts from there.
//  - stage "discretization": the fit is repeated from the optimum at 2l (same data,
//    weights, nuisances and held parameters); |ln θ_2l − ln θ_l| is the first-order
//    (Richardson, p = 1) estimate of the discretization error of ln θ at the fit's voxel
//    size l. A constant whose error exceeds half its 95 % interval is "limited by
//    discretization error", and its interval is widened by it.
// docs/calibration.md, "Discretization check" and "Coarse to fine".
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {

CoarseLevel& coarse_level(Run& run) {
  if (run.coarse) return *run.coarse;
  auto c = std::make_unique<CoarseLevel>();
  for (const auto& [id, s] : run.used_samples) {
    c->samples.emplace(id, ds::import::merge_voxels(*s, 2));
    c->fine_voxel_mm = std::max(c->fine_voxel_mm, s->voxel_mm);
  }
  c->voxel_mm = 2 * c->fine_voxel_mm;
  c->pool = std::make_unique<ReplayPool>(c->samples, run.opt.threads);
  std::vector<const RecordingModel*> models;
  for (const auto* r : run.recs) {
    c->owned.push_back(make_model(run, *r, *c->pool));
    models.push_back(c->owned.back().get());
  }
  c->obj = std::make_unique<Objective>(*run.layout, models, run.settings);
  run.coarse = std::move(c);
  return *run.coarse;
}

void coarse_search(Run& run) {
  if (!run.opt.coarse_to_fine) return;
  CoarseLevel& c = coarse_level(run);
  run.stage("coarse to fine", fmt::format("global search at voxel {:.4g} mm", c.voxel_mm));
  const auto before = c.obj->replays();
  std::swap(run.obj, c.obj);  // the search stages use run.obj
  try {
    global_search(run);
    refine(run);
  } catch (...) {
    std::swap(run.obj, c.obj);
    throw;
  }
  std::swap(run.obj, c.obj);
  run.replays_before += c.obj->replays() - before;
  run.coarse_cost = run.fit.final_cost;
  const std::vector<double> x_coarse = run.x;
  run.stage("coarse to fine", fmt::format("refining at voxel {:.4g} mm", c.fine_voxel_mm));
  refine(run);
  // The search's ends were scored at 2l: move them by the best start's shift so that
  // "reached by k of N" and the check of equally good ends compare like with like.
  for (auto& e : run.search.ends) {
    if (!e.usable) continue;
    for (std::size_t i = 0; i < e.end.size(); ++i) e.end[i] += run.x[i] - x_coarse[i];
    e.cost += run.fit.final_cost - run.coarse_cost;
  }
}

void discretization_check(Run& run) {
  if (!run.opt.discretization_check) return;
  const Layout& L = *run.layout;
  CoarseLevel& c = coarse_level(run);
  run.stage("discretization check", fmt::format("refitting at voxel {:.4g} mm", c.voxel_mm));
  SolveOptions so;
  so.max_iterations = run.opt.max_iterations;
  so.threads = run.opt.threads;
  so.progress = run.opt.progress;
  so.hold = run.unc.held;
  // Unconfirmed constants are held in params.toml, not in this refit: the grid may be why.
  for (std::size_t i = 0; i < so.hold.size() && i < run.verdict.size(); ++i)
    if (run.verdict[i] == "unconfirmed") so.hold[i] = false;
  // The coarse cost is textured at the voxel scale, so near its optimum many steps are
  // rejected; each costs only a plain coarse replay (objective.cpp, the line search's
  // interpolation), so the refit runs to convergence: a rule that stopped it after a few
  // rejections in a row could stop it short, understating the discretization error.
  const auto before = c.obj->replays();
  const SolveOutcome fit = c.obj->solve(run.x, run.w_all, so);
  run.replays_before += c.obj->replays() - before;
  run.coarse_voxel_mm = c.voxel_mm;
  run.coarse_termination = fit.termination;
  run.coarse_iterations = fit.iterations;
  if (!fit.usable) {
    run.warnings.push_back("discretization check: the refit on the coarse sample failed; no "
                           "discretization error is given");
    return;
  }
  // Is the grid what limits the constants? Discretization error at l shows as a misfit
  // at l above the noise that changes at 2l: it grows where the bone is finer than both
  // grids, and falls where the data resemble the coarse grid more than the fine one (data
  // made on a grid of 2l). A fit at l that follows the data to the noise shows no
  // discretization error there (the refit at 2l then measures the coarse model, not this
  // one: data made on the fit's own grid); a misfit the same at both (an optimum that does
  // not fit, a model error of another kind) moves constants between the grids along a flat
  // valley of that misfit and says nothing about the voxel. So: the fit at l misfits
  // (rms(residual/σ) above kMisfitAtFine, past the few per cent a σ estimated from the
  // no-contact samples is off), and the coarse cost differs significantly (p < 0.001 for
  // one parameter, in the profile threshold's unit) and by a tenth of that excess misfit
  // at least (docs/calibration.md "Discretization check").
  constexpr double kMisfitAtFine = 1.1;
  const double dof = double(run.ev.residuals_used) - double(L.size());
  const double rise = fit.final_cost - run.fit.final_cost;
  const double excess = std::max(0.0, run.fit.final_cost - 0.5 * dof);
  const double rms_fine = run.ev.residuals_used ? std::sqrt(2 * run.fit.final_cost / double(run.ev.residuals_used)) : NAN;
  const double significant = 0.5 * 10.828 * run.residual_scale;  // χ²₁(0.999)/2
  const bool grid_explains =
      rms_fine > kMisfitAtFine && std::abs(rise) > significant && std::abs(rise) > 0.1 * excess;
  run.coarse_cost_rise = rise;
  run.coarse_grid_explains = grid_explains;
  std::vector<std::string> not_grid;
  for (auto& fp : run.out.parameters) {
    const PhysicsParam* p = physics_of(L, fp);
    // An optimum in doubt only for its misfit may owe that misfit to the grid: the check
    // runs for its constants too and says so (they stay unconfirmed).
    if (!p || p->index < 0 || fp.fixed || (!fp.identifiable && fp.verdict != "unconfirmed")) continue;
    const std::size_t i = std::size_t(p->index);
    const double err = std::abs(fit.x[i] - run.x[i]);
    fp.coarse_estimate = std::exp(fit.x[i]);
    fp.discretization_error_log = err;
    const auto [lo, hi] = check_interval(fp);
    if (!(lo > 0) || !(hi > 0)) continue;
    const double est = std::isfinite(fp.estimate) ? fp.estimate : fp.held;  // an unconfirmed one is held
    const double half = std::max(std::log(hi / est), std::log(est / lo));
    fp.ci95_with_discretization_low = lo * std::exp(-err);
    fp.ci95_with_discretization_high = hi * std::exp(err);
    fp.limited_by_discretization = err > 0.5 * half && grid_explains;
    if (err > 0.5 * half && !grid_explains)
      not_grid.push_back(fmt::format("{} {} ({})", fp.class_name, fp.name,
                                     percent(100 * (std::exp(fit.x[i] - run.x[i]) - 1), true)));
    // A refit that ran into a bound measured nothing but the bound: the coarse model is
    // outside the range where halving the voxel is a small change.
    constexpr double kBoundLog = 0.01;
    if (grid_explains && (fit.x[i] - L.lower(i) < kBoundLog || L.upper(i) - fit.x[i] < kBoundLog)) {
      fp.limited_by_discretization = true;
      fp.ci95_with_discretization_low = fp.ci95_with_discretization_high = NAN;
      run.warnings.push_back(fmt::format(
          "{} {}: the refit at voxel {:.4g} mm ran into its bound ({:.4g}{}): at twice the voxel the model is too "
          "coarse for the check to measure the discretization error; treat the estimate as limited by it and verify "
          "on a finer sample (`burrbench verify`, `burrbench sample resample --split 2`)",
          fp.class_name, fp.name, c.voxel_mm, fp.coarse_estimate, data_schema::unit_suffix(fp.unit)));
      continue;
    }
    if (fp.limited_by_discretization)
      run.warnings.push_back(fmt::format(
          "{} {}: the estimate moves {} % when the voxels are merged ({:.4g} → {:.4g} mm), more than "
          "half its 95 % interval (±{} %): limited by discretization error. The interval holds for a "
          "model at this voxel size; as a physical constant, or at another voxel size, read [{:.6g}, {:.6g}]{} "
          "(a finer sample narrows it; `burrbench verify`)",
          fp.class_name, fp.name, percent(100 * (std::exp(fit.x[i] - run.x[i]) - 1), true), c.fine_voxel_mm,
          c.voxel_mm, percent(100 * (std::exp(half) - 1)), fp.ci95_with_discretization_low, fp.ci95_with_discretization_high,
          data_schema::unit_suffix(fp.unit)));
  }
  if (!not_grid.empty())
    run.warnings.push_back(fmt::format(
        "discretization check: {} move(s) when the voxels are merged ({:.4g} → {:.4g} mm) by more than half their "
        "95 % interval, but {}: that move measures the coarse model, not a discretization error of this fit, and "
        "they are not flagged as limited by it (`burrbench verify` on a finer sample tells whether the model has "
        "converged)",
        fmt::join(not_grid, ", "), c.fine_voxel_mm, c.voxel_mm,
        rms_fine <= kMisfitAtFine
            ? fmt::format("the fit at {:.4g} mm follows the data to the noise (rms(residual/σ) {:.3f})", c.fine_voxel_mm,
                          rms_fine)
            : fmt::format("the misfit is the same at both (cost {:+.4g} at 2l, against {:.4g} in excess of the noise "
                          "at l)", rise, excess)));
}

}  // namespace burrbench::calibration::detail
