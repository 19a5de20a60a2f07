#include "burrbench/model/contact.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/cube_cut.hpp"
#include "kernel_scratch.hpp"

namespace burrbench::model {

namespace {

constexpr double kPi = std::numbers::pi;

const LensTable& table_for(const Volume& vol, detail::Scratch& s, double R) {
  if (!s.has_table || s.table.radius() != R || s.table.voxel() != vol.voxel_mm()) {
    s.table = LensTable(R, vol.voxel_mm());
    s.has_table = true;
  }
  return s.table;
}

// Sums χ and x·χ over [xa, xb] of one row (float data, double sums in 4 lanes; the order
// is fixed, so results are reproducible). With SSE2 the lanes are two 2-double registers
// and x is carried as doubles (exact integers), which gives the same bits as the scalar
// lanes at a third of the instructions: this is the whole cost of a buried burr's inside.
inline void sum_row(const float* chi, int xa, int xb, double& s0, double& s1) {
  int x = xa;
#if defined(__SSE2__)
  __m128d a01 = _mm_setzero_pd(), a23 = a01, b01 = a01, b23 = a01;
  __m128d x01 = _mm_set_pd(x + 1, x), x23 = _mm_set_pd(x + 3, x + 2);
  const __m128d four = _mm_set1_pd(4.0);
  for (; x + 3 <= xb; x += 4) {
    const __m128 c = _mm_loadu_ps(chi + x);
    const __m128d c01 = _mm_cvtps_pd(c), c23 = _mm_cvtps_pd(_mm_movehl_ps(c, c));
    a01 = _mm_add_pd(a01, c01);
    a23 = _mm_add_pd(a23, c23);
    b01 = _mm_add_pd(b01, _mm_mul_pd(c01, x01));
    b23 = _mm_add_pd(b23, _mm_mul_pd(c23, x23));
    x01 = _mm_add_pd(x01, four);
    x23 = _mm_add_pd(x23, four);
  }
  double a0 = _mm_cvtsd_f64(a01), a1 = _mm_cvtsd_f64(_mm_unpackhi_pd(a01, a01));
  double a2 = _mm_cvtsd_f64(a23), a3 = _mm_cvtsd_f64(_mm_unpackhi_pd(a23, a23));
  double b0 = _mm_cvtsd_f64(b01), b1 = _mm_cvtsd_f64(_mm_unpackhi_pd(b01, b01));
  double b2 = _mm_cvtsd_f64(b23), b3 = _mm_cvtsd_f64(_mm_unpackhi_pd(b23, b23));
#else
  double a0 = 0, a1 = 0, a2 = 0, a3 = 0, b0 = 0, b1 = 0, b2 = 0, b3 = 0;
  for (; x + 3 <= xb; x += 4) {
    const double c0 = chi[x], c1 = chi[x + 1], c2 = chi[x + 2], c3 = chi[x + 3];
    a0 += c0; a1 += c1; a2 += c2; a3 += c3;
    b0 += c0 * x; b1 += c1 * (x + 1); b2 += c2 * (x + 2); b3 += c3 * (x + 3);
  }
#endif
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
  std::size_t lens_count = 0;
  double inside_chi = 0;                    // Σ χ over fully-inside voxels
};

// Running sums kept in locals by the hot loops (written back once per segment), so the
// compiler need not assume the lens-buffer stores alias them.
struct Sums {
  double lens_mass[kMaxClasses] = {};
  double in_mass[kMaxClasses] = {};
  double mx = 0, my = 0, mz = 0;  // lens Σ ΔVχ(r/d)v
  double ix = 0, iy = 0, iz = 0;  // inside Σ χ v (× inside volume at the end)
  std::vector<std::uint32_t>* inside_extra = nullptr;  // Scratch::keep_inside: list them
};

struct Row {
  const float* chi;        // χ of the row
  const std::uint8_t* lab; // labels of the row
  std::size_t base;        // linear index of x = 0
  double gx, l, dy, dz, s2;  // dx = gx + l·x
  std::uint8_t uniform;    // the row's single label, 0 if mixed
};

// Lens voxels of [x0, x1] of a row: accumulate moments, append to the lens buffer.
// Instantiated for uniform rows (one label, per-class mass in a local) and mixed rows,
// so the hot loop carries no label branch.
template <bool kUniform>
inline detail::LensVoxel* lens_segment(const Row& r, long x0, long x1, const LensTable& tab,
                                       double reach2, double inner2, Sums& S,
                                       detail::LensVoxel* out) {
  double mx = 0, my = 0, mz = 0, mu = 0;  // mu: mass when the row is uniform
  const double* const T = tab.data();
  const double t_lo = tab.d2_inner(), t_ih = tab.inv_step();
  const int t_last = tab.intervals() - 1;
  const double dy = r.dy, dz = r.dz, s2 = r.s2, gx = r.gx, l = r.l;
  for (long x = x0; x <= x1; ++x) {
    const float cf = r.chi[x];
    if (cf <= 0.0f) continue;
    const double dx = gx + l * double(x), d2 = dx * dx + s2;
    if (d2 >= reach2) continue;
    const std::uint8_t k = kUniform ? r.uniform : r.lab[x];
    if (d2 <= inner2) {  // rounding put an inside voxel here: count it as inside
      if (S.inside_extra) S.inside_extra->push_back(std::uint32_t(r.base + std::size_t(x)));
      S.in_mass[k] += cf;
      S.ix += cf * dx; S.iy += cf * dy; S.iz += cf * dz;
      continue;
    }
    const double u = (d2 - t_lo) * t_ih;
    const int i = std::min(std::max(int(u), 0), t_last);
    const double f = u - i;
    const double* a = T + 4 * i;
    const double vol = a[0] + f * (a[4] - a[0]), rd = a[2] + f * (a[6] - a[2]);
    const double w = vol * double(cf);
    if (kUniform) mu += w;
    else S.lens_mass[k] += w;
    const double wr = w * rd;
    mx += wr * dx; my += wr * dy; mz += wr * dz;
    detail::LensVoxel& o = *out++;  // field by field: no padding to zero
    o.vx = dx; o.vy = dy; o.vz = dz; o.d2 = d2; o.rd = rd;
    o.index = std::uint32_t(r.base + std::size_t(x));
    o.label = k;
    o.chi = cf;
  }
  if (kUniform) S.lens_mass[r.uniform] += mu;
  S.mx += mx; S.my += my; S.mz += mz;
  return out;
}

inline detail::LensVoxel* lens_span(const Row& r, long x0, long x1, const LensTable& tab,
                                    double reach2, double inner2, Sums& S,
                                    detail::LensVoxel* out) {
  if (x0 > x1) return out;
  return r.uniform ? lens_segment<true>(r, x0, x1, tab, reach2, inner2, S, out)
                   : lens_segment<false>(r, x0, x1, tab, reach2, inner2, S, out);
}

// The quadratures' first passes differ only in a row segment's voxels between the inside
// and the reach (Quad::span) and in those radii; gather is the same for both.
struct LensQuad {
  const LensTable& tab;
  double reach2() const { return tab.d2_outer(); }
  double inner() const { return tab.radius() > tab.eta() ? tab.radius() - tab.eta() : -1.0; }
  double inner2() const { return tab.d2_inner(); }
  double inside_volume() const { return tab.inside_volume(); }
  void grow(std::size_t) const {}
  detail::LensVoxel* span(const Row& r, long x0, long x1, Sums& S, detail::LensVoxel* out,
                          const detail::LensVoxel*) const {
    return lens_span(r, x0, x1, tab, tab.d2_outer(), tab.d2_inner(), S, out);
  }
};

// Cube quadrature: a voxel whose cube the burr's tangent plane may cut (|R − d| < l√3/2)
// is cut in closed form (cube_cut.hpp); ΔV and the radial first moment m = ΔV·d + μₙ
// enter the moments (M₁ gets χ m v/d), the cut's area its CutArea.
struct CubeQuad {
  double R, l;
  std::vector<detail::CutArea>& cut;
  double half_diag() const { return 0.5 * std::sqrt(3.0) * l; }
  double reach2() const { return (R + half_diag()) * (R + half_diag()); }
  double inner() const { return R > half_diag() ? R - half_diag() : -1.0; }
  double inner2() const { return inner() > 0 ? inner() * inner() : -1.0; }
  double inside_volume() const { return l * l * l; }
  void grow(std::size_t n) const { cut.resize(n); }
  detail::LensVoxel* span(const Row& r, long x0, long x1, Sums& S, detail::LensVoxel* out,
                          const detail::LensVoxel* first) const {
    const double reach2_ = reach2(), inner2_ = inner2();
    for (long x = x0; x <= x1; ++x) {
      const float cf = r.chi[x];
      if (cf <= 0.0f) continue;
      const double dx = r.gx + r.l * double(x), d2 = dx * dx + r.s2;
      if (d2 >= reach2_) continue;
      const std::uint8_t k = r.uniform ? r.uniform : r.lab[x];
      if (d2 <= inner2_) {  // as lens_segment: rounding put an inside voxel here
        if (S.inside_extra) S.inside_extra->push_back(std::uint32_t(r.base + std::size_t(x)));
        S.in_mass[k] += cf;
        S.ix += cf * dx; S.iy += cf * r.dy; S.iz += cf * r.dz;
        continue;
      }
      const double d = std::sqrt(d2), inv_d = 1.0 / d;
      const glm::dvec3 v(dx, r.dy, r.dz);
      const CubeCut c = cube_cut(v * inv_d, R - d, l, false);
      if (!(c.volume_mm3 > 0)) continue;
      const double w = c.volume_mm3 * double(cf);
      S.lens_mass[k] += w;
      const double wm = double(cf) * (c.volume_mm3 * d + c.normal_moment_mm4) * inv_d;  // χ m / d
      S.mx += wm * dx; S.my += wm * r.dy; S.mz += wm * r.dz;
      cut[std::size_t(out - first)] = {c.area_mm2, inv_d};
      detail::LensVoxel& o = *out++;
      o.vx = dx; o.vy = r.dy; o.vz = r.dz; o.d2 = d2; o.rd = R * inv_d;
      o.index = std::uint32_t(r.base + std::size_t(x));
      o.label = k;
      o.chi = cf;
    }
    return out;
  }
};

// First pass: moments of all voxels within reach, collecting lens voxels in scratch.
template <class Quad>
void gather(const Volume& vol, detail::Scratch& sc, const Quad& q, glm::dvec3 p, Moments& mo) {
  const auto& dims = vol.dims();
  const double l = vol.voxel_mm(), inv_l = 1.0 / l;
  // Voxels are placed by their index in the sample's grid (a cut volume holds rows y ≥ y_off,
  // layers z ≥ z_off of it), so a cut volume gives bit-identical sums (volume.hpp).
  const glm::dvec3 o = vol.grid_origin_mm();
  const long y_off = long(vol.box().lo[1]), z_off = long(vol.box().lo[2]);
  const double reach2 = q.reach2(), reach = std::sqrt(reach2);
  const double inner = q.inner();  // fully-inside radius (−1: none)
  const double v_in = q.inside_volume();
  const float* chi = vol.chi_data();
  const std::uint8_t* lab = vol.label_data();
  const std::size_t nx = dims[0], ny = dims[1];

  // Index ranges by truncation (std::floor/ceil are library calls without SSE4.1).
  auto lo_idx = [&](double c, double o_a, std::size_t n) {
    const double u = (c - o_a) * inv_l;
    if (u <= 0) return 0L;
    if (u >= double(n)) return long(n);
    const long t = long(u);
    return double(t) < u ? t + 1 : t;  // ceil
  };
  auto hi_idx = [&](double c, double o_a, std::size_t n) {
    const double u = (c - o_a) * inv_l;
    if (u < 0) return -1L;
    if (u >= double(n)) return long(n) - 1;
    return long(u);  // floor (u ≥ 0)
  };
  const long z0 = std::max(0L, lo_idx(p.z - reach, o.z, vol.box().hi[2]) - z_off),
             z1 = hi_idx(p.z + reach, o.z, vol.box().hi[2]) - z_off;

  // Lens buffer: grown (rarely) so that a whole row always fits; it keeps its size
  // across calls, so steady-state evaluation does not allocate.
  auto& lens = sc.lens;
  detail::LensVoxel* first = lens.data();
  detail::LensVoxel* out = first;
  Sums S;
  if (sc.keep_inside) {
    sc.inside_spans.clear();
    sc.inside_extra.clear();
    S.inside_extra = &sc.inside_extra;
  }

  for (long z = z0; z <= z1; ++z) {
    const double dz = o.z + l * double(z + z_off) - p.z, dz2 = dz * dz;
    if (dz2 >= reach2) continue;
    // Rows of this layer that hold bone and meet the reach disc (empty layers and space
    // above a surface cost one comparison each).
    const long ly0 = vol.layer_lo(std::size_t(z)), ly1 = vol.layer_hi(std::size_t(z));
    if (ly0 > ly1) continue;
    const double yh = std::sqrt(reach2 - dz2);
    const long y0 = std::max(ly0, lo_idx(p.y - yh, o.y, vol.box().hi[1]) - y_off);
    const long y1 = std::min(ly1, hi_idx(p.y + yh, o.y, vol.box().hi[1]) - y_off);
    for (long y = y0; y <= y1; ++y) {
      const std::size_t row = std::size_t(y) + ny * std::size_t(z);
      const long rlo = vol.row_lo(row), rhi = vol.row_hi(row);
      if (rlo > rhi) continue;
      const double dy = o.y + l * double(y + y_off) - p.y, s2 = dz2 + dy * dy;
      if (s2 >= reach2) continue;
      const double half = std::sqrt(reach2 - s2);
      const long xa = std::max(rlo, lo_idx(p.x - half, o.x, nx));
      const long xb = std::min(rhi, hi_idx(p.x + half, o.x, nx));
      if (xa > xb) continue;
      const std::size_t used = std::size_t(out - first), need = std::size_t(xb - xa + 1);
      if (used + need > lens.size()) {
        lens.resize(std::max(2 * lens.size(), used + need + 1024));
        q.grow(lens.size());
        first = lens.data();
        out = first + used;
      }
      // Fully-inside span [ia, ib] (d ≤ R − η), summed without per-voxel geometry.
      long ia = xb + 1, ib = xb;
      if (inner > 0 && s2 < inner * inner) {
        const double ih = std::sqrt(inner * inner - s2);
        ia = std::max(xa, lo_idx(p.x - ih, o.x, nx));
        ib = std::min(xb, hi_idx(p.x + ih, o.x, nx));
        if (ia > ib) { ia = xb + 1; ib = xb; }
      }
      const std::size_t base = row * nx;
      const Row r{chi + base, lab + base, base, o.x - p.x, l, dy, dz, s2, vol.row_label(row)};
      out = q.span(r, xa, ia - 1, S, out, first);
      if (ia <= ib) {
        if (sc.keep_inside) sc.inside_spans.push_back({std::uint32_t(row), std::int32_t(ia), std::int32_t(ib)});
        if (r.uniform != 0) {
          double s0, s1;
          sum_row(r.chi, int(ia), int(ib), s0, s1);
          S.in_mass[r.uniform] += s0;
          S.ix += l * s1 + r.gx * s0;
          S.iy += dy * s0;
          S.iz += dz * s0;
        } else {
          for (long x = ia; x <= ib; ++x) {
            const double cf = r.chi[x];
            S.in_mass[r.lab[x]] += cf;
            S.ix += cf * (r.gx + l * double(x));
            S.iy += cf * dy;
            S.iz += cf * dz;
          }
        }
      }
      out = q.span(r, ib + 1, xb, S, out, first);
    }
  }
  for (int k = 1; k < kMaxClasses; ++k) {
    mo.mass[k] = S.lens_mass[k] + v_in * S.in_mass[k];
    mo.inside_chi += S.in_mass[k];
  }
  mo.mass[0] = 0;  // label 0 has χ = 0 by construction
  mo.m1 = glm::dvec3(S.mx, S.my, S.mz) + v_in * glm::dvec3(S.ix, S.iy, S.iz);
  mo.lens_count = std::size_t(out - first);
}

// Δσ (the contact area element) and 1/d of the j-th voxel of the first pass: the lens's
// from its table at d² (same node and weight as the first pass's lookup), the cube's as
// the first pass stored them.
struct LensArea {
  const double* T;
  double t_lo, t_ih;
  int t_last;
  explicit LensArea(const LensTable& tab)
      : T(tab.data()), t_lo(tab.d2_inner()), t_ih(tab.inv_step()), t_last(tab.intervals() - 1) {}
  detail::CutArea operator()(std::size_t, double d2) const {
    const double u = (d2 - t_lo) * t_ih;
    const int ti = std::min(std::max(int(u), 0), t_last);
    const double f = u - ti;
    const double* ta = T + 4 * ti;
    return {ta[1] + f * (ta[5] - ta[1]), ta[3] + f * (ta[7] - ta[3])};
  }
};
struct CubeArea {
  const std::vector<detail::CutArea>& cut;  // grown by the first pass
  detail::CutArea operator()(std::size_t j, double) const { return cut[j]; }
};

template <class Quad, class Area>
ContactResult contact_with(const Volume& vol, detail::Scratch& sc, const Quad& quad, const Area& area_of, glm::dvec3 p,
                           glm::dvec3 omega, double R, const ModelParams& prm, Volume* erode_vol,
                           double dt, std::array<double, kMaxClasses>* removed,
                           std::array<double, kMaxClasses>* energy) {
  ContactResult out;
  if (!std::isfinite(p.x + p.y + p.z) || !std::isfinite(omega.x + omega.y + omega.z))
    throw InputError("model", "burr state", "finite centre and angular velocity");
  Moments mo;
  gather(vol, sc, quad, p, mo);
  detail::KernelState& st = sc.state;
  st = detail::KernelState{};
  st.p = p;
  st.radius = R;
  st.voxel = vol.voxel_mm();
  st.mass = mo.mass;
  st.m1 = mo.m1;
  st.inside_chi = mo.inside_chi;
  st.lens_count = mo.lens_count;
  double M = 0;
  for (int k = 1; k < kMaxClasses; ++k) {
    M += mo.mass[k];
    if (mo.mass[k] > 0) out.class_mask |= std::uint8_t(1u << k);
  }
  if (!(M > 0)) return out;  // no bone in reach: exactly zero force
  out.bone_volume_mm3 = M;
  st.M = M;
  const double b = immersion_depth(R, M);
  out.depth_b_mm = b;
  const double m1n = glm::length(mo.m1);
  out.buried = m1n < kBuriedMoment * M * R;
  if (!(m1n > 0)) return out;  // perfectly symmetric: no normal, no force
  const glm::dvec3 n = -mo.m1 / m1n;
  out.normal = n;
  const double g = R * R * (b / R) * std::sqrt(b / R);  // R²(b/R)^{3/2}
  // Classes not in contact keep zero partials (skipping them saves divisions per step).
  for (int k = 1; k < kMaxClasses; ++k) {
    if (!((out.class_mask >> k) & 1u)) continue;
    out.dF_dC1[k] = (mo.mass[k] / M) * g * n;
    out.elastic_N += prm.by_label[k].c1_N_per_mm2 * out.dF_dC1[k];
  }
  const double a2 = std::max(0.0, 2 * R * b - b * b);
  out.contact_radius_mm = std::sqrt(a2);
  const double fe = glm::length(out.elastic_N);
  const double wn = glm::length(omega);
  out.force_N = out.elastic_N;
  st.force = true;
  st.m1n = m1n;
  st.b = b;
  st.n = n;
  st.g = g;
  st.c1_eff = fe / g;
  st.fe = fe;
  st.a2 = a2;
  st.wn = wn;
  if (!(a2 > 0) || !(fe > 0) || !(wn > 0)) return out;

  // Second pass over the lens voxels: Hertz pressure on the contact disc, friction and
  // friction power. ξ² = (r/d)²(d² − (n̂·v)²) is the squared distance from the disc
  // centre measured in the contact plane (MODEL.md step 4).
  const glm::dvec3 w = omega / wn;
  const double p0 = 3 * fe / (2 * kPi * a2), inv_a2 = 1.0 / a2;
  const double l3 = vol.voxel_mm() * vol.voxel_mm() * vol.voxel_mm();
  double G[kMaxClasses][3] = {};
  // Friction couple per class over μ: Σ s (r/d) [(v·ω̂) v − d² ω̂] = TA − TB ω̂.
  double TA[kMaxClasses][3] = {}, TB[kMaxClasses] = {};
  double rem[kMaxClasses] = {}, en[kMaxClasses] = {};
  double wmu[kMaxClasses], kero[kMaxClasses] = {};  // μ|ω| and dt/(α l³) per class
  for (int k = 0; k < kMaxClasses; ++k) {
    const ClassConstants& cc = prm.by_label[k];
    wmu[k] = cc.mu * wn;
    // Divisions only for classes in contact (they are a visible share of a small step).
    // A lens voxel of another class has ΔV = 0, i.e. lies on the outer edge where Δσ = 0
    // and W = 0, so it would lose nothing anyway.
    if ((out.class_mask >> k) & 1u && std::isfinite(cc.alpha_N_per_mm2))
      kero[k] = dt / (cc.alpha_N_per_mm2 * l3);
  }
  st.friction = true;
  st.w = w;
  st.p0 = p0;
  for (int k = 0; k < kMaxClasses; ++k) {
    st.wmu[std::size_t(k)] = wmu[k];
    st.kero[std::size_t(k)] = kero[k];
  }
  double power = 0;
  const bool do_erode = erode_vol != nullptr && dt > 0;
  const detail::LensVoxel* lv = sc.lens.data();
  for (std::size_t j = 0; j < mo.lens_count; ++j) {
    const detail::LensVoxel& v = lv[j];
    const double vn = n.x * v.vx + n.y * v.vy + n.z * v.vz;
    const double d2 = v.d2, rd = v.rd;
    const double t2 = d2 - vn * vn;  // squared distance of c from the normal axis
    const double xi2 = rd * rd * t2;
    if (xi2 >= a2) continue;  // off the contact disc
    const detail::CutArea ai = area_of(j, d2);
    const double area = ai.area, inv_d = ai.inv_d;
    const double P = p0 * std::sqrt(1.0 - xi2 * inv_a2);
    const double chi = v.chi;
    const double s = chi * area * P * inv_d;
    // Σ s (v × ω̂) = (Σ s v) × ω̂: accumulate Σ s v, cross once per class at the end
    const int k = v.label;
    double* g = G[k];
    g[0] += s * v.vx;
    g[1] += s * v.vy;
    g[2] += s * v.vz;
    // Lever (r/d)v to the voxel's disc centre: T_i = (r/d) v × (s v × ω̂) = s (r/d)[(v·ω̂)v − d² ω̂].
    const double vwr = v.vx * w.x + v.vy * w.y + v.vz * w.z;
    const double sr = s * rd, srw = sr * vwr;
    double* tk = TA[k];
    tk[0] += srw * v.vx;
    tk[1] += srw * v.vy;
    tk[2] += srw * v.vz;
    TB[k] += sr * d2;
    if (wmu[k] == 0) continue;
    const double vw = vwr * inv_d;
    const double r = rd * d2 * inv_d;
    const double W = wmu[k] * chi * P * r * (1.0 - vw * vw) * area;
    power += W;
    if (!do_erode) continue;
    en[k] += W * dt;
    if (kero[k] > 0) rem[k] += erode_vol->erode(v.index, W * kero[k]);
  }
  if (do_erode) {
    for (int k = 0; k < kMaxClasses; ++k) {
      (*removed)[k] += l3 * rem[k];
      if (energy) (*energy)[k] += en[k];
    }
  }
  for (int k = 1; k < kMaxClasses; ++k) {
    if (!((out.class_mask >> k) & 1u)) continue;  // G_k = 0: no lens voxel of class k
    out.friction_lever[k] = glm::dvec3(G[k][0], G[k][1], G[k][2]);
    out.dFmu_dmu[k] = glm::cross(out.friction_lever[k], w);
    out.friction_N += prm.by_label[k].mu * out.dFmu_dmu[k];
    out.dTmu_dmu[k] = glm::dvec3(TA[k][0], TA[k][1], TA[k][2]) - TB[k] * w;
    out.moment_Nmm += prm.by_label[k].mu * out.dTmu_dmu[k];
  }
  out.power_W_mJ_per_s = power;
  out.force_N = out.elastic_N + out.friction_N;
  return out;
}

ContactResult contact(const Volume& vol, detail::Scratch& sc, glm::dvec3 p, glm::dvec3 omega, double R,
                      const ModelParams& prm, Volume* erode_vol, double dt,
                      std::array<double, kMaxClasses>* removed,
                      std::array<double, kMaxClasses>* energy, Quadrature q) {
  if (!(R > 0) || !std::isfinite(R))
    throw InputError("model", "radius_mm", "finite burr radius > 0 mm", std::to_string(R));
  if (q == Quadrature::kCube) {
    const CubeQuad quad{R, vol.voxel_mm(), sc.cut};
    sc.cut.resize(sc.lens.size());
    ContactResult c = contact_with(vol, sc, quad, CubeArea{sc.cut}, p, omega, R, prm, erode_vol, dt,
                                   removed, energy);
    sc.state.cube = true;
    return c;
  }
  const LensTable& tab = table_for(vol, sc, R);
  return contact_with(vol, sc, LensQuad{tab}, LensArea(tab), p, omega, R, prm, erode_vol, dt, removed, energy);
}

}  // namespace

KernelScratch::KernelScratch() : s_(std::make_unique<detail::Scratch>()) {}
KernelScratch::~KernelScratch() = default;
KernelScratch::KernelScratch(KernelScratch&&) noexcept = default;
KernelScratch& KernelScratch::operator=(KernelScratch&&) noexcept = default;

ContactResult evaluate(const Volume& vol, KernelScratch& scratch, glm::dvec3 centre_vol_mm,
                       glm::dvec3 omega_vol_rad_s, double radius_mm, const ModelParams& params,
                       Quadrature q) {
  return contact(vol, scratch.get(), centre_vol_mm, omega_vol_rad_s, radius_mm, params, nullptr, 0, nullptr,
                 nullptr, q);
}

ContactResult evaluate(const Volume& vol, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                       double radius_mm, const ModelParams& params, Quadrature q) {
  KernelScratch scratch;
  return evaluate(vol, scratch, centre_vol_mm, omega_vol_rad_s, radius_mm, params, q);
}

ContactResult step(Volume& vol, KernelScratch& scratch, glm::dvec3 centre_vol_mm,
                   glm::dvec3 omega_vol_rad_s, double radius_mm, const ModelParams& params,
                   double dt_s, std::array<double, kMaxClasses>& removed_mm3,
                   std::array<double, kMaxClasses>* energy_mJ, Quadrature q) {
  if (!(dt_s >= 0) || !std::isfinite(dt_s))
    throw InputError("model", "dt_s", "finite time step >= 0 s", std::to_string(dt_s));
  return contact(vol, scratch.get(), centre_vol_mm, omega_vol_rad_s, radius_mm, params, &vol, dt_s,
                 &removed_mm3, energy_mJ, q);
}

ContactResult step(Volume& vol, glm::dvec3 centre_vol_mm, glm::dvec3 omega_vol_rad_s,
                   double radius_mm, const ModelParams& params, double dt_s,
                   std::array<double, kMaxClasses>& removed_mm3,
                   std::array<double, kMaxClasses>* energy_mJ, Quadrature q) {
  KernelScratch scratch;
  return step(vol, scratch, centre_vol_mm, omega_vol_rad_s, radius_mm, params, dt_s, removed_mm3,
              energy_mJ, q);
}

}  // namespace burrbench::model
