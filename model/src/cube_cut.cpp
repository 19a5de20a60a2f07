#include "burrbench/model/cube_cut.hpp"

#include <algorithm>
#include <cmath>

namespace burrbench::model {

namespace {

// Components below this are raised to it: the corner sums divide by the product of the
// components, and by one of them again for the moments. Raising (not zeroing) keeps ΔV, A
// and μₙ continuous in n̂ (they are even in each component), so derivatives taken across
// the threshold by differences see no jump; the cut's n̂-derivatives in a raised component
// are 0, as the function's.
constexpr double kFlat = 1e-3;

// Integrals over the unit cube's part {a·u ≤ t}, u ∈ [0, 1]³, a ≥ 0 (zero components
// allowed), its section {a·u = t} (a density in t: ∫ δ(t − a·u) du) and their t-derivatives.
struct Unit {
  double V = 0, A = 0, At = 0;
  double M[3] = {}, m[3] = {}, mh[3] = {};  // ∫ u_i over the part, the section, ∂/∂t of the latter
};

// With D the nonzero components and Π their product, x_v = t − a·v over the corners v of
// their D-cube and s_v = (−1)^|v|, the truncated power sums P_k = Σ s_v x_v₊^k / k! and
// Q_k^i = Σ s_v v_i x_v₊^k / k! give V = P_D/Π, A = P_{D−1}/Π, ∂A/∂t = P_{D−2}/Π, and
// with H = ∫V dt = P_{D+1}/Π: M_i = −∂H/∂a_i = H/a_i + Q_D^i/Π, m_i = ∂M_i/∂t,
// ∂m_i/∂t likewise (P_{−1} = Q_{−1} = 0 almost everywhere). A zero component's axis is a
// prism's: M_i = V/2, m_i = A/2.
Unit unit_part(const double a[3], double t, bool derivs) {
  Unit u;
  if (!(t > 0)) return u;
  int e[3], D = 0;
  double prod = 1;
  for (int i = 0; i < 3; ++i)
    if (a[i] > 0) {
      e[D++] = i;
      prod *= a[i];
    }
  double P[4] = {}, Q[3][3] = {};  // P[j] = P_{D−2+j}; Q[i][j] = Q_{D−2+j}^i
  static const double inv_fact[6] = {1, 1, 0.5, 1.0 / 6, 1.0 / 24, 1.0 / 120};
  for (int v = 0; v < (1 << D); ++v) {
    double x = t;
    int bits = 0;
    for (int j = 0; j < D; ++j)
      if ((v >> j) & 1) {
        x -= a[e[j]];
        ++bits;
      }
    if (!(x > 0)) continue;
    const double s = (bits & 1) ? -1.0 : 1.0;
    double xk[5] = {1, x, x * x, 0, 0};  // x^k, k = 0..D+1 (D ≤ 3)
    xk[3] = xk[2] * x;
    xk[4] = xk[3] * x;
    double pw[4];  // x^(D−2+j)/(D−2+j)!, j = 0..3
    for (int j = 0; j < 4; ++j) {
      const int k = D - 2 + j;
      pw[j] = k < 0 ? 0.0 : xk[k] * inv_fact[k];
    }
    for (int j = 0; j < 4; ++j) P[j] += s * pw[j];
    for (int j = 0; j < D; ++j)
      if ((v >> j) & 1)
        for (int q = 0; q < 3; ++q) Q[e[j]][q] += s * pw[q];
  }
  const double ip = 1.0 / prod;
  u.V = P[2] * ip;
  u.A = P[1] * ip;
  u.At = P[0] * ip;
  const double H = P[3] * ip;
  for (int i = 0; i < 3; ++i) {
    if (a[i] > 0) {
      u.M[i] = H / a[i] + Q[i][2] * ip;
      if (derivs) {
        u.m[i] = u.V / a[i] + Q[i][1] * ip;
        u.mh[i] = u.A / a[i] + Q[i][0] * ip;
      }
    } else {
      u.M[i] = 0.5 * u.V;
      u.m[i] = 0.5 * u.A;
      u.mh[i] = 0.5 * u.At;
    }
  }
  return u;
}

}  // namespace

CubeCut cube_cut(const glm::dvec3& n, double h, double l, bool derivs) {
  double a[3], sg[3], free[3], S = 0;
  for (int i = 0; i < 3; ++i) {
    sg[i] = n[i] < 0 ? -1.0 : 1.0;
    a[i] = std::max(std::abs(n[i]), kFlat);
    free[i] = std::abs(n[i]) < kFlat ? 0.0 : 1.0;
    S += a[i];
  }
  const double t = h / l + 0.5 * S;
  CubeCut c;
  c.free_axes = glm::dvec3(free[0], free[1], free[2]);
  if (!(t > 0)) return c;
  Unit u;
  if (t <= 0.5 * S) {
    u = unit_part(a, t, derivs);
  } else {  // the complement {a·u' < S − t}, u' = 1 − u: fewer corners, no cancellation
    const Unit w = unit_part(a, S - t, derivs);
    u.V = 1 - w.V;
    u.A = w.A;
    u.At = -w.At;
    for (int i = 0; i < 3; ++i) {
      u.M[i] = 0.5 - w.V + w.M[i];
      u.m[i] = w.A - w.m[i];
      u.mh[i] = -w.At + w.mh[i];
    }
  }
  const double l2 = l * l, l3 = l2 * l, l4 = l3 * l;
  c.volume_mm3 = l3 * u.V;
  c.area_mm2 = l2 * u.A;
  for (int i = 0; i < 3; ++i) {
    const double mom = sg[i] * l4 * (u.M[i] - 0.5 * u.V);
    c.normal_moment_mm4 += sg[i] * a[i] * mom;
    if (derivs) c.moment_mm4[i] = mom;
  }
  if (derivs) {
    c.area_dh_mm = l * u.At;
    for (int i = 0; i < 3; ++i) {
      c.section_mm3[i] = sg[i] * l3 * (u.m[i] - 0.5 * u.A);
      c.section_dh_mm2[i] = sg[i] * l2 * (u.mh[i] - 0.5 * u.At);
    }
    for (int i = 0; i < 3; ++i) {
      c.section_mm3[i] *= free[i];  // ∂ΔV/∂n_i = −section_i, 0 in a raised component
      c.section_dh_mm2[i] *= free[i];
    }
  }
  return c;
}

CubeCutGradient cube_cut_gradient(const CubeCut& c, const glm::dvec3& v, double h) {
  // n̂ = v/d, h = R − d: ∂n̂/∂v = (I − n̂n̂ᵀ)/d, ∂h/∂v = −n̂. At fixed h, ∂ΔV/∂n̂ = −∫ u dA,
  // ∂A/∂n̂ = −∂(∫ u dA)/∂h and ∂μₙ/∂n̂ = ∫ u dV − h ∫ u dA; ∂ΔV/∂h = A, ∂μₙ/∂h = h A.
  const double d = glm::length(v);
  const glm::dvec3 n = v / d;
  auto tangential = [&](const glm::dvec3& x) { return (x - glm::dot(n, x) * n) / d; };
  CubeCutGradient g;
  g.volume = -c.area_mm2 * n - tangential(c.section_mm3);
  g.area = -c.area_dh_mm * n - tangential(c.section_dh_mm2);
  const glm::dvec3 dmu = -h * c.area_mm2 * n + tangential(c.free_axes * c.moment_mm4 - h * c.section_mm3);
  g.radial_moment = d * g.volume + c.volume_mm3 * n + dmu;
  return g;
}

}  // namespace burrbench::model
