// Contact kernel: zero force without bone, rotation covariance, exact per-class partials,
// buried flag, class mask, input checking and the 8-bit counter import/export.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "lumpy_scene.hpp"

#include "burrbench/data_schema/error.hpp"
#include "test_paper_scenes.hpp"

namespace bm = burrbench::model;
namespace ds = burrbench::data_schema;

namespace {

using scenes::lumpy;
using scenes::two_classes;

}  // namespace

TEST(Contact, NoBoneMeansExactlyZeroForce) {
  const auto prm = two_classes();
  ds::SampleVolume empty = scenes::half_space(10, 10, 10, 0.3, {0, 0, 1}, -1.0);
  const bm::Volume e = bm::Volume::from_sample(empty);
  const bm::ContactResult r = bm::evaluate(e, {1.5, 1.5, 1.5}, {0, 0, 300}, 0.75, prm);
  EXPECT_EQ(r.force_N, glm::dvec3(0));
  EXPECT_EQ(r.class_mask, 0);
  EXPECT_EQ(r.bone_volume_mm3, 0.0);
  // bone present, burr just out of reach (gap 1e-6 mm beyond R + η of the top voxels)
  const bm::Volume flat = bm::Volume::from_sample(scenes::half_space(10, 10, 10, 0.3, {0, 0, 1}, 1.35));
  const double top = 1.2, reach = 0.75 + bm::voxel_sphere_radius(0.3);
  const bm::ContactResult r2 = bm::evaluate(flat, {1.5, 1.5, top + reach + 1e-6}, {0, 0, 300}, 0.75, prm);
  EXPECT_EQ(r2.force_N, glm::dvec3(0));
  EXPECT_EQ(r2.elastic_N, glm::dvec3(0));
  EXPECT_EQ(r2.friction_N, glm::dvec3(0));
  const bm::ContactResult r3 = bm::evaluate(flat, {1.5, 1.5, top + reach - 1e-3}, {0, 0, 300}, 0.75, prm);
  EXPECT_GT(glm::length(r3.force_N), 0.0);
  // labelled voxels whose χ is zero are no bone either
  ds::SampleVolume ghost = scenes::half_space(10, 10, 10, 0.3, {0, 0, 1}, 1.35);
  for (auto& f : ghost.fraction) f = 0.0f;
  const bm::ContactResult r4 = bm::evaluate(bm::Volume::from_sample(ghost), {1.5, 1.5, 1.2}, {0, 0, 300}, 0.75, prm);
  EXPECT_EQ(r4.force_N, glm::dvec3(0));
}

TEST(Contact, RotatingTheSceneRotatesTheForceAndMoment) {
  // Rotate the volume 90° about z: voxel (x, y, z) → (n−1−y, x, z) about the grid centre.
  const std::size_t n = 24;
  const double l = 0.1;
  const ds::SampleVolume a = lumpy(n, l, 3);
  ds::SampleVolume b = a;
  for (std::size_t z = 0; z < n; ++z)
    for (std::size_t y = 0; y < n; ++y)
      for (std::size_t x = 0; x < n; ++x) {
        b.labels[b.index(n - 1 - y, x, z)] = a.labels[a.index(x, y, z)];
        b.fraction[b.index(n - 1 - y, x, z)] = a.fraction[a.index(x, y, z)];
      }
  const bm::Volume va = bm::Volume::from_sample(a), vb = bm::Volume::from_sample(b);
  const double c = 0.5 * l * double(n - 1);
  auto rot = [&](glm::dvec3 v) { return glm::dvec3(-v.y, v.x, v.z); };  // about the z axis
  auto rotp = [&](glm::dvec3 p) { return glm::dvec3(c, c, 0) + rot(p - glm::dvec3(c, c, 0)); };
  const auto prm = two_classes();
  for (glm::dvec3 p : {glm::dvec3(1.1, 0.93, 1.3), glm::dvec3(0.8, 1.4, 0.9), glm::dvec3(1.2, 1.0, 0.6)}) {
    const glm::dvec3 w(120.0, -40.0, 250.0);
    const bm::ContactResult ra = bm::evaluate(va, p, w, 0.5, prm);
    const bm::ContactResult rb = bm::evaluate(vb, rotp(p), rot(w), 0.5, prm);
    ASSERT_GT(glm::length(ra.force_N), 0.0);
    const double tol = 1e-9 * glm::length(ra.force_N);
    for (int k = 0; k < 3; ++k) {
      EXPECT_NEAR(rb.elastic_N[k], rot(ra.elastic_N)[k], tol);
      EXPECT_NEAR(rb.friction_N[k], rot(ra.friction_N)[k], tol);
      EXPECT_NEAR(rb.force_N[k], rot(ra.force_N)[k], tol);
      // The friction couple is a vector too (tests/model/test_moment.cpp for the rest).
      EXPECT_NEAR(rb.moment_Nmm[k], rot(ra.moment_Nmm)[k], 1e-9 * glm::length(ra.moment_Nmm));
    }
    ASSERT_GT(glm::length(ra.moment_Nmm), 0.0);
    EXPECT_NEAR(rb.depth_b_mm, ra.depth_b_mm, 1e-12);
  }
}

