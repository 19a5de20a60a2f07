// The friction couple T on the burr (MODEL.md "Moments, the sensor's wrench and the
// spindle's load"): against a brute-force sum over voxels with the exact lens geometry,
// its spin component against the friction power, its per-class partials, and its
// invariance under translating scene and burr together.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "lumpy_scene.hpp"

#include "burrbench/model/contact.hpp"
#include "burrbench/model/geometry.hpp"
#include "burrbench/model/volume.hpp"

namespace bm = burrbench::model;
namespace ds = burrbench::data_schema;

namespace {

using scenes::lumpy;
using scenes::two_classes;

// MODEL.md steps 1–5 and the moment, voxel by voxel, with the exact (untabulated) lens.
struct Brute {
  glm::dvec3 friction_N{0}, moment_Nmm{0};
  double power = 0;
};
Brute brute(const ds::SampleVolume& s, glm::dvec3 p, glm::dvec3 omega, double R, const bm::ModelParams& prm) {
  const double l = s.voxel_mm, eta = bm::voxel_sphere_radius(l);
  double M = 0, c1m = 0;
  glm::dvec3 M1(0);
  auto centre = [&](std::size_t x, std::size_t y, std::size_t z) {
    return s.origin_mm + l * glm::dvec3(double(x), double(y), double(z));
  };
  auto each = [&](auto&& f) {
    for (std::size_t z = 0; z < s.dims[2]; ++z)
      for (std::size_t y = 0; y < s.dims[1]; ++y)
        for (std::size_t x = 0; x < s.dims[0]; ++x) {
          const std::size_t i = s.index(x, y, z);
          if (s.labels[i] == 0 || s.fraction[i] <= 0) continue;
          const glm::dvec3 v = centre(x, y, z) - p;
          const double d = glm::length(v);
          const bm::LensGeometry g = bm::lens_geometry(R, eta, d);
          if (g.regime == bm::Regime::kNone) continue;
          f(v, d, g, double(s.fraction[i]), s.labels[i]);
        }
  };
  each([&](glm::dvec3 v, double d, const bm::LensGeometry& g, double chi, std::uint8_t k) {
    M += g.volume_mm3 * chi;
    c1m += g.volume_mm3 * chi * prm.by_label[k].c1_N_per_mm2;
    M1 += g.volume_mm3 * chi * (g.lever_mm / d) * v;
  });
  const glm::dvec3 n = -M1 / glm::length(M1);
  const double b = bm::immersion_depth(R, M);
  const double fe = c1m / M * R * R * std::pow(b / R, 1.5);
  const double a2 = 2 * R * b - b * b;
  const double p0 = 3 * fe / (2 * std::numbers::pi * a2);
  const double wn = glm::length(omega);
  const glm::dvec3 w = omega / wn;
  Brute out;
  each([&](glm::dvec3 v, double d, const bm::LensGeometry& g, double chi, std::uint8_t k) {
    if (g.regime != bm::Regime::kLens) return;
    const double rd = g.lever_mm / d;
    const double vn = glm::dot(n, v);
    const double xi2 = rd * rd * (d * d - vn * vn);
    const double P = p0 * std::sqrt(std::max(0.0, 1 - xi2 / a2));
    const double mu = prm.by_label[k].mu;
    const glm::dvec3 dF = mu * chi * g.disc_area_mm2 * P * glm::cross(v, omega) / (d * wn);
    out.friction_N += dF;
    out.moment_Nmm += glm::cross(rd * v, dF);
    const double c = glm::dot(v, w) / d;
    out.power += mu * chi * P * wn * g.lever_mm * (1 - c * c) * g.disc_area_mm2;
  });
  return out;
}

}  // namespace

