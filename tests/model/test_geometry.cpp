// Voxel-sphere geometry: lens volume, contact-disc area and lever against exact closed
// forms and Monte Carlo in every regime; the interpolation tables; the b(M) solve.
#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

#include "burrbench/model/geometry.hpp"

namespace bm = burrbench::model;
using std::numbers::pi;

namespace {

// Monte Carlo volume of the intersection: uniform points in the voxel sphere.
double mc_lens_volume(double R, double eta, double d, int n, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1, 1);
  int hit = 0, tot = 0;
  while (tot < n) {
    const double x = u(rng), y = u(rng), z = u(rng);
    if (x * x + y * y + z * z > 1) continue;
    ++tot;
    const double px = d + eta * x, py = eta * y, pz = eta * z;  // burr at the origin
    if (px * px + py * py + pz * pz <= R * R) ++hit;
  }
  return 4.0 / 3.0 * pi * eta * eta * eta * hit / tot;
}

// Monte Carlo of the contact disc: the part of the burr surface inside the voxel sphere
// is a cap of area 2πR(R − r); its surface fraction f gives r = R(1 − 2f) and the disc
// radius² = R² − r², independently of the radical-plane formula.
void mc_disc(double R, double eta, double d, std::mt19937_64& rng, double& r, double& rho2) {
  std::normal_distribution<double> g;
  const int n = 200000;
  int in = 0;
  for (int k = 0; k < n; ++k) {
    double x = g(rng), y = g(rng), z = g(rng);
    const double s = R / std::sqrt(x * x + y * y + z * z);
    x *= s; y *= s; z *= s;
    if ((x - d) * (x - d) + y * y + z * z <= eta * eta) ++in;
  }
  const double f = double(in) / n;
  r = R * (1 - 2 * f);
  rho2 = R * R - r * r;
}

}  // namespace

TEST(Geometry, VoxelSphereHasVoxelVolume) {
  const double l = 0.3, eta = bm::voxel_sphere_radius(l);
  EXPECT_NEAR(4.0 / 3.0 * pi * eta * eta * eta, l * l * l, 1e-15);
}

TEST(Geometry, LensVolumeMatchesMonteCarloInAllRegimes) {
  std::mt19937_64 rng(7);
  const double l = 0.3, eta = bm::voxel_sphere_radius(l);
  for (double R : {0.75, 0.1, eta}) {  // η < R, η > R, η = R
    const double edge_lo = std::abs(R - eta), edge_hi = R + eta;
    for (double f : {0.0, 0.3, 0.5, 0.7, 0.95}) {  // lens
      const double d = edge_lo + f * (edge_hi - edge_lo) + (f == 0.0 ? 1e-9 : 0);
      const double exact = bm::lens_volume(R, eta, d);
      const double mc = mc_lens_volume(R, eta, d, 400000, rng);
      const double vmax = 4.0 / 3.0 * pi * std::pow(std::min(R, eta), 3);
      // MC standard error ≈ V_eta·sqrt(p(1−p)/n) ≤ 0.0008·V_eta → 4σ bound
      EXPECT_NEAR(exact, mc, 3.5e-3 * 4.0 / 3.0 * pi * eta * eta * eta)
          << "R=" << R << " d=" << d;
      EXPECT_LE(exact, vmax * (1 + 1e-12));
      const bm::LensGeometry g = bm::lens_geometry(R, eta, d);
      EXPECT_EQ(g.regime, d > edge_lo ? bm::Regime::kLens : bm::Regime::kInside);
    }
    // inside and outside
    if (edge_lo > 0) {
      const bm::LensGeometry in = bm::lens_geometry(R, eta, 0.5 * edge_lo);
      EXPECT_EQ(in.regime, bm::Regime::kInside);
      EXPECT_DOUBLE_EQ(in.volume_mm3, 4.0 / 3.0 * pi * std::pow(std::min(R, eta), 3));
      EXPECT_EQ(in.disc_area_mm2, 0.0);
      EXPECT_DOUBLE_EQ(in.lever_mm, 0.5 * edge_lo);
      EXPECT_NEAR(mc_lens_volume(R, eta, 0.5 * edge_lo, 20000, rng), in.volume_mm3,
                  1e-12 + 0.02 * in.volume_mm3 * (R < eta ? 1 : 0));
    }
    const bm::LensGeometry out = bm::lens_geometry(R, eta, edge_hi + 1e-9);
    EXPECT_EQ(out.regime, bm::Regime::kNone);
    EXPECT_EQ(out.volume_mm3, 0.0);
    EXPECT_EQ(mc_lens_volume(R, eta, edge_hi + 1e-9, 20000, rng), 0.0);
  }
}

