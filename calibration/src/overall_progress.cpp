#include "overall_progress.hpp"

#include <algorithm>

#include "pipeline.hpp"

namespace burrbench::calibration::detail {

ReplayPlan planned_replays(const Run& run) {
  const CalibrateOptions& o = run.opt;
  const Layout& L = *run.layout;
  const double E = double(run.models.size());  // one replay per recording an evaluation
  auto solve = [&](double iterations) { return E * (iterations + 3); };
  std::set<std::uint8_t> classes;  // with a free constant
  double free = 0;
  for (const auto& p : L.physics())
    if (p.index >= 0) {
      classes.insert(p.label);
      ++free;
    }
  double starts = free > 0 ? (o.starts > 0 ? o.starts : run.exp.manifest.fit.multistart) : 1;
  // A pre-fit of every start (about three evaluations), a solve of the best few.
  auto search = [&](double n) { return 3 * E * n + std::min<double>(o.solve_starts, n) * solve(o.start_iterations); };
  // The joint search, and each class's own when its best end misfits (stage_search.cpp): planned
  // whenever they may run, so that the fraction jumps ahead when they do not, rather than stalling.
  double searching = search(starts);
  if (classes.size() > 1 && starts > 1) searching += double(classes.size()) * search(starts - 1);
  std::map<std::string, double> p;
  if (o.coarse_to_fine) {
    p["coarse_to_fine"] = searching + 2 * solve(7);  // refined at 2l, then at l
  } else {
    p["global_search"] = searching;
    p["refine"] = solve(7);
  }
  // A profile takes about (points − 1) evaluations of every recording (two sides).
  p["assess"] = E + (o.profiles ? free * E * (o.profile_points - 1) : 0);
  if (o.depth_check) p["depth_check"] = solve(2);
  if (o.discretization_check) p["discretization"] = solve(22);  // the coarse cost is textured: many steps
  p["bootstrap"] = o.bootstrap * solve(7);
  // A fold per recording (two segments of a lone one), each a warm-started solve.
  if (o.cross_validate) p["cross_validation"] = std::max(2.0, E) * solve(11);
  p["validation"] = E;
  const double refit = solve(7) + p["assess"];  // refine, then the profiles again
  return {p, {{"refit", refit}}};
}

void OverallProgress::plan(ReplayPlan plan) {
  std::lock_guard lk(mu_);
  planned_ = std::move(plan.stages);
  repeats_ = std::move(plan.repeats);
}

void OverallProgress::begin(const std::string& stage) {
  std::lock_guard lk(mu_);
  current_ = stage;
  at_begin_ = replays_();
}

void OverallProgress::end(const std::string& stage) {
  std::lock_guard lk(mu_);
  ended_.insert(stage);
  current_.clear();
}

double OverallProgress::fraction_locked() {
  if (planned_.empty()) return shown_;  // the recordings are still being selected
  const double done = double(replays_());
  double left = 0;
  for (const auto& [stage, n] : planned_) {
    if (ended_.count(stage)) continue;
    left += stage == current_ ? std::max(0.0, n - (done - double(at_begin_))) : n;
  }
  // 1 is for complete(): the overlaps and the results come after the last planned replay.
  const double f = done + left > 0 ? std::min(0.99, done / (done + left)) : 0.99;
  shown_ = std::max(shown_, f);
  return shown_;
}

double OverallProgress::fraction() {
  std::lock_guard lk(mu_);
  return fraction_locked();
}

void OverallProgress::update(double, const std::string& line) {
  const double f = fraction();
  inner_->update(f, line);
}

void OverallProgress::stage(const std::string& name, const std::string& detail) {
  double f = 0;
  {
    std::lock_guard lk(mu_);
    if (const auto it = repeats_.find(name); it != repeats_.end() && planned_.count(current_))
      planned_[current_] += it->second;
    f = fraction_locked();
  }
  inner_->stage_at(f, name, detail);
}

void OverallProgress::complete(const std::string& line) {
  {
    std::lock_guard lk(mu_);
    shown_ = 1;
  }
  if (inner_) inner_->update(1, line);  // calibrate() makes one whether or not it has a sink
}

}  // namespace burrbench::calibration::detail
