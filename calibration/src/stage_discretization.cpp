// Stage "discretization": how far the estimates move when the sample's voxels are merged
// by 2. The fit is repeated from the optimum on the coarse sample (same data, weights,
// nuisances and held parameters); |ln θ_2l − ln θ_l| is the first-order (Richardson,
// p = 1) estimate of the discretization error of ln θ at the fit's voxel size l. A
// constant whose error exceeds half its 95 % interval is "limited by discretization
// error", and its interval is widened by it (docs/calibration.md, "Discretization check").
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/import/volume.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {

void discretization_check(Run& run) {
  if (!run.opt.discretization_check) return;
  const Layout& L = *run.layout;
  run.say("discretization check: refitting on the sample with voxels merged by 2");
  std::map<std::string, ds::SampleVolume> coarse;
  double voxel_mm = 0;
  for (const auto& [id, s] : run.used_samples) {
    coarse.emplace(id, ds::import::merge_voxels(s, 2));
    voxel_mm = std::max(voxel_mm, s.voxel_mm);
  }
  ReplayPool pool(coarse, run.opt.threads);
  std::vector<std::unique_ptr<ReplayRecordingModel>> owned;
  std::vector<const RecordingModel*> models;
  for (const auto* r : run.recs) {
    owned.push_back(std::make_unique<ReplayRecordingModel>(*r, pool));
    owned.back()->set_derivatives(run.opt.derivatives);
    owned.back()->set_steps(run.steps);
    models.push_back(owned.back().get());
  }
  const Objective obj(L, models, run.settings);
  SolveOptions so;
  so.max_iterations = run.opt.max_iterations;
  so.threads = run.opt.threads;
  so.progress = run.opt.progress;
  so.hold = run.unc.held;
  const SolveOutcome fit = obj.solve(run.x, run.w_all, so);
  run.replays_before += obj.replays();
  run.coarse_voxel_mm = 2 * voxel_mm;
  if (!fit.usable) {
    run.warnings.push_back("discretization check: the refit on the coarse sample failed; no "
                           "discretization error is given");
    return;
  }
  for (auto& fp : run.out.parameters) {
    const PhysicsParam* p = nullptr;
    for (const auto& q : L.physics())
      if (q.label == fp.class_id && to_string(q.kind) == fp.name) p = &q;
    if (!p || p->index < 0 || fp.fixed || !fp.identifiable) continue;
    const std::size_t i = std::size_t(p->index);
    const double err = std::abs(fit.x[i] - run.x[i]);
    fp.coarse_estimate = std::exp(fit.x[i]);
    fp.discretization_error_log = err;
    // The interval the verdict rests on: the profile's where closed, else the covariance's.
    const double lo = std::isfinite(fp.profile_ci95_low) ? fp.profile_ci95_low : fp.ci95_low;
    const double hi = std::isfinite(fp.profile_ci95_high) ? fp.profile_ci95_high : fp.ci95_high;
    if (!(lo > 0) || !(hi > 0)) continue;
    const double half = std::max(std::log(hi / fp.estimate), std::log(fp.estimate / lo));
    fp.ci95_with_discretization_low = lo * std::exp(-err);
    fp.ci95_with_discretization_high = hi * std::exp(err);
    fp.limited_by_discretization = err > 0.5 * half;
    if (fp.limited_by_discretization)
      run.warnings.push_back(fmt::format(
          "{} {}: the estimate moves {:+.1f} % when the voxels are merged ({:.4g} → {:.4g} mm), more than "
          "half its 95 % interval (±{:.1f} %): limited by discretization error. The interval holds for a "
          "model at this voxel size; as a physical constant, or at another voxel size, read [{:.6g}, {:.6g}] {} "
          "(a finer sample narrows it; `burrbench verify`)",
          fp.class_name, fp.name, 100 * (std::exp(fit.x[i] - run.x[i]) - 1), voxel_mm, 2 * voxel_mm,
          100 * (std::exp(half) - 1), fp.ci95_with_discretization_low, fp.ci95_with_discretization_high,
          fp.unit));
  }
}

}  // namespace burrbench::calibration::detail
