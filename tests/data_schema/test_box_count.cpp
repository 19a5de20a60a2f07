// The segmentation's box count (local BV/TV) against a brute-force sum over every box:
// exact, for boxes smaller and larger than the volume, on odd non-cubic dimensions.
#include <cstdint>
#include <random>
#include <vector>

#include <gtest/gtest.h>

// A white-box test of a private piece of data_schema's CT importer.
#include "../../data_schema/src/import/morphology3d.hpp"

using burrbench::data_schema::import::detail::box_count;
using burrbench::data_schema::import::detail::Dims;

namespace {
float brute_force(const std::vector<std::uint8_t>& m, const Dims& d, long x, long y, long z, int r) {
  float n = 0;
  for (long k = z - r; k <= z + r; ++k)
    for (long j = y - r; j <= y + r; ++j)
      for (long i = x - r; i <= x + r; ++i) {
        if (i < 0 || j < 0 || k < 0 || i >= long(d[0]) || j >= long(d[1]) || k >= long(d[2])) continue;
        n += m[(std::size_t(k) * d[1] + std::size_t(j)) * d[0] + std::size_t(i)];
      }
  return n;
}
}  // namespace

TEST(BoxCount, EqualsABruteForceSumOverEveryBox) {
  const Dims d{7, 9, 13};
  std::mt19937 rng(3);
  std::vector<std::uint8_t> m(d[0] * d[1] * d[2]);
  for (auto& v : m) v = std::uint8_t(rng() % 3 == 0);
  for (int r : {0, 1, 2, 5, 8}) {  // 8: the box is larger than the volume on every axis
    const std::vector<float> got = box_count(m, d, r);
    ASSERT_EQ(got.size(), m.size());
    std::size_t wrong = 0;
    for (long z = 0; z < long(d[2]); ++z)
      for (long y = 0; y < long(d[1]); ++y)
        for (long x = 0; x < long(d[0]); ++x)
          wrong += got[(std::size_t(z) * d[1] + std::size_t(y)) * d[0] + std::size_t(x)] !=
                   brute_force(m, d, x, y, z, r);
    EXPECT_EQ(wrong, 0u) << "r = " << r;
  }
}

TEST(BoxCount, OneSliceAndAFullVolume) {
  const Dims one{5, 4, 1};
  const std::vector<std::uint8_t> full(5 * 4, 1);
  const std::vector<float> got = box_count(full, one, 1);
  EXPECT_EQ(got[0], 4.0f);            // a corner: 2 × 2 × 1
  EXPECT_EQ(got[1 * 5 + 1], 9.0f);    // inside: 3 × 3 × 1
  const Dims cube{6, 6, 6};
  const std::vector<float> all = box_count(std::vector<std::uint8_t>(216, 1), cube, 1);
  EXPECT_EQ(all[(2 * 6 + 2) * 6 + 2], 27.0f);
  EXPECT_EQ(all[0], 8.0f);
}
