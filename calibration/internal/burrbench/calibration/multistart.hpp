#pragma once
// Global search: many local fits from a Latin hypercube of starts (docs/calibration.md
// "Global search"). Every start is first warmed by the cheap pre-fit at held geometry
// (Objective::prefit: C1, μ and the linear nuisances, with lag, depth and pose held and α
// following C1·μ); the most promising ones are then solved locally with every parameter
// free; the starts run concurrently on the shared replay pool. Every end point is kept:
// sorted by cost they are the waterfall plot.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "burrbench/calibration/objective.hpp"

namespace burrbench::calibration {

// n points in x: point 0 is `x0` (the manifest's start); points 1..n−1 a Latin hypercube,
// in ln θ, over the bounds of every free physics parameter (nuisances keep x0's values).
// Seeded: the same seed gives the same points.
std::vector<std::vector<double>> latin_hypercube_starts(const Layout& layout,
                                                        const std::vector<double>& x0, int n,
                                                        std::uint64_t seed);

struct StartEnd {
  int index = 0;                   // position in the list of starts
  std::vector<double> start, end;  // x (scaled) before the pre-fit and at the end
  double prefit_cost = 0, cost = 0;
  std::uint64_t iterations = 0;
  std::string termination;
  bool usable = false;
  // How it ended: at its pre-fit (not among the starts solved locally), its local solve
  // converging, or its local solve stopping before that (abandoned as hopeless, out of
  // iterations, failed).
  enum class Ending { kScreened, kConverged, kStopped } ending = Ending::kScreened;
};
const char* to_string(StartEnd::Ending e);  // "screened", "converged", "stopped"

// Usable ends first, each group by cost (stable): the order of MultistartOutcome::ends.
void sort_ends(std::vector<StartEnd>& ends);

// The ends of a search measured against its best optimum (cost `best_cost`; ends within
// `tolerance` of it reach it). An end above it whose every entry lies inside `box` (per x
// entry, the optimum's 95 % interval [lo, hi]; ±∞ where open or not a physics constant;
// empty: not known) ended in the optimum's neighbourhood, short of its bottom. Of the
// others, only one whose local solve converged is another minimum of the cost; one that
// stopped short of converging says nothing against the optimum.
struct SearchTally {
  int reached = 0;        // usable ends within tolerance of best_cost
  int near = 0;           // above it, every entry inside the box
  int higher_optima = 0;  // above it and outside the box, local solve converged
  int stopped_short = 0;  // above it and outside the box, local solve stopped before converging
};
inline bool reaches_best(const StartEnd& e, double best_cost, double tolerance) {
  return e.usable && e.cost <= best_cost + tolerance;
}
SearchTally tally(const std::vector<StartEnd>& ends, double best_cost, double tolerance,
                  const std::vector<std::pair<double, double>>& box = {});
std::string lone_optimum_warning(const SearchTally& t, int starts, int solved);

struct MultistartOptions {
  PrefitOptions prefit;       // C1, μ and the linear nuisances at held geometry (threads: set here)
  int iterations = 6;         // local solve with everything free
  // Only the `solved` starts with the lowest pre-fit cost get the local solve; the others
  // end at their pre-fit (termination "screened by pre-fit cost"). ≤ 0: all of them.
  int solved = 0;
  int concurrent = 2;         // starts solved at once
  // Of the local solves (Ceres's |Δcost|/cost). The search only has to find the basins:
  // the refinement polishes the best end at the default 1e-7.
  double function_tolerance = 1e-7;
  // Abandon a local solve that cannot reach the best pre-fit cost in its remaining
  // iterations (hopeless_start below); its end is kept with that termination.
  bool abandon_hopeless = true;
  // Per x entry: held at its start value in the local solves (empty: none). The search
  // holds the registration's pose correction: docs/calibration.md "Global search".
  std::vector<bool> hold;
  Progress* progress = nullptr;
};

struct MultistartOutcome {
  std::vector<StartEnd> ends;  // sorted by cost (unusable ones last)
  // Ends whose cost lies within `tolerance` of the best: "best optimum reached by k of N".
  int reached_best = 0;
  double tolerance = 0;
  int solved = 0;  // starts that got the local solve
};

// Whether a local solve, whose costs after each iteration are `costs` (entry 0: its start),
// is hopeless: stalled far above `reference` (the lowest pre-fit cost of all starts, which
// the best start's own solve can only lower). It is when, after at least 3 iterations,
// even twice its relative decrease over the last two iterations, kept up for all of the
// `max_iterations` still left, would leave it above `reference`. The best start is never
// hopeless (it starts at or below the reference); a start still descending fast is kept.
// Deterministic: it depends on the start's own costs and the pre-fit alone.
bool hopeless_start(const std::vector<double>& costs, int max_iterations, double reference);

// `tolerance` (cost units): ends within it of the best count as reaching the best optimum.
MultistartOutcome multistart(const Objective& obj, const std::vector<std::vector<double>>& starts,
                             const SampleWeights& w, const MultistartOptions& opt, double tolerance);

}  // namespace burrbench::calibration
