// The kernel's scratch belongs to its caller (contact.hpp, KernelScratch), not the Volume:
// one scratch reused across radii, quadratures and volumes gives the bits a fresh one gives,
// and a Volume copies as plain data (member-wise, undo log included).
#include <array>
#include <type_traits>

#include <gtest/gtest.h>

#include "burrbench/model/contact.hpp"
#include "lumpy_scene.hpp"

namespace bm = burrbench::model;

namespace {

void expect_same_bits(const bm::ContactResult& a, const bm::ContactResult& b) {
  EXPECT_EQ(a.force_N, b.force_N);
  EXPECT_EQ(a.elastic_N, b.elastic_N);
  EXPECT_EQ(a.friction_N, b.friction_N);
  EXPECT_EQ(a.moment_Nmm, b.moment_Nmm);
  EXPECT_EQ(a.depth_b_mm, b.depth_b_mm);
  EXPECT_EQ(a.power_W_mJ_per_s, b.power_W_mJ_per_s);
  EXPECT_EQ(a.class_mask, b.class_mask);
  EXPECT_EQ(a.dF_dC1, b.dF_dC1);
  EXPECT_EQ(a.dFmu_dmu, b.dFmu_dmu);
}

}  // namespace

static_assert(std::is_nothrow_move_constructible_v<bm::Volume>);

TEST(KernelScratch, ReusedScratchGivesTheBitsOfAFreshOne) {
  const bm::Volume fine = bm::Volume::from_sample(scenes::lumpy(24, 0.1, 3));
  const bm::Volume coarse = bm::Volume::from_sample(scenes::lumpy(12, 0.2, 4));
  const auto prm = scenes::two_classes();
  const glm::dvec3 w(120.0, -40.0, 250.0);
  bm::KernelScratch shared;
  // Radius, voxel size and quadrature change between calls: the table and the voxel list
  // the scratch holds from the call before must not leak into the next.
  for (double R : {0.5, 0.35, 0.5})
    for (const bm::Volume* v : {&fine, &coarse})
      for (bm::Quadrature q : {bm::Quadrature::kLens, bm::Quadrature::kCube, bm::Quadrature::kLens})
        for (glm::dvec3 p : {glm::dvec3(1.1, 0.93, 1.0), glm::dvec3(1.3, 1.2, 0.7)}) {
          const bm::ContactResult reused = bm::evaluate(*v, shared, p, w, R, prm, q);
          ASSERT_GT(reused.bone_volume_mm3, 0.0);
          expect_same_bits(reused, bm::evaluate(*v, p, w, R, prm, q));
        }
}

TEST(KernelScratch, VolumeCopiesAsPlainData) {
  bm::Volume a = bm::Volume::from_sample(scenes::lumpy(16, 0.1, 5));
  const auto prm = scenes::two_classes();
  bm::KernelScratch scratch;
  std::array<double, bm::kMaxClasses> removed{};
  a.begin_undo();
  bm::step(a, scratch, {0.8, 0.8, 0.9}, {0, 300, 0}, 0.4, prm, 1e-2, removed);
  ASSERT_GT(a.undo_entries(), 0u);
  bm::Volume b = a;  // mid-replay: χ and the undo log come along
  EXPECT_EQ(b.undo_entries(), a.undo_entries());
  b.rollback();
  const bm::Volume start = bm::Volume::from_sample(scenes::lumpy(16, 0.1, 5));
  for (std::size_t i = 0; i < a.voxel_count(); ++i) ASSERT_EQ(b.chi(i), start.chi(i)) << i;
  EXPECT_LT(a.bone_volume_by_class()[1] + a.bone_volume_by_class()[2],
            b.bone_volume_by_class()[1] + b.bone_volume_by_class()[2]);  // a keeps its erosion
  b = a;
  expect_same_bits(bm::evaluate(b, scratch, {0.8, 0.8, 0.9}, {0, 300, 0}, 0.4, prm),
                   bm::evaluate(a, {0.8, 0.8, 0.9}, {0, 300, 0}, 0.4, prm));
}
