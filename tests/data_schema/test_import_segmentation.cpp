// Segmentation of a grey CT phantom with known compact/trabecular geometry, and the
// synthetic sample generator.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <nlohmann/json.hpp>

#include "test_formats_util.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/segment.hpp"
#include "burrbench/data_schema/import/synth.hpp"

namespace {
using namespace burrbench::data_schema;
using namespace burrbench::data_schema::import;

struct Phantom {
  ImageVolume ct;
  std::vector<std::uint8_t> truth;
};

// 64×64×48 voxels of 0.1 mm: air above z = 40; a 1 mm compact roof (z 30..39) and two
// 0.8 mm compact side walls (x < 8, x ≥ 56); a trabecular core with seeded random
// spherical pores (radius 2–6 voxels) up to 65 % porosity. Grey: bone 1000, empty 0,
// Gaussian noise σ = 150.
Phantom make_phantom(unsigned seed) {
  constexpr double kPorosity = 0.65;  // BV/TV 0.35: dense trabecular bone
  Phantom p;
  auto& v = p.ct;
  v.dims = {64, 64, 48};
  v.spacing_mm = glm::dvec3(0.1);
  v.origin_mm = {-3.2, 1.0, 0.05};
  const std::size_t n = v.voxel_count();
  p.truth.assign(n, 0);
  auto inside_core = [](long x, long, long z) { return z < 30 && x >= 8 && x < 56; };
  for (long z = 0; z < 48; ++z)
    for (long y = 0; y < 64; ++y)
      for (long x = 0; x < 64; ++x) {
        const std::size_t i = v.index(std::size_t(x), std::size_t(y), std::size_t(z));
        if (z >= 40) p.truth[i] = kEmpty;
        else if (inside_core(x, y, z)) p.truth[i] = kTrabecular;
        else p.truth[i] = kCompact;
      }
  std::mt19937 rng(seed);
  // Centres also beyond the core, so the porosity stays uniform up to the compact walls.
  std::uniform_real_distribution<double> ux(3, 61), uy(-5, 69), uz(-5, 35), ur(2, 6);
  std::size_t core = 0, pores = 0;
  for (auto t : p.truth) core += t == kTrabecular;
  while (double(pores) < kPorosity * double(core)) {
    const double cx = ux(rng), cy = uy(rng), cz = uz(rng), r = ur(rng);
    for (long z = long(cz - r) - 1; z <= long(cz + r) + 1; ++z)
      for (long y = long(cy - r) - 1; y <= long(cy + r) + 1; ++y)
        for (long x = long(cx - r) - 1; x <= long(cx + r) + 1; ++x) {
          if (x < 0 || y < 0 || z < 0 || x >= 64 || y >= 64 || z >= 48) continue;
          const double d2 = (x - cx) * (x - cx) + (y - cy) * (y - cy) + (z - cz) * (z - cz);
          const std::size_t i = v.index(std::size_t(x), std::size_t(y), std::size_t(z));
          if (d2 <= r * r && p.truth[i] == kTrabecular) {
            p.truth[i] = kEmpty;
            ++pores;
          }
        }
  }
  std::normal_distribution<double> noise(0, 150);
  v.values.resize(n);
  for (std::size_t i = 0; i < n; ++i) v.values[i] = float((p.truth[i] ? 1000.0 : 0.0) + noise(rng));
  v.source_type = VoxelType::kFloat32;
  return p;
}

class ImportSegmentationPhantom : public ::testing::TestWithParam<unsigned> {};

TEST_P(ImportSegmentationPhantom, ClassifiedAtLeast95PercentRight) {
  const Phantom p = make_phantom(GetParam());
  const Segmentation s = segment_ct(p.ct, SegmentationSettings{}, "phantom");
  ASSERT_EQ(s.sample.labels.size(), p.truth.size());
  std::size_t right = 0, right_compact = 0, compact = 0, right_trab = 0, trab = 0;
  for (std::size_t i = 0; i < p.truth.size(); ++i) {
    right += s.sample.labels[i] == p.truth[i];
    if (p.truth[i] == kCompact) { ++compact; right_compact += s.sample.labels[i] == kCompact; }
    if (p.truth[i] == kTrabecular) { ++trab; right_trab += s.sample.labels[i] == kTrabecular; }
  }
  const double acc = double(right) / double(p.truth.size());
  RecordProperty("accuracy", std::to_string(acc));
  std::printf("phantom: overall %.4f, compact %.4f, trabecular %.4f\n", acc, double(right_compact) / double(compact),
              double(right_trab) / double(trab));
  EXPECT_GE(acc, 0.95);
  // Each class on its own too: a segmentation calling everything "trabecular" fails here.
  EXPECT_GE(double(right_compact) / double(compact), 0.90);
  EXPECT_GE(double(right_trab) / double(trab), 0.90);
  // Geometry carried over, settings recorded.
  EXPECT_EQ(s.sample.voxel_mm, 0.1);
  EXPECT_EQ(s.sample.origin_mm, glm::dvec3(-3.2, 1.0, 0.05));
  const auto j = nlohmann::json::parse(s.sample.segmentation_json);
  EXPECT_EQ(j.at("threshold_method"), "otsu");
  EXPECT_NEAR(j.at("threshold").get<double>(), 500.0, 120.0);
  EXPECT_NEAR(j.at("bone_grey").get<double>(), 1000.0, 30.0);
  EXPECT_NEAR(j.at("empty_grey").get<double>(), 0.0, 30.0);
  EXPECT_TRUE(j.contains("bvtv_radius_mm") && j.contains("compact_bvtv") && j.contains("compact_open_mm"));
}

INSTANTIATE_TEST_SUITE_P(Seeds, ImportSegmentationPhantom, ::testing::Values(7u, 8u));

TEST(ImportSegmentation, FractionFromCalibrationGreysIsClampedToUnitInterval) {
  ImageVolume ct;
  ct.dims = {8, 8, 8};
  ct.spacing_mm = glm::dvec3(0.5);
  ct.values.assign(512, 0.0f);
  for (std::size_t i = 256; i < 512; ++i) ct.values[i] = (i % 3 == 0) ? 1400.0f : (i % 3 == 1 ? 900.0f : 600.0f);
  SegmentationSettings s;
  s.threshold = 500;
  s.empty_grey = 100;
  s.bone_grey = 1100;
  const auto r = segment_ct(ct, s, "ct");
  for (std::size_t i = 0; i < 256; ++i) {
    EXPECT_EQ(r.sample.labels[i], kEmpty);
    EXPECT_EQ(r.sample.fraction[i], 0.0f);
  }
  for (std::size_t i = 256; i < 512; ++i) {
    ASSERT_NE(r.sample.labels[i], kEmpty);
    const float want = (i % 3 == 0) ? 1.0f : (i % 3 == 1 ? 0.8f : 0.5f);
    EXPECT_NEAR(r.sample.fraction[i], want, 1e-6) << i;
  }
  EXPECT_EQ(nlohmann::json::parse(r.sample.segmentation_json).at("threshold_method"), "given");
}

TEST(ImportSegmentation, RefusesAnisotropicVoxelsAndBadSettings) {
  ImageVolume ct;
  ct.dims = {4, 4, 4};
  ct.spacing_mm = {0.1, 0.1, 0.2};
  ct.values.assign(64, 1.0f);
  EXPECT_THROW(segment_ct(ct, {}, "ct"), burrbench::InputError);
  ct.spacing_mm = glm::dvec3(0.1);
  SegmentationSettings s;
  s.compact_bvtv = 1.5;
  EXPECT_THROW(segment_ct(ct, s, "ct"), burrbench::InputError);
  for (const double bad : {-1.0, 1e9}) {  // the compact opening radius is named as itself
    SegmentationSettings o;
    o.compact_open_mm = bad;
    burrbench::test::expect_input_error([&] { segment_ct(ct, o, "ct"); }, {"ct: ", "compact_open_mm"});
  }
}

TEST(ImportSynth, SameSeedSameVolumeAndPorosityAsAsked) {
  SynthSettings s;
  s.extent_mm = {4, 4, 3};
  s.seed = 3;
  const SampleVolume a = synth_sample(s), b = synth_sample(s);
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.fraction, b.fraction);
  EXPECT_EQ(a.dims, (std::array<std::size_t, 3>{40, 40, 30}));
  EXPECT_EQ(a.origin_mm, glm::dvec3(0.05));
  s.seed = 4;
  EXPECT_NE(synth_sample(s).fraction, a.fraction);
  // Core (below the 1 mm compact layer = z < 20): mean χ = 1 − porosity.
  double core = 0;
  std::size_t n = 0, compact_ok = 0, compact_n = 0;
  for (std::size_t z = 0; z < 30; ++z)
    for (std::size_t y = 0; y < 40; ++y)
      for (std::size_t x = 0; x < 40; ++x) {
        const auto i = a.index(x, y, z);
        if (z < 20) { core += a.fraction[i]; ++n; EXPECT_NE(a.labels[i], kCompact); }
        else { ++compact_n; compact_ok += a.labels[i] == kCompact && a.fraction[i] == 1.0f; }
      }
  EXPECT_NEAR(core / double(n), 0.4, 1e-3);
  EXPECT_EQ(compact_ok, compact_n);
  EXPECT_NO_THROW(validate(a, "synth"));
}

}  // namespace
