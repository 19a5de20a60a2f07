// fit.json settings.registration and its summary lines: each recording's registration, the
// pose correction the fit applied, the TRE after the fit, and the pose prior's check.
#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/data_schema/fit_result.hpp"
#include "pipeline.hpp"

namespace burrbench::calibration::detail {
namespace {

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

// Where each of a mounting's 6 pose entries sits in the covariance (-1: not covered).
std::array<int, 6> pose_positions(const Layout& L, const Mounting& m, const ds::NamedMatrix& cov) {
  std::array<int, 6> at{};
  for (int k = 0; k < 6; ++k) {
    at[std::size_t(k)] = -1;
    for (std::size_t a = 0; a < cov.names.size(); ++a)
      if (cov.names[a] == L.name(std::size_t(m.offset + k))) at[std::size_t(k)] = int(a);
  }
  return at;
}

// TRE after the fit: the pose correction's posterior covariance mapped to the burr centre
// along the path, √trace(J Σ Jᵀ), J = [e_k × (p − c) | I] (the correction turns positions
// about the fiducials' centroid c, as it is applied). {rms, max} in mm; NaN: not covered.
std::pair<double, double> tre_after_fit(const std::vector<glm::dvec3>& path, const Mounting& m,
                                        const ds::NamedMatrix& cov, const std::array<int, 6>& at) {
  if (std::any_of(at.begin(), at.end(), [](int a) { return a < 0; }) || path.empty()) return {NAN, NAN};
  double ss = 0, mx = 0;
  for (const auto& p : path) {
    glm::dvec3 col[6];
    for (int k = 0; k < 6; ++k) {
      glm::dvec3 e(0);
      e[k % 3] = 1;
      col[k] = k < 3 ? glm::cross(e, p - m.centre_vol_mm) : e;
    }
    double v = 0;
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b)
        v += glm::dot(col[a], col[b]) * cov.at(std::size_t(at[std::size_t(a)]), std::size_t(at[std::size_t(b)]));
    ss += std::max(0.0, v);
    mx = std::max(mx, std::sqrt(std::max(0.0, v)));
  }
  return {std::sqrt(ss / double(path.size())), mx};
}

// The fitted correction against its fiducial prior: m² = xᵀ I x (I the fiducial fit's
// information), χ²₆ under the prior. Beyond kPosePriorLimit the data pulled the sample
// away from where the fiducials put it (a bead's coordinates off, a wrong burr radius or
// sensor frame): a finding. Each constant's linearised shift had the correction been
// held at the fiducials' registration, Δθ = −Σ_θP Σ_PP⁻¹ x_P, names the constants that
// depend on it (more than half their 95 % interval's half-width).
struct PriorCheck {
  double mahalanobis2 = NAN;
  nlohmann::json depends = nlohmann::json::array();
  std::vector<std::string> depends_text;
};

PriorCheck check_prior(const Run& run, const Mounting& m, const ds::NamedMatrix& cov, const std::array<int, 6>& at) {
  const Layout& L = *run.layout;
  PriorCheck c;
  Eigen::Matrix<double, 6, 1> x;
  for (int k = 0; k < 6; ++k) x(k) = run.x[std::size_t(m.offset + k)];
  Eigen::Matrix<double, 6, 6> U;
  for (int i = 0; i < 6; ++i)
    for (int j = 0; j < 6; ++j) U(i, j) = m.sqrt_information[std::size_t(6 * i + j)];
  c.mahalanobis2 = (U * x).squaredNorm();
  if (std::any_of(at.begin(), at.end(), [](int a) { return a < 0; })) return c;
  Eigen::Matrix<double, 6, 6> Spp;
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b) Spp(a, b) = cov.at(std::size_t(at[std::size_t(a)]), std::size_t(at[std::size_t(b)]));
  const Eigen::Matrix<double, 6, 1> w = Spp.ldlt().solve(x);
  for (const auto& fp : run.out.parameters) {
    if (!fp.identifiable || fp.fixed) continue;
    const std::string name = fp.class_name + "." + fp.name;
    std::size_t row = cov.names.size();
    for (std::size_t a = 0; a < cov.names.size(); ++a)
      if (const PhysicsParam* p = physics_of(L, fp); p && p->index >= 0 && cov.names[a] == L.name(std::size_t(p->index)))
        row = a;
    if (row == cov.names.size()) continue;
    double shift = 0;
    for (int b = 0; b < 6; ++b) shift -= cov.at(row, std::size_t(at[std::size_t(b)])) * w(b);
    const auto [lo, hi] = check_interval(fp);
    if (!(lo > 0) || !(hi > 0) || !(fp.estimate > 0)) continue;
    const double half = std::max(std::log(hi / fp.estimate), std::log(fp.estimate / lo));
    const double dlog = std::log1p(std::max(-0.99, shift / fp.estimate));
    if (std::abs(dlog) <= 0.5 * half) continue;
    c.depends.push_back({{"parameter", name}, {"estimate", fp.estimate}, {"held_at_fiducials_estimate", fp.estimate + shift}});
    c.depends_text.push_back(fmt::format("{} {} {} %", fp.class_name, fp.name, percent(100 * std::expm1(dlog), true)));
  }
  return c;
}

}  // namespace

