#pragma once
// Voxel-sphere geometry of MODEL.md: each voxel of side l is a sphere of equal volume,
// radius η = l·(3/(4π))^(1/3). For a burr of radius R and a voxel sphere at distance d:
// overlap volume ΔV(d), area Δσ(d) of the disc where the two surfaces meet, and the
// distance r(d) from the burr centre to that disc (the lever). Exact closed forms here;
// the kernel uses tables of them (LensTable) whose error the tests bound.
#include <vector>

namespace burrbench::model {

double voxel_sphere_radius(double voxel_mm);  // η

enum class Regime { kNone, kLens, kInside };  // kInside: the smaller sphere lies in the larger

struct LensGeometry {
  Regime regime = Regime::kNone;
  double volume_mm3 = 0;     // ΔV
  double disc_area_mm2 = 0;  // Δσ (0 unless kLens)
  double lever_mm = 0;       // r; for kInside r = d (MODEL.md), for kNone 0
};

// Exact: d ≥ R+η → none; d ≤ |R−η| → inside (ΔV = volume of the smaller sphere, l³ when
// η ≤ R); otherwise the lens (two-sphere intersection), Δσ = π(R² − r²),
// r = d/2 + (R² − η²)/(2d).
LensGeometry lens_geometry(double burr_radius_mm, double eta_mm, double d_mm);
double lens_volume(double burr_radius_mm, double eta_mm, double d_mm);  // exact, any regime

// Tables of ΔV, Δσ, r/d and 1/d over the lens range as functions of d², linearly interpolated.
// Only valid for |R−η|² < d² < (R+η)² (the caller classifies the regime first).
class LensTable {
 public:
  LensTable() = default;
  LensTable(double burr_radius_mm, double voxel_mm, int intervals = 1024);
  double radius() const { return R_; }
  double voxel() const { return l_; }
  double eta() const { return eta_; }
  double d2_inner() const { return d2_lo_; }  // |R−η|²
  double d2_outer() const { return d2_hi_; }  // (R+η)²
  double inside_volume() const { return v_inside_; }
  // Raw view for the kernel's hot loop (values in locals, so stores elsewhere cannot be
  // assumed to alias them): node i holds {ΔV, Δσ, r/d, 1/d} at data()[4i..4i+3].
  const double* data() const { return tab_.data(); }
  double inv_step() const { return inv_h_; }
  int intervals() const { return n_; }
  struct Entry { double volume, area, lever_over_d, inv_d; };
  Entry at(double d2) const {
    double u = (d2 - d2_lo_) * inv_h_;
    int i = static_cast<int>(u);
    if (i < 0) i = 0;
    if (i >= n_) i = n_ - 1;
    const double f = u - i;
    const double* a = &tab_[4 * static_cast<std::size_t>(i)];
    return {a[0] + f * (a[4] - a[0]), a[1] + f * (a[5] - a[1]), a[2] + f * (a[6] - a[2]),
            a[3] + f * (a[7] - a[3])};
  }

 private:
  double R_ = 0, l_ = 0, eta_ = 0, d2_lo_ = 0, d2_hi_ = 0, inv_h_ = 0, v_inside_ = 0;
  int n_ = 0;
  std::vector<double> tab_;  // (n_+1) × {ΔV, Δσ, r/d, 1/d}
};

// Immersion depth b ∈ [0, 2R] solving π b² (R − b/3) = M (M clamped to [0, 4πR³/3]).
double immersion_depth(double burr_radius_mm, double bone_volume_mm3);

}  // namespace burrbench::model
