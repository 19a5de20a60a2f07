#include "burrbench/model/verification.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "burrbench/model/job_queue.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::model {
namespace {

namespace ds = data_schema;

struct Level {
  const char* name;
  int voxel;     // 0 = l, +2 = split by 2 (l/2), −2 = merged by 2 (2l)
  double step;   // × Δt
};
constexpr std::array<Level, 4> kLevels{{{"l", 0, 1.0}, {"l/2", 2, 1.0}, {"2l", -2, 1.0}, {"dt/2", 0, 0.5}}};
constexpr std::size_t kFine = 1;  // kLevels' l/2

// The part of a sample that the burr reaches in the recordings replayed on it: the box of
// their burr centres widened by the radius and 4 voxels (2 at the merged level), with its
// corners on even voxel indices, so that merging by 2 groups the same voxels as on the
// whole sample. A lab's micro-CT holds far more bone than one drilling reaches; split by 2
// for the l/2 level, the whole of it can exceed the memory budget and costs 8× its
// voxels in page faults alone (docs/calibration.md "Discretization").
ds::SampleVolume within_reach(const ds::SampleVolume& s, const std::vector<const AlignedRecording*>& recs) {
  glm::dvec3 lo_mm(INFINITY), hi_mm(-INFINITY);
  for (const AlignedRecording* r : recs) {
    const Trajectory tr = r->trajectory(r->lag_s, 0.0);
    const double margin = r->radius_mm + 4 * s.voxel_mm;
    for (const glm::dvec3& c : tr.path_centres_vol_mm()) {
      lo_mm = glm::min(lo_mm, c - margin);
      hi_mm = glm::max(hi_mm, c + margin);
    }
  }
  std::array<std::size_t, 3> lo{}, hi{};
  for (int a = 0; a < 3; ++a) {
    const std::size_t ua = std::size_t(a), n = s.dims[ua];
    // Voxel i covers centre ± l/2: the first that reaches lo_mm, the last that reaches hi_mm.
    const double u0 = std::floor((lo_mm[a] - s.origin_mm[a]) / s.voxel_mm), u1 = std::ceil((hi_mm[a] - s.origin_mm[a]) / s.voxel_mm);
    if (!std::isfinite(u0) || !std::isfinite(u1) || u1 < 0 || u0 >= double(n)) return s;  // nothing in reach: as it is
    lo[ua] = u0 <= 0 ? 0 : std::size_t(u0) & ~std::size_t(1);
    hi[ua] = std::min(n, (std::size_t(std::max(0.0, u1)) + 2) & ~std::size_t(1));
  }
  if (lo == std::array<std::size_t, 3>{} && hi == s.dims) return s;
  return ds::import::crop_voxels(s, lo, hi);
}

double rms_diff(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b,
                const std::vector<std::uint8_t>& use) {
  double s = 0;
  std::size_t n = 0;
  for (std::size_t j = 0; j < a.size(); ++j)
    if (use[j]) {
      const glm::dvec3 d = a[j] - b[j];
      s += glm::dot(d, d);
      ++n;
    }
  return n ? std::sqrt(s / double(3 * n)) : 0.0;
}

}  // namespace

RichardsonEstimate richardson(double d_coarse, double d_fine) {
  RichardsonEstimate r;
  const double c = std::abs(d_coarse), f = std::abs(d_fine);
  if (f > 0 && c > f && d_coarse * d_fine > 0) {
    r.order = std::log2(c / f);
    const double p = std::clamp(r.order, 0.5, 4.0);
    r.error = f * std::exp2(p) / (std::exp2(p) - 1);
  } else {
    r.error = std::max(c, f);
  }
  return r;
}

