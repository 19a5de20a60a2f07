// The cube quadrature's per-voxel integrals (cube_cut.hpp) against brute force: the cube
// supersampled at 64³ points (volume, first moment, normal moment) and the section plane
// at 512² = 64³ points (area, its first moment); the h-derivatives and the gradients in v
// against central differences of the closed forms that brute force has checked.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "burrbench/model/cube_cut.hpp"

namespace bm = burrbench::model;

namespace {

struct Brute {
  double volume = 0, area = 0, normal_moment = 0;
  glm::dvec3 moment{0}, section{0};
};

Brute brute(const glm::dvec3& n, double h, double l) {
  Brute b;
  const int N = 64;
  const double cell = l / N, dv = cell * cell * cell;
  for (int i = 0; i < N; ++i)
    for (int j = 0; j < N; ++j)
      for (int k = 0; k < N; ++k) {
        const glm::dvec3 u = glm::dvec3(i + 0.5, j + 0.5, k + 0.5) * cell - glm::dvec3(0.5 * l);
        if (glm::dot(n, u) > h) continue;
        b.volume += dv;
        b.moment += dv * u;
        b.normal_moment += dv * glm::dot(n, u);
      }
  // The section: the plane n·u = h on a square of side l√3 about h n, 512² points.
  const glm::dvec3 e1 = glm::normalize(std::abs(n.x) < 0.9 ? glm::cross(n, glm::dvec3(1, 0, 0)) : glm::cross(n, glm::dvec3(0, 1, 0)));
  const glm::dvec3 e2 = glm::cross(n, e1);
  const int S = 512;
  const double side = l * std::sqrt(3.0), da = (side / S) * (side / S);
  for (int i = 0; i < S; ++i)
    for (int j = 0; j < S; ++j) {
      const glm::dvec3 u = h * n + ((i + 0.5) / S - 0.5) * side * e1 + ((j + 0.5) / S - 0.5) * side * e2;
      if (std::abs(u.x) > 0.5 * l || std::abs(u.y) > 0.5 * l || std::abs(u.z) > 0.5 * l) continue;
      b.area += da;
      b.section += da * u;
    }
  return b;
}

// Normals of every kind: generic, in a coordinate plane, near an axis, below the 1e-3 cut.
std::vector<glm::dvec3> normals() {
  std::vector<glm::dvec3> out = {glm::normalize(glm::dvec3(0.3, -0.5, 0.8)), glm::normalize(glm::dvec3(-1, 1, 1)),
                                 glm::normalize(glm::dvec3(0.6, 0.8, 0.0)), glm::dvec3(0, 0, -1),
                                 glm::normalize(glm::dvec3(2e-4, 0.02, 1.0)), glm::normalize(glm::dvec3(0.7, -0.2, 0.05))};
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  for (int i = 0; i < 4; ++i) out.push_back(glm::normalize(glm::dvec3(g(rng), g(rng), g(rng))));
  return out;
}

}  // namespace

TEST(CubeCut, EveryIntegralMatchesSupersampledCube) {
  const double l = 0.1;
  for (const glm::dvec3& n : normals()) {
    const double reach = 0.5 * l * (std::abs(n.x) + std::abs(n.y) + std::abs(n.z));
    for (double f : {-0.8, -0.35, 0.0, 0.2, 0.6, 0.95}) {
      const double h = f * reach;
      const bm::CubeCut c = bm::cube_cut(n, h, l, true);
      const Brute b = brute(n, h, l);
      SCOPED_TRACE(testing::Message() << "n = (" << n.x << ", " << n.y << ", " << n.z << "), h = " << h);
      // Midpoint sampling errs by O(cell) on the cut's boundary: a few 10⁻³ of the whole, up
      // to half a cell's layer (l/128) when the plane is parallel to a face.
      const int small = (std::abs(n.x) < 0.05) + (std::abs(n.y) < 0.05) + (std::abs(n.z) < 0.05);
      const double k = small >= 2 ? 8.0 : 1.0;
      const double l3 = k * l * l * l, l4 = l3 * l, l2 = k * l * l;
      EXPECT_NEAR(c.volume_mm3, b.volume, 4e-3 * l3);
      EXPECT_NEAR(c.normal_moment_mm4, b.normal_moment, 2e-3 * l4);
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.moment_mm4[i], b.moment[i], 2e-3 * l4);
      EXPECT_NEAR(c.area_mm2, b.area, 1e-2 * l2);
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.section_mm3[i], b.section[i], 5e-3 * l3);
      // The same without derivatives.
      const bm::CubeCut c0 = bm::cube_cut(n, h, l, false);
      EXPECT_DOUBLE_EQ(c0.volume_mm3, c.volume_mm3);
      EXPECT_DOUBLE_EQ(c0.area_mm2, c.area_mm2);
      EXPECT_DOUBLE_EQ(c0.normal_moment_mm4, c.normal_moment_mm4);
    }
  }
}

