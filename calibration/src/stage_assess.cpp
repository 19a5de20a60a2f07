// Stage "assess": profile likelihoods, verdicts and the covariance of what is identifiable.
// A profile point cheaper than the optimum sends the fit back to `refine` from there.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numeric>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/model/job_queue.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {
namespace {

constexpr int kMaxRestarts = 2;

// The precision a constant's 95 % profile interval must reach (half-width / estimate) to be
// called "identifiable" when [fit.precision] asks none: the tolerances the project checks
// its own fits against (tests' confident-miss rule): α 10 %, C1 2 %, μ 5 %.
double default_precision(PhysKind k) {
  switch (k) {
    case PhysKind::kAlpha: return 0.10;
    case PhysKind::kC1: return 0.02;
    case PhysKind::kMu: return 0.05;
  }
  BURRBENCH_UNREACHABLE();
}
constexpr double kBoundLog = 0.01;  // within 1 % (in ln θ) of a bound = at the bound

// dx_j/dx_i along the linearised profile of entry i: Σ_ji / Σ_ii (empty when the
// covariance failed or i is not in it).
std::vector<double> valley_slopes(const CovarianceOutcome& cov, std::size_t i, std::size_t n) {
  const std::size_t m = cov.indices.size();
  if (!cov.ok) return {};
  const std::size_t ia = cov.position(i);
  if (ia == m) return {};
  const double var = cov.cov[ia * m + ia];
  if (!(var > 0) || !std::isfinite(var)) return {};
  std::vector<double> slope(n, 0.0);
  for (std::size_t b = 0; b < m; ++b)
    if (std::isfinite(cov.cov[b * m + ia])) slope[cov.indices[b]] = cov.cov[b * m + ia] / var;
  slope[i] = 1.0;
  return slope;
}

// `cov`: the covariance at run.x with only `pre` held, which the profiles start from.
std::vector<Profile> run_profiles(Run& run, const Flags& pre, const CovarianceOutcome& cov) {
  const Layout& L = *run.layout;
  std::vector<std::size_t> entries;
  for (const auto& p : L.physics())
    if (p.index >= 0 && !pre.held[std::size_t(p.index)]) entries.push_back(std::size_t(p.index));
  std::vector<Profile> out(entries.size());
  std::size_t done = 0;
  std::mutex mu;
  // While a restart is left, a cheaper point ends every profile: the fit restarts from it
  // and profiles again (assess), so the profiles not begun by then are not begun.
  std::atomic<bool> cheaper{false};
  std::vector<std::size_t> queue(entries.size());
  std::iota(queue.begin(), queue.end(), std::size_t(0));
  model::run_job_queue(entries.size(), queue, run.opt.threads, [&](std::size_t, std::size_t k) {
    if (cheaper) return;
    const std::size_t i = entries[k];
    double se = NAN;
    for (std::size_t a = 0; a < cov.indices.size(); ++a)
      if (cov.ok && cov.indices[a] == i) se = std::sqrt(std::max(0.0, cov.cov[a * cov.indices.size() + a]));
    ProfileOptions po;
    po.max_points = run.opt.profile_points;
    po.first_step = std::isfinite(se) && se > 0 ? 1.96 * se : 0.1;
    po.valley = valley_slopes(cov, i, L.size());
    po.threads = run.opt.threads;  // the replay pool bounds the CPUs; the last profile uses both
    if (run.restarts < kMaxRestarts) po.cheaper_found = &cheaper;
    Profile p = profile_parameter(*run.obj, run.x, run.fit.final_cost, run.w_all, i, run.threshold,
                                  pre.held, po);
    std::lock_guard lk(mu);
    out[k] = std::move(p);
    ++done;
    run.say(fmt::format("profile {}/{}: {}", done, entries.size(), L.name(i)));
  });
  // Correlations of the free physics parameters (for the warnings below).
  const std::size_t m = cov.indices.size();
  if (cov.ok)
    for (std::size_t a = 0; a < m; ++a)
      for (std::size_t b = a + 1; b < m; ++b) {
        const auto* pa = L.physics_at(cov.indices[a]);
        const auto* pb = L.physics_at(cov.indices[b]);
        if (!pa || !pb) continue;
        const double den = std::sqrt(cov.cov[a * m + a] * cov.cov[b * m + b]);
        const double r = den > 0 ? cov.cov[a * m + b] / den : 0.0;
        if (std::abs(r) > 0.99)
          run.warnings.push_back(fmt::format("{} and {} correlate at {:.5f}: read their intervals "
                                             "together (profiles below)", L.name(cov.indices[a]),
                                             L.name(cov.indices[b]), r));
      }
  return out;
}

nlohmann::json profile_json(const Layout& L, const Profile& p) {
  std::vector<std::pair<double, double>> pts{{p.x_hat, 0.0}};
  for (const auto* s : {&p.lower, &p.upper})
    for (const auto& q : s->points) pts.emplace_back(q.x, q.delta_cost);
  std::sort(pts.begin(), pts.end());
  nlohmann::json j = nlohmann::json::array();
  for (const auto& [x, d] : pts)
    j.push_back({{"value", L.natural(p.entry, x)},
                 {"delta_cost", std::isfinite(d) ? nlohmann::json(d) : nlohmann::json(nullptr)}});
  return j;
}

// An identifiable constant that the linearised fit with the bounds the data push against
// lifted (step_past_bounds: physics at_bound and nuisances at theirs) moves by more than its
// own profile interval's half-width gets the verdict "conditional_on_bound".
void held_by_bounds(Run& run, const CovarianceOutcome& cov, std::vector<std::string>& reason) {
  const Layout& L = *run.layout;
  std::vector<std::size_t> physics;
  for (const auto& pj : run.profiles)
    if (run.verdict[pj.entry] == "at_bound") physics.push_back(pj.entry);
  const std::vector<AtBound> at = held_at_bounds(L, run.x, physics);
  if (at.empty()) return;
  std::vector<AtBound> pulled;
  const std::vector<double> step = step_past_bounds(cov, at, L.size(), &pulled);
  if (step.empty()) return;
  for (const auto& pr : run.profiles) {
    const std::size_t i = pr.entry;
    if (run.verdict[i] != "identifiable" && run.verdict[i] != "imprecise") continue;
    const double half = 0.5 * (pr.upper.crossing - pr.lower.crossing);
    if (!(std::abs(step[i]) > half)) continue;
    run.verdict[i] = "conditional_on_bound";
    reason[i] = bound_partner_reason(L, run.x, i, pulled, step[i], half);
  }
}

}  // namespace

