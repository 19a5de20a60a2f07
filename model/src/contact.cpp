#include "burrbench/model/contact.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "burrbench/data_schema/error.hpp"
#include "kernel_scratch.hpp"

namespace burrbench::model {

namespace {

constexpr double kPi = std::numbers::pi;

const LensTable& table_for(const Volume& vol, double R) {
  detail::Scratch& s = vol.scratch();
  if (!s.has_table || s.table.radius() != R || s.table.voxel() != vol.voxel_mm()) {
    s.table = LensTable(R, vol.voxel_mm());
    s.has_table = true;
  }
  return s.table;
}

// Sums χ and x·χ over [xa, xb] of one row (float data, double sums in 4 lanes so the
// compiler can keep them in registers; the order is fixed, so results are reproducible).
inline void sum_row(const float* chi, int xa, int xb, double& s0, double& s1) {
  double a0 = 0, a1 = 0, a2 = 0, a3 = 0, b0 = 0, b1 = 0, b2 = 0, b3 = 0;
  int x = xa;
  for (; x + 3 <= xb; x += 4) {
    const double c0 = chi[x], c1 = chi[x + 1], c2 = chi[x + 2], c3 = chi[x + 3];
    a0 += c0; a1 += c1; a2 += c2; a3 += c3;
    b0 += c0 * x; b1 += c1 * (x + 1); b2 += c2 * (x + 2); b3 += c3 * (x + 3);
  }
  for (; x <= xb; ++x) {
    a0 += chi[x];
    b0 += double(chi[x]) * x;
  }
  s0 = (a0 + a1) + (a2 + a3);
  s1 = (b0 + b1) + (b2 + b3);
}

struct Moments {
  std::array<double, kMaxClasses> mass{};  // Σ ΔV χ per class
  glm::dvec3 m1{0};                         // Σ ΔV χ (r/d) v
};

// First pass: moments of all voxels within reach, collecting lens voxels in scratch.
void gather(const Volume& vol, const LensTable& tab, glm::dvec3 p, Moments& mo) {
  auto& lens = vol.scratch().lens;
  lens.clear();
  const auto& dims = vol.dims();
  const double l = vol.voxel_mm(), inv_l = 1.0 / l;
  const glm::dvec3 o = vol.origin_mm();
  const double reach2 = tab.d2_outer(), reach = std::sqrt(reach2);
  const double R = tab.radius(), eta = tab.eta();
  const double inner = R > eta ? R - eta : -1.0;  // fully-inside radius (R > η only)
  const double inner2 = tab.d2_inner();
  const double v_in = tab.inside_volume();
  const float* chi = vol.chi_data();
  const std::uint8_t* lab = vol.label_data();
  const std::size_t nx = dims[0], ny = dims[1];

  auto lo_idx = [&](double c, double o_a, std::size_t n) {
    const double f = std::ceil((c - o_a) * inv_l);
    return f < 0 ? 0L : (f > double(n) ? long(n) : long(f));
  };
  auto hi_idx = [&](double c, double o_a, std::size_t n) {
    const double f = std::floor((c - o_a) * inv_l);
    return f >= double(n) ? long(n) - 1 : (f < -1 ? -1L : long(f));
  };
  const long z0 = lo_idx(p.z - reach, o.z, dims[2]), z1 = hi_idx(p.z + reach, o.z, dims[2]);
  const long y0 = lo_idx(p.y - reach, o.y, ny), y1 = hi_idx(p.y + reach, o.y, ny);
  double ins_m[kMaxClasses] = {};
  double ins_x = 0, ins_y = 0, ins_z = 0;  // Σ χ v over inside voxels (× v_in later)

  for (long z = z0; z <= z1; ++z) {
    const double dz = o.z + l * double(z) - p.z, dz2 = dz * dz;
    if (dz2 >= reach2) continue;
    for (long y = y0; y <= y1; ++y) {
      const double dy = o.y + l * double(y) - p.y, s2 = dz2 + dy * dy;
      if (s2 >= reach2) continue;
      const std::size_t row = std::size_t(y) + ny * std::size_t(z);
      const long rlo = vol.row_lo(row), rhi = vol.row_hi(row);
      if (rlo > rhi) continue;
      const double half = std::sqrt(reach2 - s2);
      const long xa = std::max(rlo, lo_idx(p.x - half, o.x, nx));
      const long xb = std::min(rhi, hi_idx(p.x + half, o.x, nx));
      if (xa > xb) continue;
      // Fully-inside span [ia, ib] (d ≤ R − η), summed without per-voxel geometry.
      long ia = xb + 1, ib = xb;
      if (inner > 0 && s2 < inner * inner) {
        const double ih = std::sqrt(inner * inner - s2);
        ia = std::max(xa, lo_idx(p.x - ih, o.x, nx));
        ib = std::min(xb, hi_idx(p.x + ih, o.x, nx));
        if (ia > ib) { ia = xb + 1; ib = xb; }
      }
      const std::size_t base = row * nx;
      const float* c = chi + base;
      auto lens_voxel = [&](long x) {
        const float cf = c[x];
        if (cf <= 0.0f) return;
        const double dx = o.x + l * double(x) - p.x, d2 = dx * dx + s2;
        if (d2 >= reach2) return;
        const std::uint8_t k = lab[base + std::size_t(x)];
        if (d2 <= inner2) {  // rounding put an inside voxel here: treat it as inside
          ins_m[k] += cf;
          ins_x += cf * dx; ins_y += cf * dy; ins_z += cf * dz;
          return;
        }
        const LensTable::Entry e = tab.at(d2);
        const double w = e.volume * cf;
        mo.mass[k] += w;
        const double wr = w * e.lever_over_d;
        mo.m1.x += wr * dx; mo.m1.y += wr * dy; mo.m1.z += wr * dz;
        lens.push_back({base + std::size_t(x), double(cf), e.area, e.lever_over_d, d2, dx, dy,
                        dz, k});
      };
      for (long x = xa; x < ia; ++x) lens_voxel(x);
      if (ia <= ib) {
        const std::uint8_t uk = vol.row_label(row);
        if (uk != 0) {
          double s0, s1;
          sum_row(c, int(ia), int(ib), s0, s1);
          ins_m[uk] += s0;
          ins_x += l * s1 + (o.x - p.x) * s0;
          ins_y += dy * s0;
          ins_z += dz * s0;
        } else {
          for (long x = ia; x <= ib; ++x) {
            const double cf = c[x];
            ins_m[lab[base + std::size_t(x)]] += cf;
            ins_x += cf * (o.x + l * double(x) - p.x);
            ins_y += cf * dy;
            ins_z += cf * dz;
          }
        }
      }
      for (long x = ib + 1; x <= xb; ++x) lens_voxel(x);
    }
  }
  for (int k = 1; k < kMaxClasses; ++k) mo.mass[k] += v_in * ins_m[k];
  mo.mass[0] = 0;  // label 0 has χ = 0 by construction
  mo.m1 += v_in * glm::dvec3(ins_x, ins_y, ins_z);
}

ContactResult contact(const Volume& vol, glm::dvec3 p, glm::dvec3 omega, double R,
                      const ModelParams& prm, Volume* erode_vol, double dt,
                      std::array<double, kMaxClasses>* removed,
                      std::array<double, kMaxClasses>* energy) {
  if (!(R > 0) || !std::isfinite(R))
    throw InputError("model", "radius_mm", "finite burr radius > 0 mm", std::to_string(R));
  ContactResult out;
  if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(omega.x + omega.y + omega.z))
    throw InputError("model", "burr state", "finite centre and angular velocity");
  const LensTable& tab = table_for(vol, R);
  Moments mo;
  gather(vol, tab, p, mo);
  double M = 0;
  for (int k = 1; k < kMaxClasses; ++k) {
    M += mo.mass[k];
    if (mo.mass[k] > 0) out.class_mask |= std::uint8_t(1u << k);
  }
  if (!(M > 0)) return out;  // no bone in reach: exactly zero force
  out.bone_volume_mm3 = M;
  const double b = immersion_depth(R, M);
  out.depth_b_mm = b;
  const double m1n = glm::length(mo.m1);
  out.buried = m1n < kBuriedMoment * M * R;
  if (!(m1n > 0)) return out;  // perfectly symmetric: no normal, no force
  const glm::dvec3 n = -mo.m1 / m1n;
  out.normal = n;
  const double g = R * R * std::pow(b / R, 1.5);
  for (int k = 1; k < kMaxClasses; ++k) {
    out.dF_dC1[k] = (mo.mass[k] / M) * g * n;
    out.elastic_N += prm.by_label[k].c1_N_per_mm2 * out.dF_dC1[k];
  }
  const double a2 = std::max(0.0, 2 * R * b - b * b);
  out.contact_radius_mm = std::sqrt(a2);
  const double fe = glm::length(out.elastic_N);
  const double wn = glm::length(omega);
  out.force_N = out.elastic_N;
  if (!(a2 > 0) || !(fe > 0) || !(wn > 0)) return out;