TEST(Moment, AgreesWithABruteForceSumOverVoxels) {
  const ds::SampleVolume s = lumpy(24, 0.1, 5);
  const bm::Volume v = bm::Volume::from_sample(s);
  const auto prm = two_classes();
  for (glm::dvec3 p : {glm::dvec3(1.1, 1.2, 0.75), glm::dvec3(0.9, 1.3, 0.95)})
    for (glm::dvec3 w : {glm::dvec3(0, 200, 100), glm::dvec3(150, -60, 240)}) {
      const bm::ContactResult r = bm::evaluate(v, p, w, 0.5, prm);
      const Brute b = brute(s, p, w, 0.5, prm);
      ASSERT_GT(glm::length(b.moment_Nmm), 0.0);
      // The kernel tabulates ΔV, Δσ, r/d and 1/d (1024 intervals in d²); the brute force
      // uses the closed forms.
      const double tol = 2e-4;
      EXPECT_LT(glm::length(r.moment_Nmm - b.moment_Nmm), tol * glm::length(b.moment_Nmm))
          << "kernel " << r.moment_Nmm.x << " " << r.moment_Nmm.y << " " << r.moment_Nmm.z << ", brute "
          << b.moment_Nmm.x << " " << b.moment_Nmm.y << " " << b.moment_Nmm.z;
      EXPECT_LT(glm::length(r.friction_N - b.friction_N), tol * glm::length(b.friction_N));
      EXPECT_NEAR(r.power_W_mJ_per_s, b.power, tol * b.power);
    }
}

TEST(Moment, SpinComponentIsTheFrictionPowerAndPartialsAreExact) {
  const bm::Volume v = bm::Volume::from_sample(lumpy(24, 0.1, 7));
  const auto prm = two_classes();
  const glm::dvec3 p(1.1, 1.2, 0.75), w(0, 200, 100);
  const bm::ContactResult r = bm::evaluate(v, p, w, 0.5, prm);
  ASSERT_EQ(r.class_mask, 0b110);
  ASSERT_GT(r.power_W_mJ_per_s, 0.0);
  // T·ω̂ = −Σ W/|ω|: the spindle's load torque above idle is −T·ω̂. Exact in MODEL.md;
  // here to the table's 1/d (W has r(1 − (v·ω̂)²/d²) where T has (r/d)(d² − (v·ω̂)²)/d).
  EXPECT_NEAR(glm::dot(r.moment_Nmm, glm::normalize(w)), -r.power_W_mJ_per_s / glm::length(w),
              1e-7 * r.power_W_mJ_per_s / glm::length(w));
  glm::dvec3 sum(0);
  for (int k = 0; k < bm::kMaxClasses; ++k) sum += prm.by_label[k].mu * r.dTmu_dmu[k];
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(sum[i], r.moment_Nmm[i], 1e-12);
  auto p2 = prm;
  p2.by_label[2].mu += 0.3;
  const bm::ContactResult r2 = bm::evaluate(v, p, w, 0.5, p2);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(r2.moment_Nmm[i] - r.moment_Nmm[i], 0.3 * r.dTmu_dmu[2][i], 1e-12);
  // μ = 0 everywhere: no couple at all.
  auto p0 = prm;
  p0.by_label[1].mu = p0.by_label[2].mu = 0;
  EXPECT_EQ(bm::evaluate(v, p, w, 0.5, p0).moment_Nmm, glm::dvec3(0));
}

// (Rotation: Contact.RotatingTheSceneRotatesTheForceAndMoment.) About the burr centre, T
// moves with the burr: the same bone and burr shifted together give the same couple.
TEST(Moment, TranslatingSceneAndBurrTogetherLeavesItUnchanged) {
  const ds::SampleVolume a = lumpy(24, 0.1, 3);
  ds::SampleVolume shifted = a;
  const glm::dvec3 shift(3.7, -1.25, 0.4);
  shifted.origin_mm += shift;
  const bm::Volume va = bm::Volume::from_sample(a), vs = bm::Volume::from_sample(shifted);
  const auto prm = two_classes();
  for (glm::dvec3 p : {glm::dvec3(1.1, 0.93, 1.3), glm::dvec3(0.8, 1.4, 0.9), glm::dvec3(1.2, 1.0, 0.6)}) {
    const glm::dvec3 w(120.0, -40.0, 250.0);
    const bm::ContactResult ra = bm::evaluate(va, p, w, 0.5, prm);
    const bm::ContactResult rs = bm::evaluate(vs, p + shift, w, 0.5, prm);
    ASSERT_GT(glm::length(ra.moment_Nmm), 0.0);
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(rs.moment_Nmm[k], ra.moment_Nmm[k], 1e-9 * glm::length(ra.moment_Nmm));
  }
}
