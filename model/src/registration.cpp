#include "burrbench/model/registration.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>

#include "burrbench/data_schema/error.hpp"
#include "jacobi.hpp"

namespace burrbench::model {
namespace {

glm::dvec3 centroid(const std::vector<glm::dvec3>& pts) {
  glm::dvec3 c{0};
  for (const auto& p : pts) c += p;
  return c / double(pts.size());
}

// Ratio of the second-largest to the largest principal spread (0 for collinear points).
double planarity(const std::vector<glm::dvec3>& pts, const glm::dvec3& c) {
  std::array<std::array<double, 3>, 3> C{}, V{};
  for (const auto& p : pts) {
    const glm::dvec3 d = p - c;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) C[i][j] += d[i] * d[j];
  }
  detail::jacobi_eigen<3>(C, V);
  std::array<double, 3> ev{C[0][0], C[1][1], C[2][2]};
  std::sort(ev.begin(), ev.end());
  if (ev[2] <= 0) return 0;
  return std::sqrt(std::max(0.0, ev[1]) / ev[2]);
}

}  // namespace

void check_rotation(const glm::dmat3& R, const std::string& file, const std::string& field) {
  const glm::dmat3 E = glm::transpose(R) * R - glm::dmat3(1.0);
  double err = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      if (!std::isfinite(R[i][j])) throw InputError(file, field, "a finite 3×3 rotation");
      err = std::max(err, std::abs(E[i][j]));
    }
  const double det = glm::determinant(R);
  if (err > 1e-6 || det <= 0)
    throw InputError(file, field, "a proper rotation (orthonormal, det +1)",
                     fmt::format("max |RᵀR − I| = {:.3g}, det = {:.6g}", err, det));
}

glm::dmat3 optimal_rotation(const std::array<std::array<double, 3>, 3>& S3) {
  // Horn (1987): the optimal unit quaternion is the top eigenvector of N(S).
  const double Sxx = S3[0][0], Sxy = S3[0][1], Sxz = S3[0][2], Syx = S3[1][0], Syy = S3[1][1],
               Syz = S3[1][2], Szx = S3[2][0], Szy = S3[2][1], Szz = S3[2][2];
  std::array<std::array<double, 4>, 4> N{{
      {Sxx + Syy + Szz, Syz - Szy, Szx - Sxz, Sxy - Syx},
      {Syz - Szy, Sxx - Syy - Szz, Sxy + Syx, Szx + Sxz},
      {Szx - Sxz, Sxy + Syx, -Sxx + Syy - Szz, Syz + Szy},
      {Sxy - Syx, Szx + Sxz, Syz + Szy, -Sxx - Syy + Szz},
  }};
  std::array<std::array<double, 4>, 4> V{};
  detail::jacobi_eigen<4>(N, V);
  int best = 0;
  for (int k = 1; k < 4; ++k)
    if (N[k][k] > N[best][best]) best = k;
  double q0 = V[0][best], qx = V[1][best], qy = V[2][best], qz = V[3][best];
  const double qn = std::sqrt(q0 * q0 + qx * qx + qy * qy + qz * qz);
  q0 /= qn, qx /= qn, qy /= qn, qz /= qn;
  // Rotation matrix of the quaternion, written row-wise, stored column-major.
  const double r[3][3] = {
      {q0 * q0 + qx * qx - qy * qy - qz * qz, 2 * (qx * qy - q0 * qz), 2 * (qx * qz + q0 * qy)},
      {2 * (qy * qx + q0 * qz), q0 * q0 - qx * qx + qy * qy - qz * qz, 2 * (qy * qz - q0 * qx)},
      {2 * (qz * qx - q0 * qy), 2 * (qz * qy + q0 * qx), q0 * q0 - qx * qx - qy * qy + qz * qz},
  };
  glm::dmat3 R;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) R[col][row] = r[row][col];
  return R;
}

RegistrationFit fit_rigid(const std::vector<glm::dvec3>& from, const std::vector<glm::dvec3>& to,
                          const std::string& file, const std::string& field) {
  if (from.size() != to.size())
    throw InputError(file, field, "as many volume fiducials as rig fiducials",
                     fmt::format("{} rig, {} volume", from.size(), to.size()));
  if (from.size() < 3)
    throw InputError(file, field, "at least 3 fiducial pairs", std::to_string(from.size()));
  for (std::size_t i = 0; i < from.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(from[i][k]) || !std::isfinite(to[i][k]))
        throw InputError(file, fmt::format("{}[{}]", field, i), "finite coordinates (mm)");
  const glm::dvec3 ca = centroid(from), cb = centroid(to);
  // Relative threshold: 1e-6 of the spread ~ far below any real fiducial layout.
  if (planarity(from, ca) < 1e-6 || planarity(to, cb) < 1e-6)
    throw InputError(file, field, "fiducials that are not collinear (rotation undetermined)");

  // Horn (1987) on the cross-covariance Σ (a−ā)(b−b̄)ᵀ.
  std::array<std::array<double, 3>, 3> S{};
  for (std::size_t i = 0; i < from.size(); ++i) {
    const glm::dvec3 a = from[i] - ca, b = to[i] - cb;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) S[std::size_t(r)][std::size_t(c)] += a[r] * b[c];
  }
  RegistrationFit fit;
  fit.transform.R = optimal_rotation(S);
  fit.transform.t = cb - fit.transform.R * ca;
  double ss = 0;
  for (std::size_t i = 0; i < from.size(); ++i) {
    const double e = glm::length(fit.transform.apply(from[i]) - to[i]);
    fit.residual_mm.push_back(e);
    ss += e * e;
    fit.max_mm = std::max(fit.max_mm, e);
  }
  fit.rms_mm = std::sqrt(ss / double(from.size()));
  return fit;
}

