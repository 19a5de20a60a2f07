// Erosion: convergence in Δt, per-class energy balance, no stall on tiny decrements,
// α = ∞ disables it, only contact-disc voxels erode.
#include <cmath>

#include <gtest/gtest.h>

#include "test_paper_scenes.hpp"

namespace bm = burrbench::model;
namespace ds = burrbench::data_schema;

namespace {

// Flat bone, compact (label 1) in the top 2 voxel layers, trabecular (2) below.
ds::SampleVolume layered(double l) {
  ds::SampleVolume s = scenes::half_space(30, 16, 16, l, {0, 0, 1}, 9.5 * l);
  for (std::size_t z = 0; z < 16; ++z)
    for (std::size_t y = 0; y < 16; ++y)
      for (std::size_t x = 0; x < 30; ++x)
        if (s.labels[s.index(x, y, z)] != 0 && z < 8) s.labels[s.index(x, y, z)] = 2;
  return s;
}

bm::ModelParams layered_params(double a1, double a2) {
  bm::ModelParams p;
  p.by_label[1] = {a1, 12.0, 0.4};
  p.by_label[2] = {a2, 5.0, 0.6};
  return p;
}

// A sweep along x at a depth that reaches into both layers, then a plunge.
bm::Trajectory sweep(double l, double seconds = 0.4) {
  bm::Trajectory tr;
  const int n = int(seconds * 1000);
  for (int i = 0; i <= n; ++i) {
    const double t = i * 1e-3;
    tr.t_s.push_back(t);
    tr.centre_vol_mm.push_back({6 * l + 10.0 * t, 8.1 * l, 9.5 * l + 0.5 - 0.2 - 0.3 * t});
    tr.omega_vol_rad_s.push_back({0, 500.0, 200.0});
  }
  return tr;
}

}  // namespace

TEST(Erosion, HalvingTheStepChangesRemovedVolumeByLessThanOnePercent) {
  const double l = 0.1;
  const bm::Volume start = bm::Volume::from_sample(layered(l));
  const auto prm = layered_params(30.0, 15.0);
  const bm::Trajectory tr = sweep(l);
  double total[3] = {};
  for (int i = 0; i < 3; ++i) {
    bm::Volume v = start;
    bm::ReplayOptions o;
    o.step_s = 1e-3 / double(1 << i);  // 1 ms, 0.5 ms, 0.25 ms
    const auto r = bm::replay(v, 0.5, prm, tr, o);
    total[i] = r.removed_mm3[1] + r.removed_mm3[2];
  }
  std::printf("removed volume: dt 1 ms %.6g, 0.5 ms %.6g, 0.25 ms %.6g mm3\n", total[0], total[1], total[2]);
  ASSERT_GT(total[2], 1e-3);  // a real amount of bone was cut (≥ 1 voxel of 0.1 mm)
  EXPECT_LT(std::abs(total[1] / total[0] - 1), 0.01);
  EXPECT_LT(std::abs(total[2] / total[1] - 1), 0.01);
  // first-order convergence: the change halves with the step
  EXPECT_LT(std::abs(total[2] - total[1]), 0.75 * std::abs(total[1] - total[0]) + 1e-12);
}

TEST(Erosion, EnergyBalancePerClass) {
  const double l = 0.1;
  bm::Volume v = bm::Volume::from_sample(layered(l));
  const auto before = v.bone_volume_by_class();
  // α large enough that no voxel reaches χ = 0 (clamping would discard energy).
  const auto prm = layered_params(400.0, 150.0);
  const auto r = bm::replay(v, 0.5, prm, sweep(l), {}, /*restore=*/false);
  const auto after = v.bone_volume_by_class();
  for (int k : {1, 2}) {
    ASSERT_GT(r.friction_energy_mJ[k], 0.0) << k;
    const double alpha = prm.by_label[k].alpha_N_per_mm2;
    // α × removed volume = ∫ Σ W dt, and the removed volume is what the volume lost
    EXPECT_NEAR(alpha * r.removed_mm3[k] / r.friction_energy_mJ[k], 1.0, 1e-9) << k;
    EXPECT_NEAR(before[k] - after[k], r.removed_mm3[k], 1e-6 * r.removed_mm3[k]) << k;
  }
  // Independent check of ∫ΣW dt: the per-sample friction power, integrated, matches.
  double e = 0;
  const auto tr = sweep(l);
  for (std::size_t i = 0; i + 1 < tr.t_s.size(); ++i)
    e += r.samples[i].contact.power_W_mJ_per_s * (tr.t_s[i + 1] - tr.t_s[i]);
  EXPECT_NEAR(e / (r.friction_energy_mJ[1] + r.friction_energy_mJ[2]), 1.0, 0.02);
}