TEST(Contact, PartialsAreExactAtFixedGeometry) {
  const bm::Volume v = bm::Volume::from_sample(lumpy(24, 0.1, 5));
  const auto prm = two_classes();
  const glm::dvec3 p(1.1, 1.2, 0.75), w(0, 200, 100);
  const bm::ContactResult r = bm::evaluate(v, p, w, 0.5, prm);
  ASSERT_EQ(r.class_mask, 0b110);  // both classes touched
  glm::dvec3 fe(0), fm(0);
  for (int k = 0; k < bm::kMaxClasses; ++k) {
    fe += prm.by_label[k].c1_N_per_mm2 * r.dF_dC1[k];
    fm += prm.by_label[k].mu * r.dFmu_dmu[k];
  }
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(fe[i], r.elastic_N[i], 1e-12);
    EXPECT_NEAR(fm[i], r.friction_N[i], 1e-12);
  }
  // Perturb one constant: the force moves exactly along the reported partial.
  auto p2 = prm;
  p2.by_label[2].c1_N_per_mm2 += 1.5;
  const bm::ContactResult r2 = bm::evaluate(v, p, w, 0.5, p2);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(r2.elastic_N[i] - r.elastic_N[i], 1.5 * r.dF_dC1[2][i], 1e-12);
  auto p3 = prm;
  p3.by_label[1].mu += 0.25;
  const bm::ContactResult r3 = bm::evaluate(v, p, w, 0.5, p3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(r3.friction_N[i] - r.friction_N[i], 0.25 * r.dFmu_dmu[1][i], 1e-12);
    EXPECT_EQ(r3.elastic_N[i], r.elastic_N[i]);
  }
  EXPECT_EQ(r.dF_dC1[0], glm::dvec3(0));
  EXPECT_EQ(r.dF_dC1[3], glm::dvec3(0));
}

TEST(Contact, BuriedFlagMarksAnIllDefinedNormal) {
  const double R = 0.5, l = 0.05, zs = 29.5 * l;
  const bm::Volume v = bm::Volume::from_sample(scenes::half_space(40, 40, 60, l, {0, 0, 1}, zs));
  const auto prm = scenes::one_class(10, 0.3);
  const bm::ContactResult shallow = bm::evaluate(v, {1.0, 1.0, zs + R - R / 4}, {0, 0, 100}, R, prm);
  EXPECT_FALSE(shallow.buried);
  const bm::ContactResult half = bm::evaluate(v, {1.0, 1.0, zs}, {0, 0, 100}, R, prm);
  EXPECT_FALSE(half.buried);
  EXPECT_NEAR(half.depth_b_mm, R, 0.01 * R);
  const bm::ContactResult deep = bm::evaluate(v, {1.0, 1.0, zs - 0.9 * R}, {0, 0, 100}, R, prm);
  EXPECT_TRUE(deep.buried);
  const bm::ContactResult sunk = bm::evaluate(v, {1.0, 1.0, zs - 2 * R}, {0, 0, 100}, R, prm);
  EXPECT_TRUE(sunk.buried);
  EXPECT_NEAR(sunk.depth_b_mm, 2 * R, 0.02 * R);
  // |F_e| saturates at C1 R² 2^{3/2} once buried
  EXPECT_NEAR(glm::length(sunk.elastic_N), 10 * R * R * std::pow(2.0, 1.5), 0.05 * 10 * R * R);
}