std::string ConvergenceStudy::verdict() const {
  if (recordings.empty()) return "no recordings were replayed";
  if (!std::isfinite(sigma_N))
    return fmt::format("estimated discretization error in force {:.3g} N (recording {}); the sensor "
                       "noise is unknown (no sensor.sigma_N and too few samples without contact)",
                       largest_error_N, worst_recording);
  if (below_noise())
    return fmt::format("the estimated discretization error in force ({:.3g} N, recording {}) is below "
                       "the sensor noise ({:.3g} N): the voxel size and step resolve the force",
                       largest_error_N, worst_recording, sigma_N);
  return fmt::format("the estimated discretization error in force ({:.3g} N, recording {}) exceeds the "
                     "sensor noise ({:.3g} N, ×{:.1f}): constants fitted at this voxel size carry a "
                     "discretization bias; refine the sample or read the fit's discretization check",
                     largest_error_N, worst_recording, sigma_N, largest_error_N / sigma_N);
}

namespace {
// 1.4826·MAD of the components' deviations from their per-recording medians.
std::optional<double> mad_sigma(const std::vector<std::vector<std::vector<double>>>& by_rec_component,
                                std::size_t components, std::size_t& samples_used) {
  std::vector<double> dev;
  for (const auto& rec : by_rec_component)
    for (auto v : rec) {
      if (v.size() < 10) continue;
      std::nth_element(v.begin(), v.begin() + long(v.size() / 2), v.end());
      const double med = v[v.size() / 2];
      for (double x : v) dev.push_back(std::abs(x - med));
    }
  samples_used = dev.size() / components;
  if (dev.size() < 10 * components) return std::nullopt;
  std::nth_element(dev.begin(), dev.begin() + long(dev.size() / 2), dev.end());
  const double s = 1.4826 * dev[dev.size() / 2];
  return s > 0 ? std::optional<double>(s) : std::nullopt;
}
}  // namespace

std::optional<double> no_contact_sigma_N(const std::vector<std::vector<glm::dvec3>>& no_contact,
                                         std::size_t& samples_used) {
  std::vector<std::vector<std::vector<double>>> c;
  for (const auto& rec : no_contact) {
    c.emplace_back(3);
    for (const auto& f : rec)
      for (int a = 0; a < 3; ++a) c.back()[std::size_t(a)].push_back(f[a]);
  }
  return mad_sigma(c, 3, samples_used);
}

std::optional<double> no_contact_sigma(const std::vector<std::vector<double>>& no_contact, std::size_t& samples_used) {
  std::vector<std::vector<std::vector<double>>> c;
  for (const auto& rec : no_contact) c.push_back({rec});
  return mad_sigma(c, 1, samples_used);
}

