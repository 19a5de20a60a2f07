#include "burrbench/calibration/multistart.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <mutex>
#include <numeric>
#include <random>
#include <thread>

#include <fmt/format.h>

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

MultistartOutcome multistart(const Objective& obj, const std::vector<std::vector<double>>& starts,
                             const SampleWeights& w, const MultistartOptions& opt,
                             double tolerance) {
  const Layout& L = obj.layout();
  MultistartOutcome out;
  out.tolerance = tolerance;
  out.ends.resize(starts.size());
  std::vector<bool> prefit_hold(L.size(), false);
  for (const auto& p : L.physics())
    if (p.index >= 0 && p.kind == PhysKind::kAlpha) prefit_hold[std::size_t(p.index)] = true;
  for (const auto& r : L.recordings()) {
    if (r.lag >= 0) prefit_hold[std::size_t(r.lag)] = true;
    if (r.depth >= 0) prefit_hold[std::size_t(r.depth)] = true;
  }
  std::atomic<std::size_t> next{0}, done{0};
  std::mutex mu;
  std::exception_ptr error;
  auto worker = [&] {
    for (;;) {
      const std::size_t s = next++;
      if (s >= starts.size()) return;
      try {
        StartEnd e;
        e.index = int(s);
        e.start = starts[s];
        SolveOptions pre;
        pre.max_iterations = opt.prefit_iterations;
        pre.geometry_terms = false;
        pre.threads = 1;
        pre.hold = prefit_hold;
        const SolveOutcome warm = obj.solve(e.start, w, pre);
        e.prefit_cost = warm.final_cost;
        SolveOptions full;
        full.max_iterations = opt.iterations;
        full.threads = 1;
        const SolveOutcome r = obj.solve(warm.usable ? warm.x : e.start, w, full);
        e.end = r.x;
        e.cost = r.usable ? r.final_cost : INFINITY;
        e.iterations = warm.iterations + r.iterations;
        e.termination = r.termination;
        e.usable = r.usable;
        std::lock_guard lk(mu);
        out.ends[s] = std::move(e);
        const std::size_t d = ++done;
        if (opt.progress)
          opt.progress->update(double(d) / double(starts.size()),
                               fmt::format("multistart {}/{}: cost {:.6g}", d, starts.size(),
                                           out.ends[s].cost));
      } catch (...) {
        std::lock_guard lk(mu);
        if (!error) error = std::current_exception();
        next = starts.size();
      }
    }
  };
  std::vector<std::thread> threads;
  for (int t = 0; t < std::max(1, opt.concurrent); ++t) threads.emplace_back(worker);
  for (auto& t : threads) t.join();
  if (error) std::rethrow_exception(error);
  std::stable_sort(out.ends.begin(), out.ends.end(),
                   [](const StartEnd& a, const StartEnd& b) { return a.cost < b.cost; });
  const double best = out.ends.empty() ? INFINITY : out.ends.front().cost;
  for (const auto& e : out.ends) out.reached_best += e.usable && e.cost <= best + tolerance;
  return out;
}

}  // namespace burrbench::calibration
