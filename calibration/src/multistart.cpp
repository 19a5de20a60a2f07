#include "burrbench/calibration/multistart.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>
#include <numeric>
#include <random>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/job_queue.hpp"

namespace burrbench::calibration {

std::vector<std::vector<double>> latin_hypercube_starts(const Layout& layout,
                                                        const std::vector<double>& x0, int n,
                                                        std::uint64_t seed) {
  std::vector<std::vector<double>> out(std::size_t(std::max(1, n)), x0);
  const int m = std::max(0, n - 1);
  if (m == 0) return out;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  for (const auto& p : layout.physics()) {
    if (p.index < 0) continue;
    const std::size_t i = std::size_t(p.index);
    // One stratum per start, strata shuffled per dimension: every parameter's range is
    // covered evenly whatever the number of starts.
    std::vector<int> strata(static_cast<std::size_t>(m));
    std::iota(strata.begin(), strata.end(), 0);
    std::shuffle(strata.begin(), strata.end(), rng);
    for (int s = 0; s < m; ++s) {
      const double f = (double(strata[std::size_t(s)]) + u01(rng)) / double(m);
      out[std::size_t(s) + 1][i] = layout.lower(i) + f * (layout.upper(i) - layout.lower(i));
    }
  }
  return out;
}

bool hopeless_start(const std::vector<double>& costs, int max_iterations, double reference) {
  const std::size_t n = costs.size();
  if (n < 4 || !std::isfinite(reference)) return false;  // start + 3 iterations
  const double now = costs[n - 1], before = costs[n - 3];
  if (!(now > reference) || !(before > 0)) return false;
  const double rate = std::max(0.0, (before - now) / before) / 2;  // per iteration
  const int left = std::max(0, max_iterations - int(n - 1));
  const double best_case = now * std::pow(std::max(0.0, 1 - 2 * rate), left);
  return best_case > reference;
}

const char* to_string(StartEnd::Ending e) {
  switch (e) {
    case StartEnd::Ending::kScreened: return "screened";
    case StartEnd::Ending::kConverged: return "converged";
    case StartEnd::Ending::kStopped: return "stopped";
  }
  BURRBENCH_UNREACHABLE();
}

void sort_ends(std::vector<StartEnd>& ends) {
  std::stable_sort(ends.begin(), ends.end(), [](const StartEnd& a, const StartEnd& b) {
    if (a.usable != b.usable) return a.usable;
    return a.cost < b.cost;
  });
}

SearchTally tally(const std::vector<StartEnd>& ends, double best_cost, double tolerance,
                  const std::vector<std::pair<double, double>>& box) {
  SearchTally t;
  for (const auto& e : ends) {
    if (!e.usable) continue;
    if (reaches_best(e, best_cost, tolerance)) {
      ++t.reached;
      continue;
    }
    bool inside = !box.empty() && box.size() == e.end.size();
    for (std::size_t i = 0; inside && i < box.size(); ++i)
      inside = box[i].first <= e.end[i] && e.end[i] <= box[i].second;
    if (inside) {
      ++t.near;
    } else {
      t.higher_optima += e.ending == StartEnd::Ending::kConverged;
      t.stopped_short += e.ending == StartEnd::Ending::kStopped;
    }
  }
  return t;
}

std::string lone_optimum_warning(const SearchTally& t, int starts, int solved) {
  // A start ending inside the optimum's intervals found its neighbourhood too: a second find.
  if (solved <= 1 || t.reached + t.near > 1) return "";
  // Why the others did not reach it decides what can be said: only a start that converged
  // away from it found another minimum.
  std::string why;
  if (t.near > 0)
    why = fmt::format("; {} ended just above it with every constant inside its 95 % intervals", t.near);
  if (t.higher_optima > 0)
    why += fmt::format("; {} other start(s) converged to higher minima outside its 95 % intervals, so the cost "
                       "has several", t.higher_optima);
  if (t.stopped_short > 0)
    why += fmt::format("; {} other start(s) stopped above it before converging (abandoned as hopeless or out "
                       "of --start-iterations) and neither confirm nor contradict it",
                       t.stopped_short);
  return fmt::format("the best optimum was reached by only {} of {} starts{}: it may not be the global one "
                     "(more starts: --starts)", t.reached, starts, why);
}

MultistartOutcome multistart(const Objective& obj, const std::vector<std::vector<double>>& starts,
                             const SampleWeights& w, const MultistartOptions& opt,
                             double tolerance) {
  MultistartOutcome out;
  out.tolerance = tolerance;
  out.ends.resize(starts.size());
  std::mutex mu;
  std::size_t done = 0;
  const std::size_t total = starts.size();
  // Runs job(i) for i in [0, n) on opt.concurrent threads; an error is rethrown once all
  // have ended, the lowest i's (as one thread would meet it).
  auto parallel = [&](std::size_t n, const std::function<void(std::size_t)>& job) {
    std::vector<std::size_t> queue(n);
    std::iota(queue.begin(), queue.end(), std::size_t(0));
    model::run_job_queue(n, queue, opt.concurrent, [&](std::size_t, std::size_t i) { job(i); });
  };
  std::size_t of = total;
  auto report = [&](const char* what, double cost) {
    std::lock_guard lk(mu);
    ++done;
    if (opt.progress)
      opt.progress->update(-1, fmt::format("multistart {} {}/{}: cost {:.6g}", what, done, of, cost));
  };
  // 1. Pre-fit every start. Pre-fits run side by side, one thread each; fewer starts than
  // threads share them out (a lone start's pre-fit would otherwise leave a core idle).
  const std::size_t concurrent = std::size_t(std::max(1, opt.concurrent));
  const int prefit_threads = int(concurrent / std::clamp<std::size_t>(total, 1, concurrent));
  parallel(total, [&](std::size_t s) {
    StartEnd e;
    e.index = int(s);
    e.start = starts[s];
    PrefitOptions pre = opt.prefit;
    pre.threads = prefit_threads;
    const SolveOutcome warm = obj.prefit(e.start, w, pre);
    e.prefit_cost = warm.usable ? warm.final_cost : INFINITY;
    e.end = warm.usable ? warm.x : e.start;
    e.cost = e.prefit_cost;
    e.iterations = warm.iterations;
    e.termination = "screened by pre-fit cost (not solved further)";
    e.usable = warm.usable;
    out.ends[s] = std::move(e);
    report("pre-fit", out.ends[s].cost);
  });
  // 2. Local solves of the most promising starts.
  std::vector<std::size_t> order(total);
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return out.ends[a].prefit_cost < out.ends[b].prefit_cost;
  });
  const std::size_t solved = opt.solved > 0 ? std::min(total, std::size_t(opt.solved)) : total;
  const double reference = total > 0 ? out.ends[order[0]].prefit_cost : INFINITY;
  done = 0;
  of = solved;
  out.solved = int(solved);
  parallel(solved, [&](std::size_t k) {
    StartEnd& e = out.ends[order[k]];
    SolveOptions full;
    full.max_iterations = opt.iterations;
    full.function_tolerance = opt.function_tolerance;
    full.hold = opt.hold;
    full.threads = std::max(1, opt.concurrent);  // the pool bounds the CPUs; a lone last solve uses both
    if (opt.abandon_hopeless)
      full.stop_early = [&](const std::vector<double>& costs) {
        return hopeless_start(costs, opt.iterations, reference);
      };
    const SolveOutcome r = obj.solve(e.end, w, full);
    if (!r.usable) {  // its end stays the pre-fit's
      e.ending = StartEnd::Ending::kStopped;
      e.termination = "local solve failed (" + r.termination + "); kept at its pre-fit";
      return;
    }
    e.end = r.x;
    e.cost = r.final_cost;
    e.iterations += r.iterations;
    e.termination = r.stopped_early
                        ? fmt::format("abandoned: stalled at cost {:.6g}, above the best pre-fit cost {:.6g} "
                                      "even at twice its recent rate of descent",
                                      r.final_cost, reference)
                        : r.termination;
    e.ending = r.converged ? StartEnd::Ending::kConverged : StartEnd::Ending::kStopped;
    e.usable = true;
    report("local solve", e.cost);
  });
  sort_ends(out.ends);
  const double best = out.ends.empty() ? INFINITY : out.ends.front().cost;
  out.reached_best = tally(out.ends, best, tolerance).reached;
  return out;
}

}  // namespace burrbench::calibration