ConvergenceStudy verify_convergence(const Experiment& e, const ModelParams& params,
                                    const VerifyOptions& options, Progress* progress) {
  if (!(options.step_s >= 0) || !std::isfinite(options.step_s))
    throw InputError("command line", "--step-us", "a step ≥ 0 (µs; 0 = half the sample period)");
  BURRBENCH_CHECK(options.threads >= 1, "verify_convergence needs at least one thread");
  ConvergenceStudy out;
  out.quadrature = options.quadrature;
  // The sample at each voxel level, built once (recordings of one sample share it).
  // Each cropped to the part its recordings reach (within_reach).
  std::map<std::string, std::array<ds::SampleVolume, 3>> samples;
  for (const auto& r : e.recordings) {
    if (samples.count(r.sample_id)) continue;
    std::vector<const AlignedRecording*> on_it;
    for (const auto& q : e.recordings)
      if (q.sample_id == r.sample_id) on_it.push_back(&q);
    const auto& whole = e.samples.at(r.sample_id);
    ds::SampleVolume s = options.crop ? within_reach(whole, on_it) : whole;
    out.reach.push_back({r.sample_id, whole.dims, s.dims});
    ds::SampleVolume fine = ds::import::split_voxels(s, 2), coarse = ds::import::merge_voxels(s, 2);
    samples[r.sample_id] = {std::move(s), std::move(fine), std::move(coarse)};
    for (const auto& [id, name] : whole.classes) out.classes[id] = name;
  }
  const std::size_t n = e.recordings.size(), L = kLevels.size();
  auto sample_at = [&](const AlignedRecording& r, const Level& lv) -> const ds::SampleVolume& {
    return samples.at(r.sample_id)[lv.voxel == 0 ? 0 : lv.voxel > 0 ? 1 : 2];
  };
  std::vector<double> dt(n);
  for (std::size_t i = 0; i < n; ++i)
    dt[i] = replay_step_s(options.step_s, e.recordings[i].t_s);

  // Every (recording, level) replay is independent: `threads` of them run at once, at most
  // one at l/2 (its volume holds 8× the voxels, and it is the longest: the l/2 replays
  // are queued first so that they run back to back beside the others).
  std::vector<std::size_t> jobs;  // recording i at level k: i·L + k
  for (std::size_t i = 0; i < n; ++i) jobs.push_back(i * L + kFine);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t k = 0; k < L; ++k)
      if (k != kFine) jobs.push_back(i * L + k);
  std::vector<RecordingPrediction> pred(n * L);
  std::vector<double> wall(n * L, 0.0);
  std::mutex mu;  // the progress line and its count of finished replays
  std::size_t finished = 0;
  // A failure reports the first failing replay in recording and level order, as one thread
  // would.
  run_job_queue(
      n * L, jobs, options.threads,
      [&](std::size_t, std::size_t j) {
        const std::size_t i = j / L, k = j % L;
        const AlignedRecording& r = e.recordings[i];
        const Level& lv = kLevels[k];
        const ds::SampleVolume& s = sample_at(r, lv);
        if (progress) {
          const std::lock_guard<std::mutex> lock(mu);
          progress->update(double(finished) / double(jobs.size()),
                           fmt::format("{}: {} (voxel {:.4g} mm, step {:.4g} µs)", r.id, lv.name, s.voxel_mm,
                                       1e6 * dt[i] * lv.step));
        }
        try {
          Volume vol = Volume::from_sample(s);
          PredictOptions po;
          po.replay.step_s = dt[i] * lv.step;
          po.replay.quadrature = options.quadrature;
          po.replay.erosion = options.erosion;
          const auto t0 = std::chrono::steady_clock::now();
          pred[j] = predict(r, vol, params, po);
          wall[j] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          const std::lock_guard<std::mutex> lock(mu);
          ++finished;
        } catch (const InputError& err) {
          throw err.in(fmt::format("recording {} at {}", r.id, lv.name));
        }
      },
      [&](std::size_t j) { return j % L == kFine; });

  std::vector<std::vector<glm::dvec3>> quiet;  // measured force without contact, per recording
  for (std::size_t i = 0; i < n; ++i) {
    const AlignedRecording& r = e.recordings[i];
    RecordingConvergence rc;
    rc.id = r.id;
    std::vector<std::uint8_t> use = r.use;
    if (std::none_of(use.begin(), use.end(), [](auto u) { return u != 0; })) use.assign(use.size(), 1);
    rc.samples = std::size_t(std::count(use.begin(), use.end(), 1));
    std::vector<std::vector<glm::dvec3>> force(L);
    for (std::size_t k = 0; k < L; ++k) {
      const Level& lv = kLevels[k];
      const RecordingPrediction& p = pred[i * L + k];
      LevelReplay lr;
      lr.level = lv.name;
      lr.voxel_mm = sample_at(r, lv).voxel_mm;
      lr.step_s = dt[i] * lv.step;
      lr.removed_mm3 = p.removed_mm3;
      lr.wall_s = wall[i * L + k];
      for (std::size_t j = 0; j < p.force_burr_vol_N.size(); ++j)
        if (use[j]) lr.peak_N = std::max(lr.peak_N, glm::length(p.force_burr_vol_N[j]));
      force[k] = p.force_burr_vol_N;
      lr.rms_change_N = k == 0 ? 0.0 : rms_diff(force[k], force[0], use);
      for (std::size_t j = 0; k > 0 && j < force[k].size(); ++j)
        if (use[j]) lr.max_change_N = std::max(lr.max_change_N, glm::length(force[k][j] - force[0][j]));
      if (k == 0) {
        quiet.emplace_back();
        for (std::size_t j = 0; j < p.class_mask.size(); ++j)
          if (use[j] && p.class_mask[j] == 0) quiet.back().push_back(r.force_sensor_N[j]);
      }
      rc.levels.push_back(lr);
    }
    // Levels: 0 = l, 1 = l/2, 2 = 2l, 3 = Δt/2. RMS norms of the changes.
    rc.voxel = richardson(rms_diff(force[2], force[0], use), rms_diff(force[0], force[1], use));
    rc.step_error_N = 2 * rc.levels[3].rms_change_N;
    rc.error_N = std::hypot(rc.voxel.error, rc.step_error_N);
    for (std::size_t c = 0; c < std::size_t(kMaxClasses); ++c)
      rc.removed[c] = richardson(rc.levels[2].removed_mm3[c] - rc.levels[0].removed_mm3[c],
                                 rc.levels[0].removed_mm3[c] - rc.levels[1].removed_mm3[c]);
    if (rc.error_N >= out.largest_error_N) {
      out.largest_error_N = rc.error_N;
      out.worst_recording = rc.id;
    }
    out.recordings.push_back(std::move(rc));
  }
  if (options.sigma_N) {
    out.sigma_N = *options.sigma_N;
    out.sigma_source = "given";
  } else if (e.manifest.sensor.sigma_N) {
    out.sigma_N = *e.manifest.sensor.sigma_N;
    out.sigma_source = "manifest (sensor.sigma_N)";
  } else {
    std::size_t quiet_n = 0;
    if (const auto s = no_contact_sigma_N(quiet, quiet_n)) {
      out.sigma_N = *s;
      out.sigma_source = fmt::format("estimated from {} no-contact samples (1.4826·MAD)", quiet_n);
    } else {
      out.sigma_source = "unknown (no sensor.sigma_N, too few no-contact samples)";
    }
  }
  if (progress) progress->finish(out.verdict());
  return out;
}