TEST(Erosion, TinyDecrementsDoNotStall) {
  bm::Volume v = bm::Volume::from_sample(scenes::half_space(4, 4, 4, 0.3, {0, 0, 1}, 0.5));
  const std::size_t i = v.index(1, 1, 0);
  ASSERT_EQ(v.chi(i), 1.0);
  // 1e-10 is 600× below float resolution at 1; a float χ alone would never move.
  double removed = 0;
  for (int k = 0; k < 100000; ++k) removed += v.erode(i, 1e-10);
  EXPECT_NEAR(removed, 1e-5, 1e-12);
  EXPECT_NEAR(1.0 - v.chi(i), 1e-5, 1e-12);
  // and through the kernel: α huge, many steps
  bm::Volume w = bm::Volume::from_sample(scenes::half_space(20, 20, 20, 0.1, {0, 0, 1}, 0.95));
  const auto prm = scenes::one_class(10.0, 0.5, 1e9);
  std::array<double, bm::kMaxClasses> rem{}, en{};
  bm::KernelScratch scratch;
  for (int k = 0; k < 2000; ++k) bm::step(w, scratch, {1.0, 1.0, 1.3}, {0, 300, 0}, 0.5, prm, 1e-3, rem, &en);
  ASSERT_GT(rem[1], 0.0);
  // χ is kept to ~2⁻⁴⁸ (float + float remainder): relative accounting error ≪ 1e-6
  EXPECT_NEAR(1e9 * rem[1] / en[1], 1.0, 1e-6);
}

TEST(Erosion, InfiniteAlphaOrDisabledErosionLeavesTheVolume) {
  const double l = 0.1;
  const ds::SampleVolume s = layered(l);
  bm::Volume v = bm::Volume::from_sample(s);
  const auto r = bm::replay(v, 0.5, layered_params(INFINITY, INFINITY), sweep(l, 0.1), {}, false);
  EXPECT_EQ(r.removed_mm3[1] + r.removed_mm3[2], 0.0);
  EXPECT_GT(r.friction_energy_mJ[1] + r.friction_energy_mJ[2], 0.0);  // friction still works
  EXPECT_EQ(v.to_sample().fraction, s.fraction);
  bm::ReplayOptions off;
  off.erosion = false;
  bm::Volume w = bm::Volume::from_sample(s);
  const auto r2 = bm::replay(w, 0.5, layered_params(10.0, 10.0), sweep(l, 0.1), off, false);
  EXPECT_EQ(r2.removed_mm3[1] + r2.removed_mm3[2], 0.0);
  EXPECT_EQ(w.to_sample().fraction, s.fraction);
  EXPECT_EQ(r2.steps, 0u);
}

TEST(Erosion, OnlyTheContactDiscErodes) {
  const double l = 0.05, R = 0.5, zs = 19.5 * l;
  const ds::SampleVolume s = scenes::half_space(40, 40, 30, l, {0, 0, 1}, zs);
  bm::Volume v = bm::Volume::from_sample(s);
  const glm::dvec3 p(1.0, 1.0, zs + R - R / 2);
  std::array<double, bm::kMaxClasses> rem{};
  const auto prm = scenes::one_class(10.0, 0.5, 5.0);
  bm::step(v, p, {0, 300, 0}, R, prm, 1e-3, rem);
  ASSERT_GT(rem[1], 0.0);
  const double eta = bm::voxel_sphere_radius(l);
  int eroded = 0;
  for (std::size_t z = 0; z < 30; ++z)
    for (std::size_t y = 0; y < 40; ++y)
      for (std::size_t x = 0; x < 40; ++x) {
        const std::size_t i = s.index(x, y, z);
        if (v.chi(i) == double(s.fraction[i])) continue;
        ++eroded;
        const double d = glm::length(s.centre_mm(x, y, z) - p);
        EXPECT_GT(d, R - eta);  // never a fully-inside voxel
        EXPECT_LT(d, R + eta);
      }
  EXPECT_GT(eroded, 10);
}
