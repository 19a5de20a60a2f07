// split_voxels / merge_voxels (solution verification): split keeps the same bone exactly,
// merge keeps the total bone volume and the covered region, and merge(split(s)) == s.
#include <gtest/gtest.h>

#include <random>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"

namespace {

using namespace burrbench::data_schema;

// An odd-sized two-class sample with partial voxels everywhere (dims not multiples of 2).
SampleVolume random_sample() {
  SampleVolume s;
  s.dims = {7, 5, 3};
  s.voxel_mm = 0.1;
  s.origin_mm = {1.0, -2.0, 0.5};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (std::size_t i = 0; i < s.voxel_count(); ++i) {
    const float r = u(rng);
    s.labels.push_back(r < 0.2f ? 0 : r < 0.6f ? 1 : 2);
    s.fraction.push_back(s.labels.back() ? u(rng) : 0.0f);
  }
  return s;
}

std::array<double, 3> bone_mm3(const SampleVolume& s) {  // per class 1, 2 and total
  std::array<double, 3> v{};
  const double cell = s.voxel_mm * s.voxel_mm * s.voxel_mm;
  for (std::size_t i = 0; i < s.voxel_count(); ++i) {
    if (s.labels[i] == 1) v[0] += s.fraction[i] * cell;
    if (s.labels[i] == 2) v[1] += s.fraction[i] * cell;
    v[2] += s.fraction[i] * cell;
  }
  return v;
}

TEST(SampleResample, SplitKeepsEveryClassAndTheCoveredRegion) {
  const SampleVolume s = random_sample();
  const SampleVolume f = import::split_voxels(s, 2);
  EXPECT_EQ(f.dims, (std::array<std::size_t, 3>{14, 10, 6}));
  EXPECT_DOUBLE_EQ(f.voxel_mm, 0.05);
  // First corner: centre − half a voxel, the same at both sizes.
  const glm::dvec3 c0 = s.origin_mm - 0.5 * s.voxel_mm, c1 = f.origin_mm - 0.5 * f.voxel_mm;
  EXPECT_NEAR(glm::length(c0 - c1), 0.0, 1e-12);
  const auto a = bone_mm3(s), b = bone_mm3(f);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a[std::size_t(k)], b[std::size_t(k)], 1e-9 * a[2]);
  // Every fine voxel centre lies in the coarse voxel it came from.
  for (std::size_t z = 0; z < f.dims[2]; ++z)
    for (std::size_t y = 0; y < f.dims[1]; ++y)
      for (std::size_t x = 0; x < f.dims[0]; ++x) {
        const glm::dvec3 p = f.centre_mm(x, y, z);
        const glm::dvec3 q = s.centre_mm(x / 2, y / 2, z / 2);
        for (int ax = 0; ax < 3; ++ax) ASSERT_LT(std::abs(p[ax] - q[ax]), 0.5 * s.voxel_mm);
        ASSERT_EQ(f.labels[f.index(x, y, z)], s.labels[s.index(x / 2, y / 2, z / 2)]);
      }
  validate(f, "split");
}

TEST(SampleResample, MergeOfASplitGivesTheSampleBack) {
  const SampleVolume s = random_sample();
  for (int n : {2, 3}) {
    const SampleVolume back = import::merge_voxels(import::split_voxels(s, n), n);
    EXPECT_EQ(back.dims, s.dims);
    EXPECT_DOUBLE_EQ(back.voxel_mm, s.voxel_mm);
    EXPECT_NEAR(glm::length(back.origin_mm - s.origin_mm), 0.0, 1e-12);
    EXPECT_EQ(back.labels, s.labels);
    for (std::size_t i = 0; i < s.voxel_count(); ++i) ASSERT_NEAR(back.fraction[i], s.fraction[i], 1e-6f);
  }
}

TEST(SampleResample, MergeKeepsTheBoneVolumeAndGivesBlocksToTheirMajorityClass) {
  const SampleVolume s = random_sample();
  const SampleVolume m = import::merge_voxels(s, 2);
  EXPECT_EQ(m.dims, (std::array<std::size_t, 3>{4, 3, 2}));  // padded with empty voxels
  EXPECT_DOUBLE_EQ(m.voxel_mm, 0.2);
  const glm::dvec3 c0 = s.origin_mm - 0.5 * s.voxel_mm, c1 = m.origin_mm - 0.5 * m.voxel_mm;
  EXPECT_NEAR(glm::length(c0 - c1), 0.0, 1e-12);
  EXPECT_NEAR(bone_mm3(m)[2], bone_mm3(s)[2], 1e-6 * bone_mm3(s)[2]);
  // Block (0,0,0) by hand.
  double b1 = 0, b2 = 0;
  for (std::size_t z = 0; z < 2; ++z)
    for (std::size_t y = 0; y < 2; ++y)
      for (std::size_t x = 0; x < 2; ++x) {
        const std::size_t i = s.index(x, y, z);
        (s.labels[i] == 1 ? b1 : s.labels[i] == 2 ? b2 : b1) += s.labels[i] ? s.fraction[i] : 0.0;
      }
  EXPECT_EQ(m.labels[0], b2 > b1 ? 2 : 1);
  EXPECT_NEAR(m.fraction[0], (b1 + b2) / 8, 1e-6);
  validate(m, "merge");
  EXPECT_THROW(import::merge_voxels(s, 0), burrbench::InputError);
}

}  // namespace