nlohmann::json to_json(const ConvergenceStudy& s) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json classes = nlohmann::json::object();
  for (const auto& [id, name] : s.classes) classes[std::to_string(id)] = name;
  nlohmann::json recs = nlohmann::json::array();
  for (const auto& r : s.recordings) {
    nlohmann::json levels = nlohmann::json::array();
    for (const auto& L : r.levels) {
      nlohmann::json removed = nlohmann::json::object();
      for (const auto& [id, name] : s.classes) removed[name] = L.removed_mm3[id];
      levels.push_back({{"level", L.level}, {"voxel_mm", L.voxel_mm}, {"step_us", 1e6 * L.step_s},
                        {"rms_change_N", L.rms_change_N}, {"max_change_N", L.max_change_N}, {"peak_N", L.peak_N},
                        {"removed_mm3", removed}, {"wall_s", L.wall_s}});
    }
    nlohmann::json removed = nlohmann::json::object();
    for (const auto& [id, name] : s.classes)
      removed[name] = {{"error_mm3", r.removed[id].error}, {"order", num(r.removed[id].order)}};
    recs.push_back({{"id", r.id}, {"samples", r.samples}, {"levels", levels},
                    {"voxel_order", num(r.voxel.order)}, {"voxel_error_N", r.voxel.error},
                    {"step_error_N", r.step_error_N}, {"error_N", r.error_N},
                    {"removed_error", removed}});
  }
  nlohmann::json reach = nlohmann::json::array();
  for (const auto& r : s.reach) reach.push_back({{"sample", r.sample_id}, {"dims", r.dims}, {"replayed_dims", r.replayed_dims}});
  return {{"quadrature", quadrature_name(s.quadrature)},
          {"recordings", recs},
          {"reach", reach},
          {"sigma_N", num(s.sigma_N)},
          {"sigma_source", s.sigma_source},
          {"largest_error_N", s.largest_error_N},
          {"worst_recording", s.worst_recording},
          {"below_noise", std::isfinite(s.sigma_N) ? nlohmann::json(s.below_noise()) : nlohmann::json(nullptr)},
          {"verdict", s.verdict()},
          {"method", "replays at (l, dt), (l/2, dt), (2l, dt), (l, dt/2); Richardson on the RMS force "
                     "change (observed order, clamped to [0.5, 4]) for the voxel size, first order "
                     "assumed for the step"}};
}

}  // namespace burrbench::model
