// Cost of the forward sensitivities (sensitivity.hpp): a replay with N directions against
// a plain replay, at R/l = 10 and 20. bench/sensitivity.sh prints the ratios.
// Scene: flat bone, class 1 over class 2 (the plunge reaches both), a 3 s plunge-and-sweep
// at 1 kHz (R = 1 mm), eroding. Directions in a calibration's order: ln α, ln C1, ln μ of
// class 1, lag (−velocity), depth (shaft axis), then ln α, ln C1, ln μ of class 2. The
// tangent pass carries fewer (ln μ follows from ln α, one ln C1 from the rest): the
// "carried" counter.
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
  for (std::size_t z = 0; z < s.dims[2]; ++z)  // class 2 below 1.85 mm (surface at 2 mm)
    if ((double(z) + 0.5) * l < 1.85)
      for (std::size_t i = 0; i < s.dims[0] * s.dims[1]; ++i) s.labels[z * s.dims[0] * s.dims[1] + i] = 2;
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
  for (const K k : {K::kLogAlpha, K::kLogC1, K::kLogMu}) all.push_back({k, 2, {}});
  std::vector<bm::Direction> out;
  for (int j = 0; j < n; ++j) out.push_back(all[std::size_t(j)]);
  return out;
}

// Args: R/l, directions (0 = plain replay), derive (0: every direction carried, as before
// the identities were used).
void BM_replay(benchmark::State& st) {
  const double l = 1.0 / double(st.range(0));
  bm::Volume v = flat(l);
  const auto tr = path();
  bm::ModelParams prm;
  prm.by_label[1] = {1500.0, 16.0, 0.4};
  prm.by_label[2] = {500.0, 8.0, 0.3};
  const auto dirs = directions(int(st.range(1)), tr);
  bm::Sensitivities sens;
  bm::ReplayOptions o;
  o.derive_directions = st.range(2) != 0;
  if (!dirs.empty()) {
    o.directions = &dirs;
    o.sensitivities = &sens;
  }
  for (auto _ : st) {
    const auto r = bm::replay(v, 1.0, prm, tr, o, true);
    benchmark::DoNotOptimize(r.samples.data());
  }
  // Directions the tangent pass carried (docs/model.md "Directions that follow from others").
  st.counters["carried"] = double(sens.carried_directions);
}

}  // namespace

BENCHMARK(BM_replay)->ArgsProduct({{10, 20}, {0, 1, 4, 8}, {1}})->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK(BM_replay)->ArgsProduct({{10, 20}, {8}, {0}})->Unit(benchmark::kMillisecond)->MinTime(1.0);
BENCHMARK_MAIN();
