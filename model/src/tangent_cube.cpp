// Tangent-linear pass of the cube quadrature (docs/model.md "The cube quadrature",
// "Its sensitivities"). The cut voxels' ΔV, A and radial moment m = ΔV·d + μₙ depend on
// the whole of v = c − p (not on d² alone, as the lens's), so each cut voxel's gradient
// (cube_cut_gradient) is applied per direction; no per-class matrices as in tangent.cpp.
#include <cmath>

#include "burrbench/model/cube_cut.hpp"
#include "kernel_scratch.hpp"
#include "tangent.hpp"

namespace burrbench::model::detail {
namespace {
constexpr std::int8_t kAlpha = 0, kMu = 2;  // as tangent.cpp
}  // namespace

void TangentState::differentiate_cube(const Volume& vol, const ContactResult& c, bool eroded, glm::dvec3* dF,
                                      glm::dvec3* dT) {
  const Scratch& sc = sc_;
  const KernelState& st = sc.state;
  const bool forces = dF != nullptr;
  const std::vector<std::size_t>& act = act_;
  const auto& dpj = dpj_;
  const double R = st.radius, l = st.voxel, l3 = l * l * l;
  const LensVoxel* lv = sc.lens.data();

  // ---- first moments: ∂mass_k = ΔV ∂χ + χ ∇ΔV·∂v, ∂M₁ = ∂(χ m n̂), ∂v = −∂p ----
  for (const std::size_t j : act) {
    dmass_[j].fill(0.0);
    dm1_[j] = glm::dvec3(0);
  }
  for (std::size_t i = 0; i < st.lens_count; ++i) {
    const LensVoxel& v = lv[i];
    const glm::dvec3 vv(v.vx, v.vy, v.vz);
    const double d = std::sqrt(v.d2), h = R - d, chi = v.chi;
    const glm::dvec3 n = vv / d;
    const CubeCut cut = cube_cut(n, h, l, true);
    const CubeCutGradient g = cube_cut_gradient(cut, vv, h);
    const double m = cut.volume_mm3 * d + cut.normal_moment_mm4;
    const double* tg = tangent(v.index);
    for (const std::size_t j : act) {
      const double dchi = tg ? tg[j] : 0.0;
      const glm::dvec3 dv = -dpj[j];
      dmass_[j][v.label] += cut.volume_mm3 * dchi + chi * glm::dot(g.volume, dv);
      dm1_[j] += (dchi * m) * n + chi * (glm::dot(g.radial_moment, dv) * n + m * (dv - glm::dot(n, dv) * n) / d);
    }
  }
  for (const std::size_t j : path_) dm1_[j] -= l3 * st.inside_chi * dpj[j];  // the inside moves as a block
  inside_tangents(vol, l3);
  elastic_tangents(st, R, forces, dF);
  if (!st.friction) return;

  // ---- friction, its couple and power on the cut voxels of the contact disc ----
  // s = χ A P at the tangent point R n̂: F_μ = Σ μ s n̂ × ω̂, T = Σ μ R s [(n̂·ω̂) n̂ − ω̂],
  // W = μ|ω| χ P R (1 − (n̂·ω̂)²) A; P = p₀ √(1 − ξ²/a²), ξ² = R²(1 − (N̂·n̂)²).
  const glm::dvec3 w = st.w, N = st.n;
  const double p0 = st.p0, a2 = st.a2;
  std::array<glm::dvec3, kMaxDirections> dfm{}, dtm{};
  for (std::size_t i = 0; i < st.lens_count; ++i) {
    const LensVoxel& v = lv[i];
    const glm::dvec3 vv(v.vx, v.vy, v.vz);
    const double d = std::sqrt(v.d2), h = R - d, chi = v.chi;
    const glm::dvec3 n = vv / d;
    const double cn = glm::dot(N, n), xi2 = R * R * (1 - cn * cn);
    if (xi2 >= a2) continue;  // off the disc
    const std::size_t k = v.label;
    const bool erodes = eroded && st.kero[k] > 0 && st.wmu[k] != 0;
    if (!forces && !erodes) continue;
    const CubeCut cut = cube_cut(n, h, l, true);
    const double A = cut.area_mm2;
    const glm::dvec3 gA = cube_cut_gradient(cut, vv, h).area;
    const double sq = std::sqrt(1.0 - xi2 / a2), P = p0 * sq;
    const double e_xi = -p0 / (2 * sq * a2), e_a2 = p0 * xi2 / (2 * sq * a2 * a2);
    const double s = chi * A * P, mu = prm_.by_label[k].mu;
    const double vw = glm::dot(n, w), q = 1 - vw * vw;
    const glm::dvec3 L = vw * n - w;
    const double wmu = st.wmu[k], W = wmu * chi * P * R * q * A, kero = st.kero[k];
    double* tg = tangent(v.index);
    const bool clamped = vol.chi(v.index) == 0.0;
    for (const std::size_t j : act) {
      const double dchi = tg ? tg[j] : 0.0;
      const glm::dvec3 dv = -dpj[j];
      const glm::dvec3 dnh = (dv - glm::dot(n, dv) * n) / d;  // ∂n̂
      const double dcn = glm::dot(dn_[j], n) + glm::dot(N, dnh);
      const double dP = sq * dp0_[j] + e_xi * (-2 * R * R * cn * dcn) + e_a2 * da2_[j];
      const double dA = glm::dot(gA, dv);
      const double ds = dchi * A * P + chi * (dA * P + A * dP);
      if (forces) {
        dfm[j] += mu * glm::cross(ds * n + s * dnh, w);
        if (dT) dtm[j] += (mu * R) * (ds * L + s * (glm::dot(dnh, w) * n + vw * dnh));
      }
      if (!erodes) continue;
      // χ ← max(0, χ − W·kero), kero = dt/(α l³), as the lens (tangent.cpp)
      double t = 0.0;
      if (!clamped) {
        const double dq = -2 * vw * glm::dot(w, dnh);
        double dW = wmu * R * (dchi * P * q * A + chi * (dP * q * A + P * dq * A + P * q * dA));
        if (kind_[j] == kMu && label_[j] == k) dW += W;
        t = dchi - kero * dW;
        if (kind_[j] == kAlpha && label_[j] == k) t += W * kero;
      }
      tnew_[j] = t;
      drem_[j][k] += l3 * (dchi - t);
    }
    if (!erodes) continue;
    if (!tg) {
      bool any = false;
      for (const std::size_t j : act) any |= tnew_[j] != 0;
      if (!any) continue;
      tg = tangent_or_new(v.index);
    }
    for (const std::size_t j : act) tg[j] = tnew_[j];
  }
  if (!forces) return;
  for (const std::size_t j : act) {
    glm::dvec3 f = dfm[j], t = dtm[j];
    if (kind_[j] == kMu) {
      f += prm_.by_label[label_[j]].mu * c.dFmu_dmu[label_[j]];
      t += prm_.by_label[label_[j]].mu * c.dTmu_dmu[label_[j]];
    }
    dF[j] += f;
    if (dT) dT[j] = t;
  }
}

}  // namespace burrbench::model::detail
