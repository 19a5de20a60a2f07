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

TangentState::TangentState(const Volume& vol, KernelScratch& scratch, const std::vector<Direction>& dirs,
                           const ModelParams& prm)
    : sc_(scratch.get()), P_(dirs.size()), prm_(prm), nx_(vol.dims()[0]), ny_(vol.dims()[1]) {
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
  active_.assign(P_, 0);
  for (std::size_t j = 0; j < P_; ++j) {
    if (kind_[j] == kPath) {
      path_.push_back(j);
      active_[j] = 1;
      act_.push_back(j);
    } else {
      ++dormant_;
    }
  }
  drem_.assign(P_, std::array<double, kMaxClasses>{});
  sc_.keep_inside = true;
}

TangentState::~TangentState() { sc_.keep_inside = false; }

double* TangentState::tangent(std::uint32_t v) {
  const std::int32_t s = slot_[v];
  return s < 0 ? nullptr : &dchi_[std::size_t(s) * P_];
}

double* TangentState::tangent_or_new(std::uint32_t v) {
  if (slot_[v] < 0) {
    slot_[v] = std::int32_t(touched_.size());
    touched_.push_back(v);
    dchi_.resize(dchi_.size() + P_, 0.0);
    const std::size_t row = v / nx_;
    const std::int32_t x = std::int32_t(v % nx_);
    row_lo_[row] = std::min(row_lo_[row], x);
    row_hi_[row] = std::max(row_hi_[row], x);
  }
  return &dchi_[std::size_t(slot_[v]) * P_];
}

// Inside voxels with a tangent (eroded earlier, now inside) add v_in·∂χ to the moments.
void TangentState::inside_tangents(const Volume& vol, double v_in) {
  const KernelState& st = sc_.state;
  const std::size_t P = P_;
  const double l = vol.voxel_mm();
  auto& dmass = dmass_;
  auto& dm1 = dm1_;
  const std::vector<std::size_t>& act = act_;
  // Inside voxels with a tangent (eroded earlier, now inside) add v_in·∂χ. The first pass
  // listed the inside voxels (Scratch::keep_inside); only rows with tangents are visited.
  if (touched_.empty()) return;
  {
    const glm::dvec3 o = vol.grid_origin_mm(), p = st.p;  // as the kernel places voxels
    const double y_off = double(vol.box().lo[1]), z_off = double(vol.box().lo[2]);
    const Scratch& sc = sc_;
    auto inside = [&](std::size_t idx, std::size_t x, std::size_t row) {
      const std::int32_t s = slot_[idx];
      if (s < 0) return;
      const std::size_t y = row % ny_, z = row / ny_;
      const glm::dvec3 vv = o + l * glm::dvec3(double(x), double(y) + y_off, double(z) + z_off) - p;
      const double* tg = &dchi_[std::size_t(s) * P];
      const std::uint8_t k = vol.label(idx);
      for (const std::size_t j : act) {
        dmass[j][k] += v_in * tg[j];
        dm1[j] += v_in * tg[j] * vv;
      }
    };
    for (const InsideSpan& sp : sc.inside_spans) {
      const std::size_t row = sp.row;
      const std::int32_t xa = std::max(sp.lo, row_lo_[row]), xb = std::min(sp.hi, row_hi_[row]);
      for (std::int32_t x = xa; x <= xb; ++x) inside(std::size_t(x) + nx_ * row, std::size_t(x), row);
    }
    for (const std::uint32_t idx : sc.inside_extra) inside(idx, idx % nx_, idx / nx_);
  }

}

