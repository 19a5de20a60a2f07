#include "burrbench/model/replay.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <string>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "direction_plan.hpp"
#include "tangent.hpp"

namespace burrbench::model {

std::vector<glm::dvec3> Trajectory::path_centres_vol_mm() const {
  std::vector<glm::dvec3> out = centre_vol_mm;
  for (const auto& v : vias) out.push_back(v.centre_vol_mm);
  return out;
}

namespace {

void check_trajectory(const Trajectory& tr) {
  const std::string file = "trajectory";
  const std::size_t n = tr.t_s.size();
  if (tr.centre_vol_mm.size() != n || tr.omega_vol_rad_s.size() != n)
    throw InputError(file, "centre_vol_mm/omega_vol_rad_s",
                     "as many entries as t_s (" + std::to_string(n) + ")");
  for (std::size_t i = 0; i < n; ++i) {
    const auto& c = tr.centre_vol_mm[i];
    const auto& w = tr.omega_vol_rad_s[i];
    if (!std::isfinite(tr.t_s[i]) || !std::isfinite(c.x + c.y + c.z) ||
        !std::isfinite(w.x + w.y + w.z))
      throw InputError(file, "sample " + std::to_string(i), "finite time, centre and omega");
    if (i > 0 && !(tr.t_s[i] > tr.t_s[i - 1]))
      throw InputError(file, "t_s[" + std::to_string(i) + "]", "strictly increasing times",
                       fmt::format("{} after {}", tr.t_s[i], tr.t_s[i - 1]));
  }
  for (std::size_t v = 0; v < tr.vias.size(); ++v) {
    const auto& via = tr.vias[v];
    const std::string field = "vias[" + std::to_string(v) + "]";
    if (!std::isfinite(via.t_s) || !std::isfinite(via.centre_vol_mm.x + via.centre_vol_mm.y + via.centre_vol_mm.z) ||
        !std::isfinite(via.omega_vol_rad_s.x + via.omega_vol_rad_s.y + via.omega_vol_rad_s.z))
      throw InputError(file, field, "finite time, centre and omega");
    // Inside its interval (before the first sample for kBeforeFirst) and later than the via
    // before it: with the samples' times increasing, that puts them in interval order too.
    const bool lead = via.after == Trajectory::Via::kBeforeFirst;
    const bool inside = n > 0 && (lead ? via.t_s < tr.t_s[0]
                                       : via.after + 1 < n && via.t_s > tr.t_s[via.after] && via.t_s < tr.t_s[via.after + 1]);
    if (!inside || (v > 0 && !(via.t_s > tr.vias[v - 1].t_s)))
      throw InputError(file, field, "a time inside its interval, after the via before it",
                       lead ? fmt::format("t = {} before the first sample", via.t_s)
                            : fmt::format("t = {} after sample {}", via.t_s, via.after));
  }
}

}  // namespace

double default_step_s(const std::vector<double>& t) {
  if (t.size() < 2) return 0;
  std::vector<double> dt(t.size() - 1);
  for (std::size_t i = 1; i < t.size(); ++i) dt[i - 1] = t[i] - t[i - 1];
  auto mid = dt.begin() + std::ptrdiff_t(dt.size() / 2);
  std::nth_element(dt.begin(), mid, dt.end());
  return 0.5 * *mid;
}

double replay_step_s(double step_s, const std::vector<double>& t) {
  const double half_period = default_step_s(t);
  if (step_s <= 0) return half_period;
  return half_period > 0 ? std::min(step_s, 2 * half_period) : step_s;
}

ReplayResult replay(Volume& vol, double radius_mm, const ModelParams& params,
                    const Trajectory& tr, const ReplayOptions& opt, bool restore,
                    Progress* progress) {
  check_trajectory(tr);
  if (!(radius_mm > 0) || !std::isfinite(radius_mm))
    throw InputError("replay", "radius_mm", "finite burr radius > 0 mm", std::to_string(radius_mm));
  if (!(opt.step_s >= 0) || !std::isfinite(opt.step_s))
    throw InputError("replay", "step_s", "finite step >= 0 s (0 = half the sample period)",
                     std::to_string(opt.step_s));
  const auto t_start = std::chrono::steady_clock::now();
  ReplayResult res;
  const std::size_t n = tr.t_s.size();
  res.samples.resize(n);
  if (n == 0) return res;
  const double h = replay_step_s(opt.step_s, tr.t_s);
  // Refuse step counts that could not finish (e.g. a 1 ns step over an hour).
  const double span_s = tr.t_s.back() - std::min(tr.t_s.front(), tr.vias.empty() ? INFINITY : tr.vias.front().t_s);
  if (n > 1 && span_s / h > 1e9)
    throw InputError("replay", "step_s", "at most 1e9 internal steps", fmt::format("{} s over {} s", h, span_s));
  // The kernel's working space, this replay's own: replays of copies may run side by side.
  KernelScratch scratch;
  // Forward sensitivities: a tangent state beside the undo log (it lives for this replay).
  // It carries only the directions that do not follow exactly from others (direction_plan.hpp).
  const bool sens = opt.directions && opt.sensitivities;
  std::unique_ptr<detail::TangentState> tan;
  detail::DirectionPlan plan;
  Sensitivities carried;
  std::vector<std::uint32_t> reached;
  std::vector<glm::dvec3> dp, dF, dT;
  const bool moments = opt.moment_sensitivities;
  if (sens) {
    const auto& dirs = *opt.directions;
    for (std::size_t j = 0; j < dirs.size(); ++j)
      if (dirs[j].kind == Direction::Kind::kPath && dirs[j].dcentre_vol_mm.size() != n + tr.vias.size())
        throw InputError("replay", fmt::format("directions[{}].dcentre_vol_mm", j),
                         fmt::format("one entry per trajectory sample and via ({})", n + tr.vias.size()),
                         std::to_string(dirs[j].dcentre_vol_mm.size()));
    if (dirs.size() > kMaxDirections)
      throw InputError("replay", "directions", fmt::format("at most {}", kMaxDirections),
                       std::to_string(dirs.size()));
    plan = detail::plan_directions(dirs, params, vol.bone_volume_by_class(), opt.derive_directions);
    const std::size_t P = plan.carried.size();
    tan = std::make_unique<detail::TangentState>(vol, scratch, plan.carried, params);
    carried.dforce_N.assign(P, std::vector<glm::dvec3>(n, glm::dvec3(0)));
    reached.assign(n, 0);
    dp.assign(P, glm::dvec3(0));
    dF.assign(P, glm::dvec3(0));
    if (moments) {
      carried.dmoment_Nmm.assign(P, std::vector<glm::dvec3>(n, glm::dvec3(0)));
      dT.assign(P, glm::dvec3(0));
    }
  }
  // ∂p/∂θ_j at a fraction f of the way from path point a to b (linear, like the centre;
  // points numbered as in path_centres_vol_mm).
  auto path_at = [&](std::size_t a, std::size_t b, double f) {
    for (std::size_t j = 0; j < plan.carried.size(); ++j) {
      if (plan.carried[j].kind != Direction::Kind::kPath) continue;
      const auto& d = (*opt.directions)[plan.requested_of[j]].dcentre_vol_mm;
      dp[j] = f == 0 ? d[a] : d[a] + f * (d[b] - d[a]);
    }
  };
  struct Point { std::size_t index; double t_s; glm::dvec3 centre, omega; };
  auto sample_point = [&](std::size_t k) { return Point{k, tr.t_s[k], tr.centre_vol_mm[k], tr.omega_vol_rad_s[k]}; };
  std::vector<Point> points;  // what is eroded next: an interval's samples and its vias, or the lead-in
  std::size_t next_via = 0;
  auto record = [&](std::size_t k) {
    for (std::size_t j = 0; j < dF.size(); ++j) carried.dforce_N[j][k] = dF[j];
    for (std::size_t j = 0; j < dT.size(); ++j) carried.dmoment_Nmm[j][k] = dT[j];
    reached[k] = tan->reached_classes();
  };
  // Erodes along `points` (each piece in sub-steps: forward Euler, the force at a
  // sub-step's start erodes over the sub-step). With `report` < n, the first sub-step's
  // contact is the one reported at sample `report`; the others just advance the tangents.
  constexpr std::size_t kNoReport = std::size_t(-1);
  auto erode_along = [&](std::size_t report) {
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      const Point &a = points[i], &b = points[i + 1];
      const double T = b.t_s - a.t_s;
      const std::size_t m = std::max<std::size_t>(1, std::size_t(std::ceil(T / h - 1e-9)));
      const double dt = T / double(m);
      const glm::dvec3 dpk = b.centre - a.centre, dw = b.omega - a.omega;
      for (std::size_t j = 0; j < m; ++j) {
        const double f = double(j) / double(m);
        const bool reported = report != kNoReport && i == 0 && j == 0;
        ContactResult c = step(vol, scratch, a.centre + f * dpk, a.omega + f * dw, radius_mm, params, dt,
                               res.removed_mm3, &res.friction_energy_mJ, opt.quadrature);
        if (sens) {
          path_at(a.index, b.index, f);
          tan->differentiate(vol, c, dp.data(), true, reported ? dF.data() : nullptr,
                             reported && moments ? dT.data() : nullptr);
          if (reported) record(report);
        }
        if (reported) res.samples[report].contact = c;
        ++res.steps;
      }
      if (opt.cancel && i % 64 == 63) opt.cancel->check();
    }
  };
  auto via_point = [&](std::size_t v) {
    return Point{n + v, tr.vias[v].t_s, tr.vias[v].centre_vol_mm, tr.vias[v].omega_vol_rad_s};
  };
  if (restore) vol.begin_undo();
  try {
    // The path before the first sample (a sensor that started late): eroded, not reported.
    points.clear();
    for (; next_via < tr.vias.size() && tr.vias[next_via].after == Trajectory::Via::kBeforeFirst; ++next_via)
      points.push_back(via_point(next_via));
    if (!points.empty() && opt.erosion) {
      points.push_back(sample_point(0));
      erode_along(kNoReport);
    }
    for (std::size_t k = 0; k < n; ++k) {
      if (opt.cancel && k % 64 == 0) opt.cancel->check();
      if (k + 1 == n || !opt.erosion) {
        res.samples[k].contact =
            evaluate(vol, scratch, tr.centre_vol_mm[k], tr.omega_vol_rad_s[k], radius_mm, params, opt.quadrature);
        if (sens) {
          path_at(k, k, 0);
          tan->differentiate(vol, res.samples[k].contact, dp.data(), false, dF.data(),
                            moments ? dT.data() : nullptr);
          record(k);
        }
      }
      if (k + 1 == n) break;
      if (!opt.erosion) continue;
      // The interval's pieces: from sample k through its vias to sample k + 1.
      points.assign(1, sample_point(k));
      for (; next_via < tr.vias.size() && tr.vias[next_via].after == k; ++next_via) points.push_back(via_point(next_via));
      points.push_back(sample_point(k + 1));
      erode_along(k);
      if (progress && (k % 1024 == 0))
        progress->update(double(k) / double(n), fmt::format("sample {}/{}", k, n));
    }
  } catch (...) {
    if (restore) vol.rollback();
    throw;
  }
  if (sens) {
    carried.dremoved_mm3 = tan->dremoved_mm3();
    carried.tangent_voxels = tan->tangent_voxels();
    std::vector<const ContactResult*> contacts(n);
    for (std::size_t k = 0; k < n; ++k) contacts[k] = &res.samples[k].contact;
    detail::assemble_directions(plan, params, carried, contacts, reached, moments,
                                *opt.sensitivities);
  }
  if (restore) vol.rollback();
  res.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  if (progress)
    progress->finish(fmt::format("replayed {} samples, {} steps in {:.3f} s", n, res.steps,
                                 res.wall_s));
  return res;
}

}  // namespace burrbench::model
