// Speed of the burr–bone kernel (issue 3 targets; bench/model.sh prints the table).
// Single thread. Each figure is the time of one force + erosion step (or one replay).
#include <cmath>
#include <vector>

#include <benchmark/benchmark.h>

#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/model.hpp"

namespace bm = burrbench::model;

namespace {

// Flat bone, surface on a voxel face at height zs: all voxels with centre below it.
bm::Volume flat(std::size_t nx, std::size_t ny, std::size_t nz, double l, double zs) {
  burrbench::data_schema::SampleVolume s;
  s.dims = {nx, ny, nz};
  s.voxel_mm = l;
  s.labels.assign(s.voxel_count(), 0);
  s.fraction.assign(s.voxel_count(), 0.0f);
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x)
        if (double(z) * l < zs) {
          s.labels[s.index(x, y, z)] = z * 3 < nz ? 2 : 1;  // compact over trabecular
          s.fraction[s.index(x, y, z)] = 1.0f;
        }
  return bm::Volume::from_sample(s);
}

bm::ModelParams params() {
  bm::ModelParams p;
  p.by_label[1] = {200.0, 12.0, 0.4};
  p.by_label[2] = {80.0, 5.0, 0.6};
  return p;
}

// One force + erosion step at 1 kHz while sliding slowly over the surface with the burr's
// lowest point `depth` below it (depth > 2R: the whole burr is buried, its centre
// depth − R below the surface). The undo log is rolled
// back every 4096 steps so the surface stays intact over any number of iterations.
void run_steps(benchmark::State& st, double R, double l, double depth,
               bm::Quadrature q = bm::Quadrature::kLens) {
  // Room for the burr buried a full diameter below the surface, inside the volume.
  const std::size_t n = std::size_t(std::ceil(6 * R / l)) + 8;
  const double zs = (double(n) / 2 - 0.5) * l;
  bm::Volume v = flat(n, n, n, l, zs);
  const auto prm = params();
  std::array<double, bm::kMaxClasses> removed{}, energy{};
  bm::KernelScratch scratch;  // as a replay holds one: the table is built once
  const double c = 0.5 * l * double(n);
  v.begin_undo();
  std::size_t i = 0;
  double fsum = 0;
  for (auto _ : st) {
    const double s = 0.37 * l * std::sin(0.013 * double(i));  // slide within ±0.37 l
    const glm::dvec3 p(c + s, c + 0.5 * s, zs + R - depth);
    const bm::ContactResult r = bm::step(v, scratch, p, {0, 2000.0, 500.0}, R, prm, 1e-3, removed, &energy, q);
    fsum += r.force_N.z;
    if (++i % 4096 == 0) {
      v.rollback();
      v.begin_undo();
    }
  }
  benchmark::DoNotOptimize(fsum);
  st.counters["us_per_step"] =
      benchmark::Counter(double(st.iterations()), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}

void BM_paper_R075_l03_depth_R4(benchmark::State& st) { run_steps(st, 0.75, 0.3, 0.75 / 4); }
void BM_microct_R1_l005_depth_R4(benchmark::State& st) { run_steps(st, 1.0, 0.05, 0.25); }
void BM_microct_R1_l005_buried(benchmark::State& st) { run_steps(st, 1.0, 0.05, 2.0 + 0.25); }
// The cube quadrature (closed-form cut of every voxel the burr's surface crosses) on the
// same steps: its cost against the lens's table lookups (bench/model.sh prints the ratio).
void BM_cube_microct_R1_l005_depth_R4(benchmark::State& st) {
  run_steps(st, 1.0, 0.05, 0.25, bm::Quadrature::kCube);
}

// Replay of 15 s at 1 kHz, R/l = 10 (R = 0.5 mm, l = 0.05 mm): plunge to R/2 while sweeping
// ±2.5 mm along x at 0.5 Hz (up to 7.9 mm/s) and slowly along y, eroding.
void BM_replay_15s_1kHz_R_over_l_10(benchmark::State& st) {
  const double R = 0.5, l = 0.05;
  const std::size_t nx = 160, ny = 80, nz = 60;
  const double zs = 39.5 * l;
  const bm::Volume start = flat(nx, ny, nz, l, zs);
  bm::Trajectory tr;
  for (int k = 0; k < 15000; ++k) {
    const double t = k * 1e-3;
    const double depth = std::min(0.25, 0.1 * t);                // plunge at 0.1 mm/s to R/2
    const double x = 4.0 + 2.5 * std::sin(2 * M_PI * 0.5 * t);  // ±2.5 mm sweeps
    const double y = 2.0 + 0.5 * std::sin(2 * M_PI * 0.13 * t);
    tr.t_s.push_back(t);
    tr.centre_vol_mm.push_back({x, y, zs + R - depth});
    tr.omega_vol_rad_s.push_back({0, 0, 2 * M_PI * 30000 / 60});  // 30 000 rpm
  }
  bm::Volume v = start;
  double wall = 0;
  for (auto _ : st) {
    const bm::ReplayResult r = bm::replay(v, R, params(), tr, {}, /*restore=*/true);
    benchmark::DoNotOptimize(r.samples.data());
    wall += r.wall_s;
  }
  st.counters["realtime_factor"] = 15.0 * double(st.iterations()) / wall;
}

}  // namespace

BENCHMARK(BM_paper_R075_l03_depth_R4)->MinTime(1.0);
BENCHMARK(BM_microct_R1_l005_depth_R4)->MinTime(1.0);
BENCHMARK(BM_microct_R1_l005_buried)->MinTime(1.0);
BENCHMARK(BM_cube_microct_R1_l005_depth_R4)->MinTime(1.0);
BENCHMARK(BM_replay_15s_1kHz_R_over_l_10)->Iterations(3)->Unit(benchmark::kMillisecond);
BENCHMARK_MAIN();