TEST(CubeCut, EmptyAndWholeCube) {
  const double l = 0.2;
  const glm::dvec3 n = glm::normalize(glm::dvec3(1, 2, 3));
  const double reach = 0.5 * l * (n.x + n.y + n.z);
  const bm::CubeCut none = bm::cube_cut(n, -reach - 1e-9, l, true);
  EXPECT_EQ(none.volume_mm3, 0.0);
  EXPECT_EQ(none.area_mm2, 0.0);
  const bm::CubeCut all = bm::cube_cut(n, reach + 1e-9, l, true);
  EXPECT_NEAR(all.volume_mm3, l * l * l, 1e-15);
  EXPECT_NEAR(all.area_mm2, 0.0, 1e-15);
  EXPECT_NEAR(glm::length(all.moment_mm4), 0.0, 1e-15);
  // Half the cube through its centre, normal along z: ∫ z dV = −l⁴/8.
  const bm::CubeCut half = bm::cube_cut(glm::dvec3(0, 0, 1), 0.0, l, true);
  // (The zero components are raised to 1e-3: the section tilts by 1e-3, O(10⁻⁶) changes.)
  EXPECT_NEAR(half.volume_mm3, 0.5 * l * l * l, 1e-9 * l * l * l);  // corner sums over Π = 10⁻⁶: 6e-12
  EXPECT_NEAR(half.area_mm2, l * l, 1e-6 * l * l);
  EXPECT_NEAR(half.normal_moment_mm4, -l * l * l * l / 8, 1e-6 * l * l * l * l);
}

TEST(CubeCut, DerivativesMatchCentralDifferences) {
  const double l = 0.1, R = 1.0;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> U(-1, 1);
  for (int trial = 0; trial < 40; ++trial) {
    const glm::dvec3 dir = glm::normalize(glm::dvec3(U(rng), U(rng), U(rng)));
    const glm::dvec3 v = (R + 0.8 * U(rng) * 0.5 * l * std::sqrt(3.0)) * dir;
    auto at = [&](const glm::dvec3& x) {
      const double d = glm::length(x);
      return bm::cube_cut(x / d, R - d, l, true);
    };
    const double d = glm::length(v), h = R - d;
    const bm::CubeCut c = at(v);
    if (c.volume_mm3 <= 0 || c.volume_mm3 >= l * l * l) continue;
    // ∂/∂h at fixed n̂
    const double eh = 1e-7;
    const bm::CubeCut hp = bm::cube_cut(v / d, h + eh, l, true), hm = bm::cube_cut(v / d, h - eh, l, true);
    EXPECT_NEAR(c.area_mm2, (hp.volume_mm3 - hm.volume_mm3) / (2 * eh), 1e-6 * l * l);
    EXPECT_NEAR(c.area_dh_mm, (hp.area_mm2 - hm.area_mm2) / (2 * eh), 1e-5 * l);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(c.section_mm3[i], (hp.moment_mm4[i] - hm.moment_mm4[i]) / (2 * eh), 1e-6 * l * l * l);
      EXPECT_NEAR(c.section_dh_mm2[i], (hp.section_mm3[i] - hm.section_mm3[i]) / (2 * eh), 1e-5 * l * l);
    }
    // ∇_v of ΔV, A and the radial moment m = ΔV·d + μₙ
    const bm::CubeCutGradient g = bm::cube_cut_gradient(c, v, h);
    const double ev = 1e-7;
    for (int i = 0; i < 3; ++i) {
      glm::dvec3 e(0);
      e[i] = ev;
      const bm::CubeCut p = at(v + e), m = at(v - e);
      const double dp = glm::length(v + e), dm = glm::length(v - e);
      EXPECT_NEAR(g.volume[i], (p.volume_mm3 - m.volume_mm3) / (2 * ev), 1e-6 * l * l);
      EXPECT_NEAR(g.area[i], (p.area_mm2 - m.area_mm2) / (2 * ev), 1e-5 * l);
      const double mp = p.volume_mm3 * dp + p.normal_moment_mm4, mm = m.volume_mm3 * dm + m.normal_moment_mm4;
      EXPECT_NEAR(g.radial_moment[i], (mp - mm) / (2 * ev), 1e-6 * l * l * R);
    }
  }
}