  // Second pass over the lens voxels: Hertz pressure on the contact disc, friction and
  // friction power. ξ² = (r/d)²(d² − (n̂·v)²) is the squared distance from the disc
  // centre measured in the contact plane (MODEL.md step 4).
  const glm::dvec3 w = omega / wn;
  const double p0 = 3 * fe / (2 * kPi * a2), inv_a2 = 1.0 / a2;
  const double l3 = vol.voxel_mm() * vol.voxel_mm() * vol.voxel_mm();
  std::array<glm::dvec3, kMaxClasses> G{};
  double power = 0;
  const bool do_erode = erode_vol != nullptr && dt > 0;
  for (const detail::LensVoxel& e : vol.scratch().lens) {
    const double vn = n.x * e.vx + n.y * e.vy + n.z * e.vz;
    const double xi2 = e.lever_over_d * e.lever_over_d * (e.d2 - vn * vn);
    if (xi2 >= a2) continue;
    const double P = p0 * std::sqrt(1.0 - xi2 * inv_a2);
    const double inv_d = 1.0 / std::sqrt(e.d2);
    const double s = e.chi * e.area * P * inv_d;
    // (v × ω̂)/|v|, weighted
    G[e.label] += s * glm::dvec3(e.vy * w.z - e.vz * w.y, e.vz * w.x - e.vx * w.z,
                                 e.vx * w.y - e.vy * w.x);
    const ClassConstants& cc = prm.by_label[e.label];
    if (cc.mu == 0) continue;
    const double vw = (e.vx * w.x + e.vy * w.y + e.vz * w.z) * inv_d;
    const double r = e.lever_over_d * e.d2 * inv_d;
    const double W = cc.mu * e.chi * P * wn * r * (1.0 - vw * vw) * e.area;
    power += W;
    if (!do_erode) continue;
    if (energy) (*energy)[e.label] += W * dt;
    if (std::isfinite(cc.alpha_N_per_mm2))
      (*removed)[e.label] += l3 * erode_vol->erode(e.index, dt * W / (cc.alpha_N_per_mm2 * l3));
  }
  for (int k = 1; k < kMaxClasses; ++k) {
    out.dFmu_dmu[k] = G[k];
    out.friction_N += prm.by_label[k].mu * G[k];
  }
  out.power_W_mJ_per_s = power;
  out.force_N = out.elastic_N + out.friction_N;
  return out;
}

}  // namespace

ContactResult evaluate(const Volume& vol, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                       double radius_mm, const ModelParams& params) {
  return contact(vol, centre_vol_mm, omega_vol_rad_s, radius_mm, params, nullptr, 0, nullptr,
                 nullptr);
}

ContactResult step(Volume& vol, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                   double radius_mm, const ModelParams& params, double dt_s,
                   std::array<double, kMaxClasses>& removed_mm3,
                   std::array<double, kMaxClasses>* energy_mJ) {
  if (!(dt_s >= 0) || !std::isfinite(dt_s))
    throw InputError("model", "dt_s", "finite time step >= 0 s", std::to_string(dt_s));
  return contact(vol, centre_vol_mm, omega_vol_rad_s, radius_mm, params, &vol, dt_s,
                 &removed_mm3, energy_mJ);
}

}  // namespace burrbench::model
