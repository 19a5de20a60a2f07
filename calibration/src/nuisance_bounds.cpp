// Nuisances that ended at a bound (parameters.hpp NuisanceAtBound).
#include <fmt/format.h>

#include "burrbench/calibration/parameters.hpp"

namespace burrbench::calibration {

namespace {

// Which bound x[i] lies at, if any: within kNuisanceBoundShare of the range.
int at_bound(const Layout& L, const std::vector<double>& x, std::size_t i) {
  const double lo = L.lower(i), hi = L.upper(i), tol = kNuisanceBoundShare * (hi - lo);
  if (x[i] - lo <= tol) return -1;
  if (hi - x[i] <= tol) return 1;
  return 0;
}

constexpr const char* kMiss =
    "the constants, fitted so, can miss the truth by more than their intervals say (those hold it at the bound)";

}  // namespace

std::vector<NuisanceAtBound> nuisances_at_bounds(const Layout& L, const std::vector<double>& x) {
  std::vector<NuisanceAtBound> out;
  auto add = [&](int index, std::string text) {
    out.push_back({std::size_t(index), at_bound(L, x, std::size_t(index)) > 0, std::move(text)});
  };
  for (const auto& r : L.recordings()) {
    if (r.lag >= 0 && at_bound(L, x, std::size_t(r.lag)) != 0) {
      const bool up = at_bound(L, x, std::size_t(r.lag)) > 0;
      add(r.lag, fmt::format(
                     "Recording {}: the fitted lag ended at its {} bound ({:g} ms; [fit.nuisance] lag_bounds_ms = "
                     "[{:g}, {:g}]): the data want a lag beyond it, so each force was fitted against the burr's "
                     "position off by the rest, and {}. Widen lag_bounds_ms: a rig's delay includes its sensor's "
                     "filter and the polling.",
                     r.recording_id, up ? "upper" : "lower", x[std::size_t(r.lag)], r.lag_bounds_ms[0],
                     r.lag_bounds_ms[1], kMiss));
    }
    if (r.depth >= 0 && at_bound(L, x, std::size_t(r.depth)) != 0)
      add(r.depth, fmt::format(
                       "Recording {}: the fitted depth offset ended at its bound ({:+g} mm; |offset| ≤ R/2 = {:g} "
                       "mm): the burr's depth along the shaft is off by more than that, so {}. Check the tool "
                       "offset and the registration (`burrbench verify`).",
                       r.recording_id, x[std::size_t(r.depth)], r.depth_bound_mm, kMiss));
  }
  for (const auto& m : L.mountings())
    for (int k = 0; k < 6; ++k) {
      const std::size_t i = std::size_t(m.offset + k);
      if (at_bound(L, x, i) == 0) continue;
      add(int(i), fmt::format(
                      "Sample mounting {}: its pose correction ended at a bound ({} = {:+g} {}, bound ±{:g}): the "
                      "fiducial registration is off by more than the fit corrects, so {}. Check the fiducials "
                      "(`burrbench verify`).",
                      m.name, L.name(i).substr(m.name.size() + 1), x[i], k < 3 ? "rad" : "mm", L.upper(i), kMiss));
    }
  return out;
}

}  // namespace burrbench::calibration