// ∂n̂, ∂|F_e|, ∂a², ∂p₀ from ∂mass and ∂M₁; ∂F_e into dF when `forces`.
void TangentState::elastic_tangents(const KernelState& st, double R, bool forces, glm::dvec3* dF) {
  auto& dmass = dmass_;
  auto& dm1 = dm1_;
  const std::vector<std::size_t>& act = act_;
  // ---- depth, normal, elastic force ----
  const glm::dvec3 n = st.n;
  const double M = st.M, b = st.b, g = st.g, cbar = st.c1_eff;
  const double a2 = st.a2;
  const bool full = M >= 4.0 / 3.0 * kPi * R * R * R;  // b clamped at 2R
  auto &dfe = dfe_, &da2 = da2_, &dp0 = dp0_;
  auto& dn = dn_;
  for (const std::size_t j : act) {
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
    if (forces) dF[j] = (dc * g + cbar * dg) * n + cbar * g * dn[j];
    dfe[j] = dc * g + cbar * dg;
    da2[j] = 2 * (R - b) * db;
    dp0[j] = st.friction ? st.p0 * (dfe[j] / st.fe - da2[j] / a2) : 0.0;
  }
}

// A hot kernel, long on purpose: it runs at every step of a sensitivity replay, for all
// directions at once over the contact's voxels (bench/sensitivity_replay.cpp measures it).
// NOLINTNEXTLINE(readability-function-size)
void TangentState::differentiate(const Volume& vol, const ContactResult& c, const glm::dvec3* dp,
                                 bool eroded, glm::dvec3* dF, glm::dvec3* dT) {
  const std::size_t P = P_;
  // No dF: only the voxel tangents advance (an erosion sub-step whose force is not
  // reported); the friction force's derivative sums are skipped.
  const bool forces = dF != nullptr;
  BURRBENCH_CHECK(forces || (eroded && !dT), "differentiate: no dF only for an unreported erosion step");
  if (forces)
    for (std::size_t j = 0; j < P; ++j) dF[j] = glm::dvec3(0);
  if (dT)
    for (std::size_t j = 0; j < P; ++j) dT[j] = glm::dvec3(0);
  const KernelState& st = sc_.state;
  const LensTable& tab = sc_.table;
  if (!st.force) return;  // no bone in reach, or no normal: F ≡ 0 here
  // A class's constants act on nothing before its bone first comes within reach: their
  // directions stay exactly zero until then and are skipped (a recording in one class
  // carries 3 fewer directions).
  reached_ |= c.class_mask;
  if (dormant_ > 0)
    for (std::size_t j = 0; j < P; ++j)
      if (!active_[j] && ((c.class_mask >> label_[j]) & 1u)) {
        active_[j] = 1;
        act_.push_back(j);
        --dormant_;
      }
  const std::vector<std::size_t>& act = act_;
  const double* const T = tab.data();
  const double t_lo = tab.d2_inner(), t_ih = tab.inv_step();
  const int t_last = tab.intervals() - 1;
  const double v_in = tab.inside_volume(), R = tab.radius();
  const double l = vol.voxel_mm(), l3 = l * l * l;
  const LensVoxel* lv = sc_.lens.data();
  const bool moves = !path_.empty();
  // ∂p per direction, zero for the constants (they do not move the burr).
  auto& dpj = dpj_;
  for (const std::size_t j : act) dpj[j] = kind_[j] == kPath ? dp[j] : glm::dvec3(0);
  if (st.cube) {
    differentiate_cube(vol, c, eroded, dF, dT);
    return;
  }

  // ---- first moments: ∂mass_k, ∂M₁ ----
  // A path direction changes every lens voxel's d² by −2 v·∂p, so its terms are linear in
  // ∂p: their coefficients are summed once over the lens (a vector per class, one matrix)
  // and applied per direction. Only voxels with a χ tangent need work per direction.
  auto& dmass = dmass_;
  auto& dm1 = dm1_;
  for (const std::size_t j : act) {
    dmass[j].fill(0.0);
    dm1[j] = glm::dvec3(0);
  }
  std::array<glm::dvec3, kMaxClasses> amass{};  // Σ −2χ s_V v: ∂mass_k = amass_k·∂p
  Sym3 B;                                       // Σ (χ s_V r/d + w s_R) v vᵀ
  double swr = 0;                               // Σ w r/d
  for (std::size_t i = 0; i < st.lens_count; ++i) {
    const LensVoxel& v = lv[i];
    const glm::dvec3 vv(v.vx, v.vy, v.vz);
    const double u = (v.d2 - t_lo) * t_ih;
    const int ti = std::min(std::max(int(u), 0), t_last);
    const double f = u - ti;
    const double* a = T + 4 * ti;
    const double dV = a[0] + f * (a[4] - a[0]);
    const double chi = v.chi, rd = v.rd;
    if (const double* tg = tangent(v.index)) {
      const glm::dvec3 vr = dV * rd * vv;
      for (const std::size_t j : act) {
        dmass[j][v.label] += dV * tg[j];
        dm1[j] += tg[j] * vr;
      }
    }
    if (!moves) continue;
    const double sV = (a[4] - a[0]) * t_ih;  // dΔV/dd²
    const double sR = (a[6] - a[2]) * t_ih;  // d(r/d)/dd²
    const double w = dV * chi;
    amass[v.label] += (-2.0 * chi * sV) * vv;
    B.add(chi * sV * rd + w * sR, vv);
    swr += w * rd;
  }
  // Fully-inside voxels move with p as a block: ∂M₁ = −v_in·Σχ·∂p.
  for (std::size_t j : path_) {
    for (int k = 1; k < kMaxClasses; ++k) dmass[j][std::size_t(k)] += glm::dot(amass[std::size_t(k)], dp[j]);
    dm1[j] += -2.0 * (B * dp[j]) - (swr + v_in * st.inside_chi) * dp[j];
  }
  inside_tangents(vol, v_in);
  elastic_tangents(st, R, forces, dF);
  if (!st.friction) return;
  const glm::dvec3 n = st.n;
  const double a2 = st.a2;
  const auto &da2 = da2_, &dp0 = dp0_;
  const auto& dn = dn_;

  // ---- friction and friction power ----
  // Per disc voxel, ∂s (friction weight) and ∂W (power) are linear in the direction's
  // (∂p, ∂n̂, ∂p₀, ∂a²) and its own ∂χ. The friction sum Σ ∂s v − s ∂p takes the geometric
  // part as per-class sums applied once per direction; ∂W, which each eroding voxel's
  // tangent needs, is one 8-term dot product per direction.
  const glm::dvec3 w = st.w;
  const double p0 = st.p0, inv_a2 = 1.0 / a2;
  auto& dG = dG_;  // ∂χ part of Σ ∂s v, per direction and class
  for (const std::size_t j : act) dG[j].fill(glm::dvec3(0));
  std::array<Sym3, kMaxClasses> D2, VN;             // Σ c_d² v vᵀ, Σ c_vn v vᵀ
  std::array<glm::dvec3, kMaxClasses> uvn{}, up0{}, ua2{};  // Σ c_vn v, Σ c_p₀ v, Σ c_a² v
  std::array<double, kMaxClasses> ssum{};           // Σ s
  auto& z = z_;  // per direction: (∂p, ∂n̂, ∂p₀, ∂a²)
  for (const std::size_t j : act)
    z[j] = {dpj[j].x, dpj[j].y, dpj[j].z, dn[j].x, dn[j].y, dn[j].z, dp0[j], da2[j]};
  // The couple T_k = Σ s (r/d) L, L = (v·ω̂)v − d²ω̂ (contact.cpp): the same ∂s terms, with
  // the lever (r/d)L in place of v, plus ∂(r/d) and ∂L for a moving burr
  // (∂L = −(∂p·ω̂)v − (v·ω̂)∂p + 2(v·∂p)ω̂). Matrices Σ c L vᵀ are not symmetric.
  auto& dTG = dTG_;
  if (dT)
    for (const std::size_t j : act) dTG[j].fill(glm::dvec3(0));
  std::array<glm::dmat3, kMaxClasses> TVN{}, TD2{};          // Σ c_vn (r/d) L vᵀ, Σ (c_d2 r/d + s ∂(r/d)/∂d²) L vᵀ
  std::array<glm::dvec3, kMaxClasses> tp0{}, ta2{}, tvn{}, tsv{};  // Σ c_p₀(r/d)L, c_a²(r/d)L, c_vn(r/d)L, s(r/d)v
  std::array<double, kMaxClasses> tsvw{};                    // Σ s (r/d)(v·ω̂)
  for (auto& m : TVN) m = glm::dmat3(0.0);
  for (auto& m : TD2) m = glm::dmat3(0.0);
  auto& tnew = tnew_;
  for (std::size_t i = 0; i < st.lens_count; ++i) {
    const LensVoxel& v = lv[i];
    const glm::dvec3 vv(v.vx, v.vy, v.vz);
    const double vn = glm::dot(n, vv), d2 = v.d2, rd = v.rd;
    const double t2 = d2 - vn * vn, xi2 = rd * rd * t2;
    if (xi2 >= a2) continue;  // off the disc: neither force nor power
    const std::size_t k = v.label;
    const bool erodes = eroded && st.kero[k] > 0 && st.wmu[k] != 0;
    if (!forces && !erodes) continue;
    double* tg = tangent(v.index);
    const double chi = v.chi;
    const double u = (d2 - t_lo) * t_ih;
    const int ti = std::min(std::max(int(u), 0), t_last);
    const double f = u - ti;
    const double* a = T + 4 * ti;
    const double area = a[1] + f * (a[5] - a[1]), inv_d = a[3] + f * (a[7] - a[3]);
    const double s_area = (a[5] - a[1]) * t_ih, s_invd = (a[7] - a[3]) * t_ih, s_rd = (a[6] - a[2]) * t_ih;
    const double sq = std::sqrt(1.0 - xi2 * inv_a2);
    const double P0 = p0 * sq;
    const double A = area * inv_d;
    // ∂P = sq ∂p₀ + e_xi ∂ξ² + e_a2 ∂a²,  ∂ξ² = h_d2 ∂d² + h_vn ∂(n̂·v)
    const double e_xi = -p0 / (2 * sq * a2), e_a2 = p0 * xi2 / (2 * sq * a2 * a2);
    const double h_d2 = 2 * rd * s_rd * t2 + rd * rd, h_vn = -2 * rd * rd * vn;
    if (forces) {  // the friction force's derivative sums
      // ∂s = A P₀ ∂χ + c_d2 ∂d² + c_vn ∂(n̂·v) + c_p0 ∂p₀ + c_a2 ∂a²
      const double c_chi = A * P0;
      const double c_d2 = chi * ((s_area * inv_d + area * s_invd) * P0 + A * e_xi * h_d2);
      const double c_vn = chi * A * e_xi * h_vn;
      VN[k].add(c_vn, vv);
      up0[k] += (chi * A * sq) * vv;
      ua2[k] += (chi * A * e_a2) * vv;
      if (moves) {
        D2[k].add(c_d2, vv);
        uvn[k] += c_vn * vv;
        ssum[k] += chi * c_chi;
      }
      if (tg) {
        const glm::dvec3 cv = c_chi * vv;
        for (const std::size_t j : act) dG[j][k] += tg[j] * cv;
      }
      if (dT) {
        const double vw_ = glm::dot(vv, w), s_ = chi * c_chi;
        const glm::dvec3 L = vw_ * vv - d2 * w, rL = rd * L;
        TVN[k] += glm::outerProduct(c_vn * rL, vv);
        tp0[k] += (chi * A * sq) * rL;
        ta2[k] += (chi * A * e_a2) * rL;
        if (moves) {
          TD2[k] += glm::outerProduct((c_d2 * rd + s_ * s_rd) * L, vv);
          tvn[k] += c_vn * rL;
          tsv[k] += (s_ * rd) * vv;
          tsvw[k] += s_ * rd * vw_;
        }
        if (tg) {
          const glm::dvec3 cl = c_chi * rL;
          for (const std::size_t j : act) dTG[j][k] += tg[j] * cl;
        }
      }
    }
    if (!erodes) continue;
    // ∂W = w_chi ∂χ + K1 ∂P + K2 ∂d² + K3 ∂(v·ω̂/d), with ∂d² = −2 v·∂p, ∂(n̂·v) = v·∂n̂ − n̂·∂p
    // and ∂(v·ω̂/d) = −ω̂·∂p/d + (v·ω̂) s_invd ∂d².
    const double wmu = st.wmu[k];
    const double r = rd * d2 * inv_d, vwr = glm::dot(vv, w), vw = vwr * inv_d, q = 1.0 - vw * vw;
    const double W = wmu * chi * P0 * r * q * area;
    const double r_d2 = s_rd * d2 * inv_d + rd * inv_d + rd * d2 * s_invd;
    const double w_chi = wmu * P0 * r * q * area;
    const double K1 = wmu * chi * r * q * area;
    const double K2 = wmu * chi * P0 * (q * area * r_d2 + r * q * s_area);
    const double K3 = wmu * chi * P0 * r * area * (-2 * vw);
    const double E_d2 = K1 * e_xi * h_d2 + K2 + K3 * vwr * s_invd, E_vn = K1 * e_xi * h_vn;
    const glm::dvec3 gp = -2 * E_d2 * vv - E_vn * n - K3 * inv_d * w, gn = E_vn * vv;
    const double cw[8] = {gp.x, gp.y, gp.z, gn.x, gn.y, gn.z, K1 * sq, K1 * e_a2};
    // χ ← max(0, χ − W·kero), kero = dt/(α l³): ∂χ' = ∂χ − kero·∂W (+ W·kero for ln α_k).
    const double kero = st.kero[k];
    const bool clamped = vol.chi(v.index) == 0.0;
    for (const std::size_t j : act) {
      const double old = tg ? tg[j] : 0.0;
      double t = 0.0;
      if (!clamped) {
        const auto& zj = z[j];
        double dW = w_chi * old;
        for (int m = 0; m < 8; ++m) dW += cw[m] * zj[std::size_t(m)];
        if (kind_[j] == kMu && label_[j] == k) dW += W;
        t = old - kero * dW;
        if (kind_[j] == kAlpha && label_[j] == k) t += W * kero;
      }
      tnew[j] = t;
      drem_[j][k] += l3 * (old - t);
    }
    if (!tg) {
      bool any = false;
      for (const std::size_t j : act) any |= tnew[j] != 0;
      if (!any) continue;
      tg = tangent_or_new(v.index);
    }
    for (const std::size_t j : act) tg[j] = tnew[j];
  }
  if (!forces) return;
  for (const std::size_t j : act) {
    glm::dvec3 dfm(0);
    const double ndp = glm::dot(n, dpj[j]);
    for (int k = 1; k < kMaxClasses; ++k) {
      const std::size_t kk = std::size_t(k);
      const double mu = prm_.by_label[kk].mu;
      if (mu == 0) continue;
      glm::dvec3 g_k = dG[j][kk] + VN[kk] * dn[j] + dp0[j] * up0[kk] + da2[j] * ua2[kk];
      if (kind_[j] == kPath) g_k += -2.0 * (D2[kk] * dpj[j]) - ndp * uvn[kk] - ssum[kk] * dpj[j];
      dfm += mu * glm::cross(g_k, w);
    }
    if (kind_[j] == kMu) dfm += prm_.by_label[label_[j]].mu * c.dFmu_dmu[label_[j]];
    dF[j] += dfm;
    if (!dT) continue;
    glm::dvec3 dtm(0);
    for (int k = 1; k < kMaxClasses; ++k) {
      const std::size_t kk = std::size_t(k);
      const double mu = prm_.by_label[kk].mu;
      if (mu == 0) continue;
      glm::dvec3 t_k = dTG[j][kk] + TVN[kk] * dn[j] + dp0[j] * tp0[kk] + da2[j] * ta2[kk];
      if (kind_[j] == kPath)
        t_k += -2.0 * (TD2[kk] * dpj[j]) - ndp * tvn[kk] - glm::dot(w, dpj[j]) * tsv[kk] - tsvw[kk] * dpj[j] +
               2.0 * glm::dot(tsv[kk], dpj[j]) * w;
      dtm += mu * t_k;
    }
    if (kind_[j] == kMu) dtm += prm_.by_label[label_[j]].mu * c.dTmu_dmu[label_[j]];
    dT[j] = dtm;
  }
}

}  // namespace burrbench::model::detail
