// The paper's figure checks as MODEL.md restates them (figures 5–8).
#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>

#include "test_paper_scenes.hpp"

namespace bm = burrbench::model;

TEST(Paper, PlungeFollowsHertzLaw) {
  for (double ratio : {2.5, 10.0}) {
    const double R = 0.75, l = R / ratio;
    const std::size_t n = std::size_t(std::ceil(6 * R / l)) + 4;
    const double zs = (double(n / 2) - 0.5) * l;  // surface on a voxel face
    const bm::Volume vol = bm::Volume::from_sample(
        scenes::half_space(n, n, n, l, {0, 0, 1}, zs));
    const auto prm = scenes::one_class(10.0, 0.0);
    const double c = 0.5 * l * double(n - 1);
    double worst = 0;
    for (double depth = l; depth <= 1.0 * R + 1e-12; depth += l / 16) {
      const bm::ContactResult r =
          bm::evaluate(vol, {c + 0.1 * l, c + 0.27 * l, zs + R - depth}, {0, 0, 100}, R, prm);
      const double expect = 10.0 * R * R * std::pow(depth / R, 1.5);
      worst = std::max(worst, std::abs(glm::length(r.elastic_N) / expect - 1));
      EXPECT_GT(r.normal.z, 0.999);  // off-axis voxels tilt n̂ slightly
    }
    std::printf("R/l=%g worst relative deviation %.4f\n", ratio, worst);
    EXPECT_LT(worst, 0.02) << "R/l = " << ratio;
  }
}

// Friction with μ = 1/2 grows with sin θ (θ between the surface normal and ω). For a
// shallow contact every contact point's lever is ≈ −R n̂, so |F_μ| → μ|F_e| sin θ.
// Tolerances: the sin θ SHAPE is exact up to the voxel sampling of the contact disc, so
// the ratio |F_μ|/(μ|F_e| sin θ) must agree across θ within 1 %. Its absolute value
// differs from 1 because Σ χΔσP over the few voxels on the disc approximates ∫P dσ = |F_e|
// (R/l = 10: a spans 3.5 voxels at b = R/16 and the measured offset is 11 %, 3 % at R/8,
// 1 % at R/4), so the absolute check allows 12 %.
TEST(Paper, FrictionGrowsWithSinTheta) {
  const double R = 1.0, l = 0.1, mu = 0.5;
  const std::size_t n = 40;
  const double zs = 19.5 * l;
  const bm::Volume vol = bm::Volume::from_sample(scenes::half_space(n, n, n, l, {0, 0, 1}, zs));
  const auto prm = scenes::one_class(10.0, mu);
  for (double depth : {R / 16, R / 8, R / 4}) {
    std::vector<double> ratios;
    for (double th_deg : {30.0, 60.0, 90.0}) {
      const double th = th_deg * std::numbers::pi / 180;
      const glm::dvec3 w = 300.0 * glm::dvec3(std::sin(th), 0, std::cos(th));
      const bm::ContactResult r =
          bm::evaluate(vol, {2.0 + 0.03, 2.0 + 0.07, zs + R - depth}, w, R, prm);
      const double ratio =
          glm::length(r.friction_N) / (mu * glm::length(r.elastic_N) * std::sin(th));
      EXPECT_NEAR(ratio, 1.0, 0.12) << "depth " << depth << " theta " << th_deg;
      // friction is tangential: perpendicular to the normal and to ω
      EXPECT_NEAR(glm::dot(r.friction_N, r.normal), 0.0, 0.01 * glm::length(r.friction_N));
      ratios.push_back(ratio);
    }
    EXPECT_NEAR(ratios[0] / ratios[2], 1.0, 0.01) << depth;
    EXPECT_NEAR(ratios[1] / ratios[2], 1.0, 0.01) << depth;
  }
  // ω along the normal (θ = 0): the pressure distribution is symmetric, friction ≈ 0
  const bm::ContactResult r0 =
      bm::evaluate(vol, {2.0, 2.0, zs + R - R / 4}, {0, 0, 300.0}, R, prm);
  EXPECT_LT(glm::length(r0.friction_N), 1e-9 * glm::length(r0.elastic_N));
}

namespace {

// Period of a sampled signal: the smallest lag whose autocorrelation peak reaches 90 % of
// the highest peak (after the first zero crossing), refined by a parabola through the
// peak and its neighbours. Robust to harmonics that an FFT's strongest line would pick.
double repeat_period(const std::vector<double>& f, double ds) {
  const std::size_t n = f.size();
  double mean = 0;
  for (double v : f) mean += v;
  mean /= double(n);
  const std::size_t maxlag = n / 3;
  std::vector<double> ac(maxlag + 1);
  for (std::size_t k = 0; k <= maxlag; ++k) {
    double s = 0;
    for (std::size_t i = 0; i + k < n; ++i) s += (f[i] - mean) * (f[i + k] - mean);
    ac[k] = s / double(n - k);
  }
  std::size_t k0 = 1;
  while (k0 < maxlag && ac[k0] > 0) ++k0;
  double best = 0;
  for (std::size_t k = k0; k < maxlag; ++k) best = std::max(best, ac[k]);
  for (std::size_t k = k0 + 1; k < maxlag; ++k) {
    if (ac[k] >= 0.9 * best && ac[k] >= ac[k - 1] && ac[k] >= ac[k + 1]) {
      const double a = ac[k - 1], b = ac[k], c = ac[k + 1];
      const double off = 0.5 * (a - c) / (a - 2 * b + c);
      return (double(k) + off) * ds;
    }
  }
  return NAN;
}

std::vector<double> slide(const bm::Volume& vol, glm::dvec3 start, glm::dvec3 dir, double R,
                          double len, double ds) {
  const auto prm = scenes::one_class(10.0, 0.5);
  std::vector<double> f;
  for (double s = 0; s < len; s += ds)
    f.push_back(glm::length(bm::evaluate(vol, start + s * dir, {0, 0, 0}, R, prm).elastic_N));
  return f;
}

}  // namespace

