#include "burrbench/model/geometry.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::model {

namespace {
constexpr double kPi = std::numbers::pi;
double sphere_volume(double r) { return 4.0 / 3.0 * kPi * r * r * r; }
}  // namespace

double voxel_sphere_radius(double voxel_mm) {
  return voxel_mm * std::cbrt(3.0 / (4.0 * kPi));
}

double lens_volume(double R, double eta, double d) {
  if (d >= R + eta) return 0;
  if (d <= std::abs(R - eta)) return sphere_volume(std::min(R, eta));
  // Intersection of two spheres (radii R, η, centres d apart): sum of two caps.
  const double s = R + eta - d;
  return kPi * s * s *
         (d * d + 2 * d * eta - 3 * eta * eta + 2 * d * R + 6 * R * eta - 3 * R * R) /
         (12 * d);
}

LensGeometry lens_geometry(double R, double eta, double d) {
  LensGeometry g;
  if (d >= R + eta) return g;
  if (d <= std::abs(R - eta)) {
    g.regime = Regime::kInside;
    g.volume_mm3 = sphere_volume(std::min(R, eta));
    g.lever_mm = d;
    return g;
  }
  g.regime = Regime::kLens;
  g.volume_mm3 = lens_volume(R, eta, d);
  g.lever_mm = d / 2 + (R * R - eta * eta) / (2 * d);
  g.disc_area_mm2 = std::max(0.0, kPi * (R * R - g.lever_mm * g.lever_mm));
  return g;
}

LensTable::LensTable(double R, double l, int intervals)
    : R_(R), l_(l), eta_(voxel_sphere_radius(l)), n_(intervals) {
  BURRBENCH_CHECK(R > 0 && l > 0 && intervals >= 2, "LensTable needs R, l > 0");
  d2_lo_ = (R - eta_) * (R - eta_);
  d2_hi_ = (R + eta_) * (R + eta_);
  inv_h_ = n_ / (d2_hi_ - d2_lo_);
  v_inside_ = sphere_volume(std::min(R, eta_));
  tab_.resize(4 * static_cast<std::size_t>(n_ + 1));
  for (int i = 0; i <= n_; ++i) {
    const double d2 = d2_lo_ + (d2_hi_ - d2_lo_) * i / n_;
    const double d = std::sqrt(d2);
    double* e = &tab_[4 * static_cast<std::size_t>(i)];
    e[3] = d > 0 ? 1.0 / d : 0.0;  // only at d = 0 when R = η; never read there
    if (i == 0) {  // inner edge: limit of the lens forms (d = 0 when R = η)
      e[0] = v_inside_;
      e[2] = d2 > 0 ? 0.5 + (R * R - eta_ * eta_) / (2 * d2) : 0.5;
      const double r = e[2] * d;
      e[1] = std::max(0.0, kPi * (R * R - r * r));
    } else if (i == n_) {
      e[0] = 0;
      e[1] = 0;
      e[2] = R / d;
    } else {
      const LensGeometry g = lens_geometry(R, eta_, d);
      e[0] = g.volume_mm3;
      e[1] = g.disc_area_mm2;
      e[2] = g.lever_mm / d;
    }
  }
}

double immersion_depth(double R, double M) {
  // s = b/R solves s³ − 3s² + 3m = 0 with m = M/(πR³) ∈ [0, 4/3]; with s = 1 + y the
  // depressed cubic y³ − 3y + (3m − 2) = 0 has the root in y ∈ [−1, 1]
  // y = 2 cos((2π − acos(1 − 3m/2))/3). One safeguarded Newton step polishes it.
  if (!(M > 0)) return 0;
  const double m = std::min(M / (kPi * R * R * R), 4.0 / 3.0);
  const double c = std::clamp(1.0 - 1.5 * m, -1.0, 1.0);
  double s = 1.0 + 2.0 * std::cos((2 * kPi - std::acos(c)) / 3.0);
  // Tiny M: 1 − 3m/2 rounds away m, so start from the series s ≈ √m instead.
  if (m < 1e-6) s = std::sqrt(m);
  for (int it = 0; it < 2; ++it) {  // Newton; f' = s(2 − s) vanishes only at s = 0, 2
    const double fp = s * (2 - s);
    if (!(fp > 1e-6 * s)) break;
    s -= (s * s * (1 - s / 3) - m) / fp;
  }
  return R * std::clamp(s, 0.0, 2.0);
}

}  // namespace burrbench::model
