#include "tangent.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "burrbench/data_schema/error.hpp"
#include "kernel_scratch.hpp"

namespace burrbench::model::detail {
namespace {
constexpr double kPi = std::numbers::pi;
constexpr std::int8_t kAlpha = 0, kC1 = 1, kMu = 2, kPath = 3;
}  // namespace

TangentState::TangentState(const Volume& vol, const std::vector<Direction>& dirs,
                           const ModelParams& prm)
    : P_(dirs.size()), prm_(prm), nx_(vol.dims()[0]), ny_(vol.dims()[1]) {
  BURRBENCH_CHECK(P_ <= kMaxDirections, "too many sensitivity directions");
  for (const auto& d : dirs) {
    kind_.push_back(d.kind == Direction::Kind::kLogAlpha ? kAlpha
                    : d.kind == Direction::Kind::kLogC1  ? kC1
                    : d.kind == Direction::Kind::kLogMu  ? kMu
                                                         : kPath);
    label_.push_back(d.label);
  }
  slot_.assign(vol.voxel_count(), -1);
  row_lo_.assign(vol.dims()[1] * vol.dims()[2], std::numeric_limits<std::int32_t>::max());
  row_hi_.assign(vol.dims()[1] * vol.dims()[2], -1);
  for (std::size_t j = 0; j < P_; ++j)
    if (kind_[j] == kPath) path_.push_back(j);
  drem_.assign(P_, std::array<double, kMaxClasses>{});
}

double* TangentState::tangent(std::uint32_t v) {
  const std::int32_t s = slot_[v];
  return s < 0 ? nullptr : &dchi_[std::size_t(s) * P_];
}

double* TangentState::tangent_or_new(std::uint32_t v) {
  if (slot_[v] < 0) {
    slot_[v] = std::int32_t(touched_.size());
    touched_.push_back(v);
    stamp_.push_back(eval_);
    dchi_.resize(dchi_.size() + P_, 0.0);
    const std::size_t row = v / nx_;
    const std::int32_t x = std::int32_t(v % nx_);
    row_lo_[row] = std::min(row_lo_[row], x);
    row_hi_[row] = std::max(row_hi_[row], x);
  }
  return &dchi_[std::size_t(slot_[v]) * P_];
}

void TangentState::differentiate(const Volume& vol, const ContactResult& c, const glm::dvec3* dp,
                                 bool eroded, glm::dvec3* dF) {
  const std::size_t P = P_;
  for (std::size_t j = 0; j < P; ++j) dF[j] = glm::dvec3(0);
  const KernelState& st = vol.scratch().state;
  const LensTable& tab = vol.scratch().table;
  if (!st.force) return;  // no bone in reach, or no normal: F ≡ 0 here
  ++eval_;
  const double* const T = tab.data();
  const double t_lo = tab.d2_inner(), t_ih = tab.inv_step();
  const int t_last = tab.intervals() - 1;
  const double reach2 = tab.d2_outer(), v_in = tab.inside_volume(), R = tab.radius();
  const double l = vol.voxel_mm(), l3 = l * l * l;
  const LensVoxel* lv = vol.scratch().lens.data();

  // ---- first moments: ∂mass_k, ∂M₁ ----
  // Per-direction accumulators, zeroed for the P directions only (not kMaxDirections).
  auto& dmass = dmass_;
  auto& dm1 = dm1_;
  for (std::size_t j = 0; j < P; ++j) {
    dmass[j].fill(0.0);
    dm1[j] = glm::dvec3(0);
  }
  for (std::size_t i = 0; i < st.lens_count; ++i) {
    const LensVoxel& v = lv[i];
    const glm::dvec3 vv(v.vx, v.vy, v.vz);
    const double u = (v.d2 - t_lo) * t_ih;
    const int ti = std::min(std::max(int(u), 0), t_last);
    const double f = u - ti;
    const double* a = T + 4 * ti;
    const double dV = a[0] + f * (a[4] - a[0]), sV = (a[4] - a[0]) * t_ih;  // ΔV, dΔV/dd²
    const double sR = (a[6] - a[2]) * t_ih;                                  // d(r/d)/dd²
    const double chi = v.chi, w = dV * chi, rd = v.rd;
    const double* tg = tangent(v.index);
    if (tg) stamp_[std::size_t(slot_[v.index])] = eval_;
    if (tg)
      for (std::size_t j = 0; j < P; ++j) {
        const double dw = dV * tg[j];
        dmass[j][v.label] += dw;
        dm1[j] += dw * rd * vv;
      }
    for (std::size_t j : path_) {
      const double dd2 = -2.0 * glm::dot(vv, dp[j]);
      const double dw = chi * sV * dd2;
      dmass[j][v.label] += dw;
      dm1[j] += dw * rd * vv + w * (sR * dd2 * vv - rd * dp[j]);
    }
  }
  // Fully-inside voxels: their mass moves with p as a block (∂M₁ = −v_in·Σχ·δp), and
  // those with a tangent (eroded earlier, now inside) add v_in·∂χ.
  for (std::size_t j = 0; j < P; ++j)
    if (kind_[j] == kPath) dm1[j] += -v_in * st.inside_chi * dp[j];
  if (!touched_.empty()) {
    const glm::dvec3 o = vol.origin_mm(), p = st.p;
    const double reach = std::sqrt(reach2);
    const auto& dims = vol.dims();
    auto range = [&](double c, double oa, std::size_t n, long& lo, long& hi) {
      lo = std::max(0L, long(std::floor((c - reach - oa) / l)));
      hi = std::min(long(n) - 1, long(std::ceil((c + reach - oa) / l)));
    };
    long z0, z1, y0, y1, x0, x1;
    range(p.z, o.z, dims[2], z0, z1);
    range(p.y, o.y, dims[1], y0, y1);
    range(p.x, o.x, dims[0], x0, x1);
    for (long z = z0; z <= z1; ++z)
      for (long y = y0; y <= y1; ++y) {
        const std::size_t row = std::size_t(y) + ny_ * std::size_t(z);
        const long xa = std::max(x0, long(row_lo_[row])), xb = std::min(x1, long(row_hi_[row]));
        for (long x = xa; x <= xb; ++x) {
          const std::size_t idx = std::size_t(x) + nx_ * row;
          const std::int32_t s = slot_[idx];
          if (s < 0 || stamp_[std::size_t(s)] == eval_) continue;  // none, or a lens voxel
          const glm::dvec3 vv = o + l * glm::dvec3(double(x), double(y), double(z)) - p;
          if (glm::dot(vv, vv) >= reach2) continue;
          const double* tg = &dchi_[std::size_t(s) * P];
          const std::uint8_t k = vol.label(idx);
          for (std::size_t j = 0; j < P; ++j) {
            dmass[j][k] += v_in * tg[j];
            dm1[j] += v_in * tg[j] * vv;
          }
        }
      }
  }

  // ---- depth, normal, elastic force ----
  const glm::dvec3 n = st.n;
  const double M = st.M, b = st.b, g = st.g, cbar = st.c1_eff;
  const double a2 = st.a2;
  const bool full = M >= 4.0 / 3.0 * kPi * R * R * R;  // b clamped at 2R
  auto &dfe = dfe_, &da2 = da2_, &dp0 = dp0_;
  auto& dn = dn_;
  for (std::size_t j = 0; j < P; ++j) {
    double dM = 0, dc = 0;
    for (int k = 1; k < kMaxClasses; ++k) {
      dM += dmass[j][std::size_t(k)];
      dc += prm_.by_label[std::size_t(k)].c1_N_per_mm2 * dmass[j][std::size_t(k)];
    }
    dc = (dc - cbar * dM) / M;
    if (kind_[j] == kC1) dc += prm_.by_label[label_[j]].c1_N_per_mm2 * st.mass[label_[j]] / M;
    // π b²(R − b/3) = M  ⇒  dM = π(2Rb − b²) db = π a² db
    const double db = (!full && a2 > 0) ? dM / (kPi * a2) : 0.0;
    const double dg = 1.5 * g / b * db;
    dn[j] = -(dm1[j] - n * glm::dot(n, dm1[j])) / st.m1n;
    dF[j] = (dc * g + cbar * dg) * n + cbar * g * dn[j];
    dfe[j] = dc * g + cbar * dg;
    da2[j] = 2 * (R - b) * db;
    dp0[j] = st.friction ? st.p0 * (dfe[j] / st.fe - da2[j] / a2) : 0.0;
  }
  if (!st.friction) return;

  // ---- friction and friction power ----
  const glm::dvec3 w = st.w;
  const double p0 = st.p0, inv_a2 = 1.0 / a2;
  auto& dG = dG_;
  for (std::size_t j = 0; j < P; ++j) dG[j].fill(glm::dvec3(0));
  auto &dW = dW_, &tnew = tnew_;
  for (std::size_t i = 0; i < st.lens_count; ++i) {
    const LensVoxel& v = lv[i];
    const glm::dvec3 vv(v.vx, v.vy, v.vz);
    const double vn = glm::dot(n, vv), d2 = v.d2, rd = v.rd;
    const double t2 = d2 - vn * vn, xi2 = rd * rd * t2;
    const int k = v.label;
    double* tg = tangent(v.index);
    const double chi = v.chi;
    const bool erodes = eroded && st.kero[std::size_t(k)] > 0 && st.wmu[std::size_t(k)] != 0;
    if (xi2 >= a2) continue;  // off the disc: neither force nor power
    const double u = (d2 - t_lo) * t_ih;
    const int ti = std::min(std::max(int(u), 0), t_last);
    const double f = u - ti;
    const double* a = T + 4 * ti;
    const double area = a[1] + f * (a[5] - a[1]), inv_d = a[3] + f * (a[7] - a[3]);
    const double s_area = (a[5] - a[1]) * t_ih, s_invd = (a[7] - a[3]) * t_ih, s_rd = (a[6] - a[2]) * t_ih;
    const double sq = std::sqrt(1.0 - xi2 * inv_a2);
    const double P0 = p0 * sq;
    const double s = chi * area * P0 * inv_d;
    const double wmu = st.wmu[std::size_t(k)];
    const double r = rd * d2 * inv_d, vwr = glm::dot(vv, w), vw = vwr * inv_d, q = 1.0 - vw * vw;
    const double W = wmu * chi * P0 * r * q * area;
    for (std::size_t j = 0; j < P; ++j) {
      const bool path = kind_[j] == kPath;
      const glm::dvec3 dv = path ? -dp[j] : glm::dvec3(0);
      const double dd2 = path ? -2.0 * glm::dot(vv, dp[j]) : 0.0;
      const double dvn = glm::dot(dn[j], vv) + glm::dot(n, dv);
      const double dt2 = dd2 - 2 * vn * dvn;
      const double drd = s_rd * dd2;
      const double dxi2 = 2 * rd * drd * t2 + rd * rd * dt2;
      const double dP = dp0[j] * sq + p0 * (-(dxi2 * a2 - xi2 * da2[j]) * inv_a2 * inv_a2) / (2 * sq);
      const double darea = s_area * dd2, dinvd = s_invd * dd2;
      const double dchi = tg ? tg[j] : 0.0;
      const double ds = dchi * area * P0 * inv_d +
                        chi * (darea * P0 * inv_d + area * dP * inv_d + area * P0 * dinvd);
      dG[j][std::size_t(k)] += ds * vv + s * dv;
      if (!erodes) continue;
      const double dr = drd * d2 * inv_d + rd * dd2 * inv_d + rd * d2 * dinvd;
      const double dvw = glm::dot(dv, w) * inv_d + vwr * dinvd;
      const double dq = -2 * vw * dvw;
      double dw = wmu * (dchi * P0 * r * q * area +
                         chi * (dP * r * q * area + P0 * dr * q * area + P0 * r * dq * area + P0 * r * q * darea));
      if (kind_[j] == kMu && label_[j] == k) dw += W;
      dW[j] = dw;
    }
    if (!erodes) continue;
    // χ ← max(0, χ − W·kero), kero = dt/(α l³): ∂χ' = ∂χ − kero·∂W (+ W·kero for ln α_k).
    const double kero = st.kero[std::size_t(k)];
    const bool clamped = vol.chi(v.index) == 0.0;
    for (std::size_t j = 0; j < P; ++j) {
      const double old = tg ? tg[j] : 0.0;
      double t = clamped ? 0.0 : old - kero * dW[j];
      if (!clamped && kind_[j] == kAlpha && label_[j] == k) t += W * kero;
      tnew[j] = t;
      drem_[j][std::size_t(k)] += l3 * (old - t);
    }
    if (!tg) {
      bool any = false;
      for (std::size_t j = 0; j < P; ++j) any |= tnew[j] != 0;
      if (!any) continue;
      tg = tangent_or_new(v.index);
      stamp_[std::size_t(slot_[v.index])] = eval_;
    }
    for (std::size_t j = 0; j < P; ++j) tg[j] = tnew[j];
  }
  for (std::size_t j = 0; j < P; ++j) {
    glm::dvec3 dfm(0);
    for (int k = 1; k < kMaxClasses; ++k) {
      const double mu = prm_.by_label[std::size_t(k)].mu;
      if (mu != 0) dfm += mu * glm::cross(dG[j][std::size_t(k)], w);
    }
    if (kind_[j] == kMu) dfm += prm_.by_label[label_[j]].mu * c.dFmu_dmu[label_[j]];
    dF[j] += dfm;
  }
}

}  // namespace burrbench::model::detail
