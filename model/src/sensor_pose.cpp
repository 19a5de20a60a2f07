#include "burrbench/model/sensor_pose.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/registration.hpp"
#include "jacobi.hpp"

namespace burrbench::model {
namespace {

glm::dmat3 skew(const glm::dvec3& f) {  // skew(f)·o = f × o (glm: column-major)
  return glm::dmat3(glm::dvec3(0, f.z, -f.y), glm::dvec3(-f.z, 0, f.x), glm::dvec3(f.y, -f.x, 0));
}

// Rank of the directions spanned by a set of vectors (relative threshold).
int span_rank(const std::vector<glm::dvec3>& v) {
  std::array<std::array<double, 3>, 3> A{}, V{};
  double tr = 0;
  for (const auto& x : v)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) A[std::size_t(r)][std::size_t(c)] += x[r] * x[c];
  for (int k = 0; k < 3; ++k) tr += A[std::size_t(k)][std::size_t(k)];
  detail::jacobi_eigen<3>(A, V);
  int rank = 0;
  for (int k = 0; k < 3; ++k) rank += A[std::size_t(k)][std::size_t(k)] > 1e-10 * tr;
  return rank;
}

}  // namespace

SensorPoseFit estimate_sensor_pose(const std::vector<StaticLoad>& loads, const std::string& file) {
  if (loads.size() < 2) throw InputError(file, "loads", "at least 2 loads (3 or more recommended)", std::to_string(loads.size()));
  for (std::size_t i = 0; i < loads.size(); ++i) {
    const auto& l = loads[i];
    for (const auto& v : {l.force_rig_N, l.point_rig_mm, l.force_sensor_N, l.moment_sensor_Nmm})
      if (!std::isfinite(v.x + v.y + v.z)) throw InputError(file, fmt::format("loads[{}]", i), "finite values");
    if (!(glm::length(l.force_rig_N) > 0)) throw InputError(file, fmt::format("loads[{}]", i), "a non-zero load");
  }
  // Moments are weighed against forces by the loads' lever: residuals in N and in N·mm/L.
  glm::dvec3 centre(0);
  for (const auto& l : loads) centre += l.point_rig_mm / double(loads.size());
  double lever2 = 0;
  for (const auto& l : loads) lever2 += glm::dot(l.point_rig_mm - centre, l.point_rig_mm - centre) / double(loads.size());
  const double w_m = 1.0 / std::max(1.0, lever2);
  {
    std::vector<glm::dvec3> sensor, rig;
    for (const auto& l : loads) {
      sensor.push_back(l.force_sensor_N);
      sensor.push_back(l.moment_sensor_Nmm);
      rig.push_back(l.force_rig_N);
    }
    if (span_rank(sensor) < 2)
      throw InputError(file, "loads", "readings that span at least two directions (the rotation is undetermined)");
  }
  // The normal equations of o: Σ skew(f)ᵀ skew(f), the same every iteration; its
  // pseudo-inverse drops a direction every load is parallel to.
  glm::dmat3 A(0.0);
  for (const auto& l : loads) A += glm::transpose(skew(l.force_rig_N)) * skew(l.force_rig_N);
  std::array<std::array<double, 3>, 3> Aa{}, V{};
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) Aa[std::size_t(r)][std::size_t(c)] = A[c][r];
  detail::jacobi_eigen<3>(Aa, V);
  const double top = std::max({Aa[0][0], Aa[1][1], Aa[2][2]});
  glm::dmat3 Ainv(0.0);
  SensorPoseFit fit;
  for (int k = 0; k < 3; ++k) {
    const glm::dvec3 e(V[0][std::size_t(k)], V[1][std::size_t(k)], V[2][std::size_t(k)]);
    const double lam = Aa[std::size_t(k)][std::size_t(k)];
    if (lam > 1e-9 * top) Ainv += glm::outerProduct(e, e) / lam;
    else fit.unobservable_rig = e;
  }
  glm::dmat3 Q(1.0);
  glm::dvec3 o(0);
  for (int it = 1; it <= 200; ++it) {
    fit.iterations = it;
    std::array<std::array<double, 3>, 3> S{};
    for (const auto& l : loads) {
      const glm::dvec3 mb = glm::cross(l.point_rig_mm - o, l.force_rig_N);
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c)
          S[std::size_t(r)][std::size_t(c)] +=
              l.force_sensor_N[r] * l.force_rig_N[c] + w_m * l.moment_sensor_Nmm[r] * mb[c];
    }
    const glm::dmat3 Qn = optimal_rotation(S);
    // f × o = Q M − a × f for every load.
    glm::dvec3 rhs(0);
    for (const auto& l : loads)
      rhs += glm::transpose(skew(l.force_rig_N)) * (Qn * l.moment_sensor_Nmm - glm::cross(l.point_rig_mm, l.force_rig_N));
    const glm::dvec3 on = Ainv * rhs;
    double dq = 0;
    for (int c = 0; c < 3; ++c) dq = std::max(dq, glm::length(Qn[c] - Q[c]));
    const double dox = glm::length(on - o);
    Q = Qn;
    o = on;
    if (dq < 1e-13 && dox < 1e-10) break;
  }
  fit.rotation_sensor_to_rig = Q;
  fit.origin_rig_mm = o;
  double sf = 0, sm = 0;
  for (const auto& l : loads) {
    const double ef = glm::length(Q * l.force_sensor_N - l.force_rig_N);
    const double em = glm::length(Q * l.moment_sensor_Nmm - glm::cross(l.point_rig_mm - o, l.force_rig_N));
    fit.force_residual_N.push_back(ef);
    fit.moment_residual_Nmm.push_back(em);
    sf += ef * ef;
    sm += em * em;
  }
  fit.force_rms_N = std::sqrt(sf / double(loads.size()));
  fit.moment_rms_Nmm = std::sqrt(sm / double(loads.size()));
  return fit;
}

}  // namespace burrbench::model