nlohmann::json registration_report(Run& run, std::string& text) {
  const Layout& L = *run.layout;
  const auto& cov = run.out.covariance;
  nlohmann::json reg = nlohmann::json::object();
  std::vector<bool> checked(L.mountings().size(), false);
  for (std::size_t q = 0; q < run.recs.size(); ++q) {
    const auto* r = run.recs[q];
    const auto& g = r->registration;
    reg[r->id] = {{"method", g.method},        {"fiducials", g.fiducials},         {"rms_mm", num(g.rms_mm)},
                  {"max_mm", num(g.max_mm)},   {"worst_fiducial", g.worst},        {"fle_mm", num(g.fle_mm)},
                  {"fle_given", g.fle_given},  {"tre_path_rms_mm", num(g.tre_path_rms_mm)},
                  {"tre_path_max_mm", num(g.tre_path_max_mm)}};
    const auto& nz = L.recordings()[q];
    if (nz.pose < 0) continue;
    const auto& m = L.mountings()[std::size_t(nz.mounting)];
    const auto at = pose_positions(L, m, cov);
    const auto tr = r->trajectory(nz.lag >= 0 ? run.x[std::size_t(nz.lag)] * 1e-3 : nz.lag_fixed_ms * 1e-3);
    const auto [rms, mx] = tre_after_fit(tr.centre_vol_mm, m, cov, at);
    const PriorCheck pc = check_prior(run, m, cov, at);
    const bool beyond = pc.mahalanobis2 > kPosePriorLimit;
    auto val = [&](int k) { return run.x[std::size_t(m.offset + k)]; };
    reg[r->id]["pose_correction"] = {{"mounting", m.name},
                                     {"rotation_rad", {val(0), val(1), val(2)}},
                                     {"translation_mm", {val(3), val(4), val(5)}},
                                     {"centre_vol_mm", {m.centre_vol_mm.x, m.centre_vol_mm.y, m.centre_vol_mm.z}},
                                     {"tre_after_fit_rms_mm", num(rms)},
                                     {"tre_after_fit_max_mm", num(mx)},
                                     {"prior_mahalanobis2", num(pc.mahalanobis2)},
                                     {"prior_limit", kPosePriorLimit},
                                     {"beyond_prior", beyond},
                                     {"constants_depending", pc.depends}};
    text += fmt::format("  {}: pose correction of {}: rotation ({:.3g}, {:.3g}, {:.3g}) mrad, translation "
                        "({:.3g}, {:.3g}, {:.3g}) um ({:.2g} σ from its fiducial prior); TRE after the fit along "
                        "the path RMS {:.3g} um\n",
                        r->id, m.name, 1e3 * val(0), 1e3 * val(1), 1e3 * val(2), 1e3 * val(3), 1e3 * val(4),
                        1e3 * val(5), std::sqrt(pc.mahalanobis2), 1e3 * rms);
    if (!beyond || checked[std::size_t(nz.mounting)]) continue;
    checked[std::size_t(nz.mounting)] = true;
    run.warnings.push_back(fmt::format(
        "registration of {}: the fit moved the sample beyond its fiducial prior (Mahalanobis² {:.3g} > {:.4g}, "
        "χ²₆(0.999); translation ({:.3g}, {:.3g}, {:.3g}) um, rotation ({:.3g}, {:.3g}, {:.3g}) mrad): the data "
        "disagree with the fiducials — check each bead's rig coordinates (`burrbench inspect` lists the "
        "registration's residuals), the burr radius and the sensor frame. {}",
        m.name, pc.mahalanobis2, kPosePriorLimit, 1e3 * val(3), 1e3 * val(4), 1e3 * val(5), 1e3 * val(0),
        1e3 * val(1), 1e3 * val(2),
        pc.depends_text.empty()
            ? std::string("No constant moves by more than half its 95 % interval with the correction held at the "
                          "fiducials' registration")
            : fmt::format("These constants depend on the correction (their linearised move, were it held at the "
                          "fiducials' registration): {}", fmt::join(pc.depends_text, ", "))));
  }
  return reg;
}

}  // namespace burrbench::calibration::detail