// Sliding at depth R/4 over flat bone (paper figure 7): the voxel-sphere ripple repeats
// every l along an axis-aligned surface and every √2·l along the diagonal one.
TEST(Paper, SlidingRipplePeriodsHaveRatioSqrt2) {
  const double R = 0.75, l = 0.3, ds = l / 64, len = 24 * l, depth = R / 4;
  // axis-aligned: surface z = zs, slide along x
  const double zs = 7.5 * l;
  const bm::Volume flat = bm::Volume::from_sample(scenes::half_space(36, 12, 16, l, {0, 0, 1}, zs));
  const auto f1 = slide(flat, {3 * l + 0.013, 5.37 * l, zs + R - depth}, {1, 0, 0}, R, len, ds);
  // diagonal: surface normal (0,1,1)/√2 through the point q, slide along (0,1,−1)/√2
  const glm::dvec3 nrm = glm::normalize(glm::dvec3(0, 1, 1)), dir = glm::normalize(glm::dvec3(0, 1, -1));
  const glm::dvec3 q(5.23 * l, 6 * l, 26 * l);
  const bm::Volume diag = bm::Volume::from_sample(
      scenes::half_space(12, 34, 34, l, nrm, glm::dot(nrm, q)));
  const auto f2 = slide(diag, q + (R - depth) * nrm, dir, R, len, ds);
  const double p1 = repeat_period(f1, ds), p2 = repeat_period(f2, ds);
  std::printf("periods %.5f mm %.5f mm ratio %.5f\n", p1, p2, p2 / p1);
  EXPECT_NEAR(p1, l, 0.01 * l);
  EXPECT_NEAR(p2 / p1, std::sqrt(2.0), 0.01 * std::sqrt(2.0));
}

// Polishing (paper figure 8): strokes back and forth at 10 mm/s at a fixed depth with
// erosion on. The force during contact is ordered F_total > F_e > F_μ, and a groove is
// cut along the stroke and nowhere else.
TEST(Paper, PolishingStrokeCutsAGroove) {
  const double R = 0.75, l = 0.3, zs = 7.5 * l;
  const auto sample = scenes::half_space(40, 16, 12, l, {0, 0, 1}, zs);
  bm::Volume vol = bm::Volume::from_sample(sample);
  // α in N/mm²: the paper's 3.1e6 mm²/s² is mass-based; we pick a value that cuts a
  // visible groove in one second of polishing.
  const auto prm = scenes::one_class(10.0, 0.5, 20.0);
  bm::Trajectory tr;
  const double y = 7.3 * l, z = zs + R - R / 4;
  for (int i = 0; i <= 1000; ++i) {  // 1 s at 1 kHz, strokes of 6 mm at 10 mm/s
    const double t = i * 1e-3, ph = std::fmod(10.0 * t, 12.0);
    const double x = 3.0 + (ph < 6.0 ? ph : 12.0 - ph);
    tr.t_s.push_back(t);
    tr.centre_vol_mm.push_back({x, y, z});
    tr.omega_vol_rad_s.push_back({0, 300.0, 0});  // shaft along y: θ = 90° to the normal
  }
  const bm::ReplayResult res = bm::replay(vol, R, prm, tr, {}, /*restore=*/false);
  int in_contact = 0;
  for (const auto& s : res.samples) {
    const auto& c = s.contact;
    if (c.bone_volume_mm3 <= 0) continue;
    ++in_contact;
    EXPECT_GT(glm::length(c.force_N), glm::length(c.elastic_N));
    EXPECT_GT(glm::length(c.elastic_N), glm::length(c.friction_N));
    EXPECT_GT(glm::length(c.friction_N), 0.0);
  }
  EXPECT_EQ(in_contact, 1001);
  EXPECT_GT(res.removed_mm3[1], 0.0);
  // The groove: voxels of the top layer under the stroke lost bone; far from it none did.
  const auto after = vol.to_sample();
  const std::size_t top = 7;
  double under = 0, far = 0;
  for (std::size_t x = 12; x < 28; ++x) {
    under += sample.fraction[sample.index(x, 7, top)] - after.fraction[after.index(x, 7, top)];
    far += sample.fraction[sample.index(x, 1, top)] - after.fraction[after.index(x, 1, top)];
  }
  EXPECT_GT(under / 16, 0.05);
  EXPECT_EQ(far, 0.0);
  // Total removed equals the volume's loss.
  EXPECT_NEAR(res.removed_mm3[1],
              bm::Volume::from_sample(sample).bone_volume_by_class()[1] -
                  vol.bone_volume_by_class()[1],
              1e-9);
}
