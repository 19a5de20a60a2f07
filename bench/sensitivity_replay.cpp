// Cost of the forward sensitivities (sensitivity.hpp): a replay with N directions against
// a plain replay, at R/l = 10 and 20. bench/sensitivity.sh prints the ratios.
// Scene: flat bone, a 3 s plunge-and-sweep at 1 kHz (R = 1 mm), eroding; directions as in
// a calibration: ln α, ln C1, ln μ of the class, lag (−velocity) and depth (shaft axis).
#include <benchmark/benchmark.h>

#include <cmath>

#include "burrbench/model/replay.hpp"
#include "burrbench/model/volume.hpp"

namespace bm = burrbench::model;
namespace ds = burrbench::data_schema;

namespace {

bm::Volume flat(double l) {
  ds::SampleVolume s;
  s.voxel_mm = l;
  s.dims = {std::size_t(std::lround(6 / l)), std::size_t(std::lround(4 / l)), std::size_t(std::lround(2 / l))};
  s.labels.assign(s.voxel_count(), 1);
  s.fraction.assign(s.voxel_count(), 1.0f);
  s.segmentation_json = "{}";
  return bm::Volume::from_sample(s);
}

bm::Trajectory path() {
  bm::Trajectory tr;
  for (int k = 0; k < 3000; ++k) {
    const double t = k * 1e-3, depth = std::min(0.3, 0.6 * t);
    tr.t_s.push_back(t);
    tr.centre_vol_mm.push_back({1.5 + 3.0 * std::max(0.0, t - 0.5) / 2.5, 2.0, 2.0 + 1.0 - depth});
    tr.omega_vol_rad_s.push_back(4000.0 * glm::dvec3(0.8, 0, 0.6));
  }
  return tr;
}

std::vector<bm::Direction> directions(int n, const bm::Trajectory& tr) {
  using K = bm::Direction::Kind;
  std::vector<bm::Direction> all{{K::kLogAlpha, 1, {}}, {K::kLogC1, 1, {}}, {K::kLogMu, 1, {}}};
  std::vector<glm::dvec3> vel(tr.t_s.size()), axis(tr.t_s.size(), -glm::dvec3(0.8, 0, 0.6));
  for (std::size_t k = 1; k < vel.size(); ++k)
    vel[k] = -(tr.centre_vol_mm[k] - tr.centre_vol_mm[k - 1]) / (tr.t_s[k] - tr.t_s[k - 1]) * 1e-3;
  all.push_back({K::kPath, 0, vel});
  all.push_back({K::kPath, 0, axis});
  std::vector<bm::Direction> out;
  for (int j = 0; j < n; ++j) out.push_back(all[std::size_t(j) % all.size()]);
  return out;
}

// Args: R/l, directions (0 = plain replay).
void BM_replay(benchmark::State& st) {
  const double l = 1.0 / double(st.range(0));
  bm::Volume v = flat(l);
  const auto tr = path();
  bm::ModelParams prm;
  prm.by_label[1] = {1500.0, 16.0, 0.4};
  const auto dirs = directions(int(st.range(1)), tr);
  bm::Sensitivities sens;
  bm::ReplayOptions o;
  if (!dirs.empty()) {
    o.directions = &dirs;
    o.sensitivities = &sens;
  }
  for (auto _ : st) {
    const auto r = bm::replay(v, 1.0, prm, tr, o, true);
    benchmark::DoNotOptimize(r.samples.data());
  }
}

}  // namespace

BENCHMARK(BM_replay)->ArgsProduct({{10, 20}, {0, 1, 4, 8}})->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_MAIN();