double noise_floor_cost(const Run& run) {
  return 0.5 * std::max(0.0, double(run.ev.residuals_used) - double(run.layout->size()));
}

std::vector<std::string> optimum_doubts(const Run& run, const SearchTally& t, const std::string& cheaper_left) {
  std::vector<std::string> d;
  // An end within the threshold of the optimum, or inside every one of its intervals, is a
  // second find of its basin. A lone find is in doubt when the cost demonstrably has other
  // minima (another start converged outside the intervals) or when no start's end reached
  // it at all; a lone find whose other starts were abandoned far above it is neither
  // confirmed nor contradicted, and keeps the lone-optimum warning only.
  // A lone find that fits to the noise is confirmed by the noise floor instead: no other
  // optimum can fit much better.
  const double rms = run.ev.residuals_used ? std::sqrt(2 * run.ev.cost / double(run.ev.residuals_used)) : NAN;
  if (run.search.solved > 1 && t.reached + t.near <= 1 && (t.higher_optima > 0 || t.reached == 0) &&
      !(rms <= kLoneFindRms))
    d.push_back(fmt::format("the best optimum was reached by {} of {} starts{}, and its misfit (rms(residual/σ) "
                            "{:.3f}) is above the noise floor's {:.2g}",
                            t.reached, run.starts,
                            t.higher_optima > 0 ? fmt::format(" and {} converged to other minima", t.higher_optima)
                                                : std::string(),
                            rms, kLoneFindRms));
  if (!cheaper_left.empty()) d.push_back(cheaper_left);
  if (rms > kUnconfirmedRms)
    d.push_back(fmt::format("rms(residual/σ) = {:.3f}, far above 1 (limit {:.2g}): the model does not follow the data "
                            "at this optimum", rms, kUnconfirmedRms));
  return d;
}