TEST(Geometry, LensVolumeIsContinuousAtRegimeEdges) {
  const double l = 0.3, eta = bm::voxel_sphere_radius(l), R = 0.75;
  EXPECT_NEAR(bm::lens_volume(R, eta, R - eta + 1e-9), l * l * l, 1e-9);
  EXPECT_NEAR(bm::lens_volume(R, eta, R + eta - 1e-9), 0.0, 1e-12);
  // The volume of two caps, computed independently: cap heights from the plane position.
  const double d = R, r = d / 2 + (R * R - eta * eta) / (2 * d);
  const double h1 = R - r, h2 = eta - (d - r);
  const double caps = pi * h1 * h1 * (3 * R - h1) / 3 + pi * h2 * h2 * (3 * eta - h2) / 3;
  EXPECT_NEAR(bm::lens_volume(R, eta, d), caps, 1e-14);
}

TEST(Geometry, DiscAreaAndLeverMatchMonteCarloAndClosedForm) {
  std::mt19937_64 rng(11);
  const double l = 0.3, eta = bm::voxel_sphere_radius(l);
  for (double R : {0.75, 0.1}) {
    const double lo = std::abs(R - eta), hi = R + eta;
    for (double f : {0.2, 0.5, 0.8}) {
      const double d = lo + f * (hi - lo);
      const bm::LensGeometry g = bm::lens_geometry(R, eta, d);
      // closed form: the radical plane x = (d² + R² − η²)/(2d)
      const double r_exact = (d * d + R * R - eta * eta) / (2 * d);
      EXPECT_NEAR(g.lever_mm, r_exact, 1e-14);
      EXPECT_NEAR(g.disc_area_mm2, pi * (R * R - r_exact * r_exact), 1e-14);
      double r_mc, rho2_mc;
      mc_disc(R, eta, d, rng, r_mc, rho2_mc);
      EXPECT_NEAR(g.lever_mm, r_mc, 5e-3 * R) << "R=" << R << " d=" << d;
      EXPECT_NEAR(g.disc_area_mm2, pi * rho2_mc, 0.01 * pi * R * R) << "R=" << R;
    }
  }
}

TEST(Geometry, TablesInterpolateTheExactFormsClosely) {
  for (auto [R, l] : {std::pair{0.75, 0.3}, std::pair{1.0, 0.05}, std::pair{0.1, 0.3}}) {
    const bm::LensTable t(R, l);
    const double eta = t.eta();
    double worst_v = 0, worst_a = 0, worst_r = 0, worst_i = 0;
    for (int i = 1; i < 20000; ++i) {
      const double d2 = t.d2_inner() + (t.d2_outer() - t.d2_inner()) * (i + 0.37) / 20001.0;
      const double d = std::sqrt(d2);
      const bm::LensGeometry g = bm::lens_geometry(R, eta, d);
      const bm::LensTable::Entry e = t.at(d2);
      worst_v = std::max(worst_v, std::abs(e.volume - g.volume_mm3) / (l * l * l));
      worst_a = std::max(worst_a, std::abs(e.area - g.disc_area_mm2) / (pi * eta * eta));
      worst_r = std::max(worst_r, std::abs(e.lever_over_d - g.lever_mm / d) * d / R);
      worst_i = std::max(worst_i, std::abs(e.inv_d * d - 1));
    }
    // Errors relative to a voxel's volume, the voxel sphere's cross-section, and R.
    EXPECT_LT(worst_v, 1e-5) << R << " " << l;
    EXPECT_LT(worst_a, 1e-4) << R << " " << l;
    EXPECT_LT(worst_r, 1e-4) << R << " " << l;
    EXPECT_LT(worst_i, 1e-5) << R << " " << l;
    std::printf("R=%g l=%g table errors: dV/l3 %.1e dS/(pi eta2) %.1e r %.1e 1/d %.1e\n", R, l, worst_v, worst_a, worst_r, worst_i);
  }
}

TEST(Geometry, ImmersionDepthSolvesTheCapVolume) {
  const double R = 0.75;
  for (double s = 0; s <= 2.0; s += 1.0 / 64) {
    const double b = s * R, M = pi * b * b * (R - b / 3);
    EXPECT_NEAR(bm::immersion_depth(R, M), b, 1e-12 * R) << s;
  }
  EXPECT_NEAR(bm::immersion_depth(R, 1e-15), std::sqrt(1e-15 / (pi * R)), 1e-12);
  EXPECT_EQ(bm::immersion_depth(R, 0), 0);
  EXPECT_EQ(bm::immersion_depth(R, 10.0), 2 * R);  // more than the sphere: buried
  EXPECT_EQ(bm::immersion_depth(R, -1.0), 0);
}