double predicted_tre_mm(const std::vector<glm::dvec3>& fid, double fle_mm, const glm::dvec3& target) {
  const std::size_t n = fid.size();
  if (n < 3) return NAN;
  const glm::dvec3 c = centroid(fid);
  std::array<std::array<double, 3>, 3> C{}, V{};
  for (const auto& p : fid) {
    const glm::dvec3 d = p - c;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) C[i][j] += d[i] * d[j];
  }
  detail::jacobi_eigen<3>(C, V);
  const glm::dvec3 r = target - c;
  double sum = 0;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 e(V[0][k], V[1][k], V[2][k]);
    double f2 = 0;
    for (const auto& p : fid) {
      const glm::dvec3 d = p - c;
      f2 += glm::dot(d, d) - glm::dot(d, e) * glm::dot(d, e);
    }
    f2 /= double(n);
    const double d2 = glm::dot(r, r) - glm::dot(r, e) * glm::dot(r, e);
    if (f2 > 0) sum += d2 / f2;
  }
  return fle_mm * std::sqrt((1 + sum / 3) / double(n));
}

void check_fiducial_fit(const RegistrationFit& fit, const std::vector<glm::dvec3>& from,
                        const std::vector<glm::dvec3>& to, double limit_mm,
                        const std::string& file, const std::string& field) {
  if (!(fit.rms_mm > limit_mm)) return;
  std::size_t worst = 0;
  for (std::size_t i = 0; i < fit.residual_mm.size(); ++i)
    if (fit.residual_mm[i] > fit.residual_mm[worst]) worst = i;
  // Two rows exchanged in one list is the common mistake: try every swap.
  double best = INFINITY;
  std::size_t bi = 0, bj = 0;
  for (std::size_t i = 0; i < to.size(); ++i)
    for (std::size_t j = i + 1; j < to.size(); ++j) {
      std::vector<glm::dvec3> t = to;
      std::swap(t[i], t[j]);
      try {
        const double r = fit_rigid(from, t, file, field).rms_mm;
        if (r < best) { best = r; bi = i; bj = j; }
      } catch (const InputError&) {}
    }
  const std::string swapped =
      best <= limit_mm ? fmt::format("; rows {} and {} look swapped (exchanged, the RMS is {:.4g} mm)", bi, bj, best)
                       : "";
  throw InputError(file, field,
                   fmt::format("fiducial residuals within the limit (RMS <= {:.4g} mm = {} x fiducial_error_mm)",
                               limit_mm, kFiducialLimitFactor),
                   fmt::format("RMS {:.4g} mm, worst fiducial {} ({:.4g} mm){}", fit.rms_mm, worst,
                               fit.residual_mm[worst], swapped));
}

namespace {
// Rodrigues: v turned by the angle |w| about w/|w|.
glm::dvec3 rodrigues(const glm::dvec3& w, const glm::dvec3& v) {
  const double a = glm::length(w);
  if (!(a > 0)) return v;
  const glm::dvec3 k = w / a;
  return v * std::cos(a) + glm::cross(k, v) * std::sin(a) + k * glm::dot(k, v) * (1 - std::cos(a));
}
}  // namespace

glm::dvec3 PoseCorrection::apply(const glm::dvec3& p) const {
  return centre_vol_mm + rodrigues(rotation_rad, p - centre_vol_mm) + translation_mm;
}

glm::dvec3 PoseCorrection::rotate(const glm::dvec3& v) const { return rodrigues(rotation_rad, v); }
glm::dvec3 PoseCorrection::unrotate(const glm::dvec3& v) const { return rodrigues(-rotation_rad, v); }

glm::dvec3 PoseCorrection::derivative(int k, const glm::dvec3& p) const {
  glm::dvec3 e(0);
  e[k % 3] = 1;
  if (k >= 3) return e;
  return glm::cross(e, apply(p) - translation_mm - centre_vol_mm);
}

std::array<double, 36> fiducial_fit_information(const std::vector<glm::dvec3>& fid, double fle_mm) {
  std::array<double, 36> info{};
  const double s2 = fle_mm * fle_mm / 3.0;
  const glm::dvec3 c = centroid(fid);
  for (const auto& p : fid) {
    const glm::dvec3 x = p - c;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) info[std::size_t(6 * i + j)] += ((i == j) * glm::dot(x, x) - x[i] * x[j]) / s2;
  }
  for (int i = 3; i < 6; ++i) info[std::size_t(6 * i + i)] = double(fid.size()) / s2;
  return info;
}

}  // namespace burrbench::model