namespace {

// Profiles from the optimum; a profile point cheaper than it restarts the refinement
// from there (at most kMaxRestarts times). Returns the contact checks' flags; `cheaper_left`
// names a profile point still cheaper by more than the threshold ("" if none).
Flags profile_until_settled(Run& run, CovarianceOutcome& cov, std::string& cheaper_left) {
  const Layout& L = *run.layout;
  Flags flags;
  for (;;) {
    run.ev = run.obj->evaluate(run.x, run.w_all);
    const double dof = double(run.ev.residuals_used) - double(L.size());
    const double s2 = dof > 0 ? std::max(2.0 * run.ev.cost / dof, 1e-12) : 1.0;
    // Correlated residuals (a misfit the model cannot follow, or coloured sensor noise)
    // carry less information than their count says: widen by the AR(1) factor.
    run.inflation = run.opt.noise_inflation ? ar1_inflation(run.ev.residual_lag1) : 1.0;
    run.residual_scale = s2 * run.inflation;
    run.chi2_threshold = 0.5 * kChi2_1_95 * run.residual_scale;
    run.threshold = run.chi2_threshold;
    run.texture = {};
    flags = contact_checks(*run.obj, run.x, run.w_all, run.ev);
    run.profiles.clear();
    run.warnings.clear();
    if (!run.opt.profiles) break;
    cov = run.obj->covariance(run.x, run.w_all, flags.held, run.inflation);
    run.stage("texture", fmt::format("{} refits from the 95 % ellipsoid: where a re-optimisation stops",
                                     kTextureProbes));
    run.texture = probe_texture(*run.obj, run.x, run.fit.final_cost, run.w_all, flags.held, cov, run.chi2_threshold,
                                run.opt.threads);
    run.threshold = run.chi2_threshold + run.texture.allowance;
    // The cheapest point found away from the optimum: a texture probe's end or a profile
    // point. Cheaper by less than a quarter of the threshold is the optimum's own dip.
    std::string source;
    const std::vector<double>* at = nullptr;
    double cost = run.fit.final_cost - 0.25 * run.threshold;
    if (run.texture.cheapest_cost < cost) {
      source = "a texture probe";
      at = &run.texture.cheapest_at;
      cost = run.texture.cheapest_cost;
    }
    if (!at) {
      run.stage("profiles", "re-optimising along each physics parameter");
      run.profiles = run_profiles(run, flags, cov);
      for (const auto& p : run.profiles)
        if (p.found_lower && p.lower_cost < cost) {
          source = fmt::format("the profile of {}", L.name(p.entry));
          at = &p.lower_at;
          cost = p.lower_cost;
        }
    }
    if (!at) break;
    if (run.restarts >= kMaxRestarts) {
      run.warnings.push_back(fmt::format("{} is still cheaper than the optimum (cost {:.6g} < {:.6g}) after {} "
                                         "restarts", source, cost, run.fit.final_cost, run.restarts));
      // A point cheaper by less than the profile threshold lies in the optimum's own basin
      // (the search counts such ends as reaching it): the voxel texture of the cost, not
      // another optimum. Only a point cheaper by more puts the optimum in doubt.
      if (run.fit.final_cost - cost > run.threshold)
        cheaper_left = fmt::format("{} found a point cheaper than the optimum by more than the profile threshold "
                                   "(cost {:.6g} < {:.6g} − {:.3g}) after {} restarts",
                                   source, cost, run.fit.final_cost, run.threshold, run.restarts);
      if (run.profiles.empty()) run.profiles = run_profiles(run, flags, cov);
      break;
    }
    run.stage("refit", fmt::format("{} found a cheaper point (cost {:.6g} < {:.6g}): refitting from there", source,
                                   cost, run.fit.final_cost));
    run.x = *at;
    ++run.restarts;
    const auto previous = run.fit;
    refine(run);
    run.fit.initial_cost = previous.initial_cost;
    run.fit.iterations += previous.iterations;
  }
  return flags;
}

// One physics constant's verdict from its profile, and the reason when it is not plainly
// identifiable.
std::pair<std::string, std::string> profile_verdict(const Run& run, const Profile& pr) {
  const Layout& L = *run.layout;
  const std::size_t i = pr.entry;
  const auto* p = L.physics_at(i);
  const double xi = run.x[i];
  std::string v, why;
  if (xi - L.lower(i) < kBoundLog || L.upper(i) - xi < kBoundLog) {
    const bool up = L.upper(i) - xi < kBoundLog;
    v = "at_bound";
    why = fmt::format("estimate at its {} bound ({:.4g}{}): widen it ([fit.classes.{}] {})",
                      up ? "upper" : "lower", std::exp(xi), data_schema::unit_suffix(unit_of(p->kind)), p->class_name,
                      to_string(p->kind));
  } else if (pr.lower.closed && pr.upper.closed) {
    v = "identifiable";
    // Closed, but wider than the precision the lab asked for ([fit.precision]), or, when it
    // asked none, than the default precision: "identifiable" is read as "known to within
    // the tolerances a lab works to", and a lab that does not know the section must not get
    // a constant ±17 % wide under that name (docs/calibration.md "Profiles and verdicts").
    const auto& fs = run.exp.manifest.fit;
    const auto asked = p->kind == PhysKind::kAlpha ? fs.precision_alpha
                       : p->kind == PhysKind::kC1  ? fs.precision_c1
                                                    : fs.precision_mu;
    const double wanted = asked.value_or(default_precision(p->kind));
    const double half = 0.5 * (std::exp(pr.upper.crossing) - std::exp(pr.lower.crossing)) / std::exp(xi);
    if (half > wanted) {
      v = "imprecise";
      why = fmt::format("95 % profile interval ±{} %, wider than the ±{} % {} (fit.precision.{})",
                        percent(100 * half), percent(100 * wanted), asked ? "asked" : "of the default precision",
                        to_string(p->kind));
    }
  } else if (pr.lower.closed || pr.upper.closed) {
    v = "practically_non_identifiable";
    const bool up_open = !pr.upper.closed;
    why = fmt::format("profile flat towards its {} bound: the data give only {} limit ({} {:.4g}{})",
                      up_open ? "upper" : "lower", up_open ? "a lower" : "an upper",
                      up_open ? ">=" : "<=",
                      std::exp(up_open ? pr.lower.crossing : pr.upper.crossing), data_schema::unit_suffix(unit_of(p->kind)));
  } else {
    v = "non_identifiable";
    why = "profile flat on both sides within the bounds";
  }
  // Other near-optimal ends of the global search outside the profile interval: the
  // profile's valley does not hold every optimum of equal cost.
  if (v == "identifiable")
    for (const auto& e : run.search.ends)
      if (e.usable && e.cost <= run.fit.final_cost + run.threshold &&
          (e.end[i] < pr.lower.crossing || e.end[i] > pr.upper.crossing)) {
        v = "non_identifiable";
        why = fmt::format("start {} reached an equally good fit (cost {:.6g}) at {:.4g}{}, "
                          "outside the profile interval", e.index, e.cost, std::exp(e.end[i]),
                          data_schema::unit_suffix(unit_of(p->kind)));
        break;
      }
  return {v, why};
}

// The optimum itself in doubt: no constant is called identifiable at it.
void doubt_the_optimum(Run& run, std::vector<std::string>& reason, const std::string& cheaper_left) {
  const Layout& L = *run.layout;
  std::vector<std::pair<double, double>> box(L.size(), {-INFINITY, INFINITY});
  for (const auto& pr : run.profiles)
    box[pr.entry] = {pr.lower.closed ? pr.lower.crossing : -INFINITY, pr.upper.closed ? pr.upper.crossing : INFINITY};
  const std::vector<std::string> doubts =
      optimum_doubts(run, tally(run.search.ends, run.fit.final_cost, run.threshold, box), cheaper_left);
  if (!doubts.empty()) {
    const std::string why = fmt::format("the optimum is not confirmed: {}", fmt::join(doubts, "; "));
    run.doubts = doubts;
    run.warnings.push_back(fmt::format("{}: no constant is called identifiable at it, and params.toml flags them "
                                       "all (more starts: --starts; check the registration, the sensor frame "
                                       "and the model)", why));
    for (const auto& pr : run.profiles) {
      const std::size_t i = pr.entry;
      if (run.verdict[i] != "identifiable" && run.verdict[i] != "imprecise") continue;
      run.verdict[i] = "unconfirmed";
      reason[i] = why;
    }
  }
}

// Each profiled constant's verdict; all but the identifiable and the imprecise are held.
void profile_verdicts(Run& run, Flags& flags, const CovarianceOutcome& cov, const std::string& cheaper_left) {
  std::vector<std::string> reason(run.layout->size());
  for (const auto& pr : run.profiles) std::tie(run.verdict[pr.entry], reason[pr.entry]) = profile_verdict(run, pr);
  held_by_bounds(run, cov, reason);
  doubt_the_optimum(run, reason, cheaper_left);
  for (const auto& pr : run.profiles) {
    const std::size_t i = pr.entry;
    if (run.verdict[i] == "imprecise") {
      // Determined, only not as finely as asked: it keeps its estimate and covariance.
      run.imprecise_reason[i] = reason[i];
    } else if (run.verdict[i] != "identifiable") {
      flags.held[i] = true;
      flags.reason[i] = reason[i];
    }
  }
}

// The intervals and the fit.json tables; where the search's ends lie against them.
void record_uncertainty(Run& run, const Flags& flags) {
  const Layout& L = *run.layout;
  run.unc = assess_uncertainty(*run.obj, run.x, run.w_all, run.ev, flags, !run.opt.profiles,
                               run.inflation);
  // Where the search's ends lie against the optimum's 95 % intervals (profile, else
  // covariance; an open side is unbounded), per x entry; nuisances are not boxed.
  std::vector<std::pair<double, double>> box(L.size(), {-INFINITY, INFINITY});
  for (auto& fp : run.unc.parameters) {
    const PhysicsParam* p = physics_of(L, fp);
    if (!p || p->index < 0) continue;
    const std::size_t i = std::size_t(p->index);
    fp.verdict = !run.verdict[i].empty() ? run.verdict[i]
                 : fp.identifiable       ? "identifiable"
                                         : "non_identifiable";
    if (const auto it = run.imprecise_reason.find(i); it != run.imprecise_reason.end()) fp.reason = it->second;
    for (const auto& pr : run.profiles)
      if (pr.entry == i) {
        fp.profile = profile_json(L, pr);
        fp.profile_ci95_low = pr.lower.closed ? std::exp(pr.lower.crossing) : NAN;
        fp.profile_ci95_high = pr.upper.closed ? std::exp(pr.upper.crossing) : NAN;
      }
    const bool prof = std::isfinite(fp.profile_ci95_low) || std::isfinite(fp.profile_ci95_high);
    const double lo = prof ? fp.profile_ci95_low : fp.ci95_low, hi = prof ? fp.profile_ci95_high : fp.ci95_high;
    box[i] = {lo > 0 ? std::log(lo) : -INFINITY, hi > 0 ? std::log(hi) : INFINITY};
  }
  run.search_reference_cost = !L.mountings().empty() && !run.search.ends.empty() ? run.search.ends.front().cost
                                                                                  : run.fit.final_cost;
  run.tally = tally(run.search.ends, run.search_reference_cost, run.threshold, box);
  run.search.reached_best = run.tally.reached;
  if (auto w = lone_optimum_warning(run.tally, run.starts, run.search.solved); !w.empty())
    run.warnings.push_back(std::move(w));
  run.out.parameters = run.unc.parameters;
  run.out.nuisance = run.unc.nuisance;
  run.out.covariance = run.unc.covariance;
  run.out.correlation = run.unc.correlation;
  run.out.channel_information = run.unc.channel_information;
}

}  // namespace

void assess(Run& run) {
  const Layout& L = *run.layout;
  CovarianceOutcome cov;
  std::string cheaper_left;  // a profile point still cheaper than the optimum ("" if none)
  Flags flags = profile_until_settled(run, cov, cheaper_left);
  // "Best optimum reached by k of N" (below): ends within the profile threshold of it.
  run.search.tolerance = run.threshold;
  run.verdict.assign(L.size(), "");
  for (const auto& p : L.physics())
    if (p.index >= 0 && flags.held[std::size_t(p.index)]) run.verdict[std::size_t(p.index)] = "non_identifiable";
  if (run.opt.profiles) profile_verdicts(run, flags, cov, cheaper_left);
  record_uncertainty(run, flags);
}

}  // namespace burrbench::calibration::detail