TEST(Contact, BadInputIsRejected) {
  ds::SampleVolume s = scenes::half_space(4, 4, 4, 0.3, {0, 0, 1}, 0.5);
  s.labels[3] = bm::kMaxClasses;
  EXPECT_THROW(bm::Volume::from_sample(s), burrbench::InputError);
  s = scenes::half_space(4, 4, 4, 0.3, {0, 0, 1}, 0.5);
  s.fraction[0] = 1.5f;
  EXPECT_THROW(bm::Volume::from_sample(s), burrbench::InputError);
  s.fraction[0] = NAN;
  EXPECT_THROW(bm::Volume::from_sample(s), burrbench::InputError);
  s = scenes::half_space(4, 4, 4, 0.3, {0, 0, 1}, 0.5);
  s.fraction.pop_back();
  EXPECT_THROW(bm::Volume::from_sample(s), burrbench::InputError);
  s = scenes::half_space(4, 4, 4, 0.3, {0, 0, 1}, 0.5);
  s.voxel_mm = 0;
  EXPECT_THROW(bm::Volume::from_sample(s), burrbench::InputError);
  s.voxel_mm = 0.3;
  s.dims = {1u << 21, 1, 1};
  EXPECT_THROW(bm::Volume::from_sample(s), burrbench::InputError);

  ds::ParameterSet ps;
  ps.classes[9] = {"bogus", 1.0, 1.0, 0.1};
  EXPECT_THROW(bm::ModelParams::from(ps), burrbench::InputError);
  ps.classes.clear();
  ps.classes[1] = {"compact", -1.0, 1.0, 0.1};
  EXPECT_THROW(bm::ModelParams::from(ps), burrbench::InputError);
  ps.classes[1] = {"compact", INFINITY, 12.0, 0.3};
  ps.classes[2] = {"trabecular", 40.0, 3.0, 0.6};
  const bm::ModelParams mp = bm::ModelParams::from(ps);
  EXPECT_TRUE(std::isinf(mp.by_label[1].alpha_N_per_mm2));
  EXPECT_EQ(mp.by_label[2].c1_N_per_mm2, 3.0);
  EXPECT_EQ(mp.by_label[2].mu, 0.6);

  const bm::Volume v = bm::Volume::from_sample(scenes::half_space(4, 4, 4, 0.3, {0, 0, 1}, 0.5));
  EXPECT_THROW(bm::evaluate(v, {0, 0, 0}, {0, 0, 1}, 0.0, mp), burrbench::InputError);
  EXPECT_THROW(bm::evaluate(v, {NAN, 0, 0}, {0, 0, 1}, 0.5, mp), burrbench::InputError);
}

TEST(Contact, EightBitCounterImportExport) {
  const std::size_t n = 6;
  std::vector<std::uint8_t> labels(n * n * n, 1), counters(n * n * n);
  for (std::size_t i = 0; i < counters.size(); ++i) counters[i] = std::uint8_t((i * 37) % 256);
  labels[5] = 0;
  const bm::Volume v = bm::Volume::from_counters({n, n, n}, 0.3, {0, 0, 0}, labels, counters);
  EXPECT_NEAR(v.chi(7), counters[7] / 255.0, 1e-7);
  EXPECT_EQ(v.chi(5), 0.0);  // label 0 is empty whatever the counter says
  const auto back = v.to_counters();
  for (std::size_t i = 0; i < counters.size(); ++i) {
    if (i != 5) {
      EXPECT_EQ(back[i], counters[i]) << i;
    }
  }
  // Erosion below one count is kept (float χ + remainder) and shows in the float export.
  bm::Volume w = v;
  w.erode(7, 0.4 / 255.0);
  EXPECT_EQ(w.to_counters()[7], counters[7]);  // rounds back to the same counter
  EXPECT_LT(w.to_sample().fraction[7], v.to_sample().fraction[7]);
}
