#include "burrbench/model/fitted_nuisances.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::model {
namespace ds = data_schema;

namespace {

std::optional<double> estimate(const ds::FitResult& fit, const std::string& rec, const std::string& name) {
  for (const auto& n : fit.nuisance)
    if (n.recording_id == rec && n.name == name && std::isfinite(n.estimate)) return n.estimate;
  return std::nullopt;
}

std::optional<glm::dvec3> estimate3(const ds::FitResult& fit, const std::string& rec, const std::string& prefix) {
  const auto x = estimate(fit, rec, prefix + "_x"), y = estimate(fit, rec, prefix + "_y"),
             z = estimate(fit, rec, prefix + "_z");
  if (!x || !y || !z) return std::nullopt;
  return glm::dvec3(*x, *y, *z);
}

std::optional<PoseCorrection> fitted_pose(const ds::FitResult& fit, const std::string& rec) {
  if (!fit.settings.contains("registration")) return std::nullopt;
  const auto& reg = fit.settings["registration"];
  if (!reg.is_object() || !reg.contains(rec) || !reg[rec].is_object() || !reg[rec].contains("pose_correction"))
    return std::nullopt;
  const auto& pc = reg[rec]["pose_correction"];
  const std::string field = fmt::format("settings.registration.{}.pose_correction", rec);
  if (!pc.is_object() || !pc.contains("rotation_rad") || !pc.contains("translation_mm") || !pc.contains("centre_vol_mm"))
    throw InputError("fit.json", field, "rotation_rad, translation_mm and centre_vol_mm");
  const auto vec = [&](const char* key) {
    const auto& a = pc.at(key);
    if (!a.is_array() || a.size() != 3 || !a[0].is_number() || !a[1].is_number() || !a[2].is_number())
      throw InputError("fit.json", field + "." + key, "3 numbers");
    return glm::dvec3(a[0].get<double>(), a[1].get<double>(), a[2].get<double>());
  };
  PoseCorrection p;
  p.rotation_rad = vec("rotation_rad");
  p.translation_mm = vec("translation_mm");
  p.centre_vol_mm = vec("centre_vol_mm");
  return p;
}

}  // namespace

FittedNuisances fitted_nuisances(const ds::FitResult& fit, const std::string& rec) {
  FittedNuisances n;
  n.lag_ms = estimate(fit, rec, "lag");
  n.depth_offset_mm = estimate(fit, rec, "depth_offset");
  n.force_bias_N = estimate3(fit, rec, "bias");
  n.torque_bias_Nmm = estimate3(fit, rec, "torque_bias");
  n.spindle_idle_Nmm = estimate(fit, rec, "spindle_idle");
  n.spindle_viscous_Nmm_per_krpm = estimate(fit, rec, "spindle_viscous").value_or(0.0);
  n.spindle_lag_ms = estimate(fit, rec, "spindle_lag").value_or(0.0);
  n.pose = fitted_pose(fit, rec);
  return n;
}

BandCovariance band_covariance(const ds::FitResult& fit, const ds::ParameterSet& params) {
  BandCovariance out;
  if (fit.covariance.size() == 0) return out;
  std::vector<std::size_t> at;
  std::vector<double> value;
  const auto& names = fit.covariance.names;
  for (const auto& [label, c] : params.classes)
    for (const auto kind : {Direction::Kind::kLogAlpha, Direction::Kind::kLogC1, Direction::Kind::kLogMu}) {
      const bool alpha = kind == Direction::Kind::kLogAlpha, c1 = kind == Direction::Kind::kLogC1;
      const auto it = std::find(names.begin(), names.end(), c.name + (alpha ? ".alpha" : c1 ? ".c1" : ".mu"));
      const double v = alpha ? c.alpha_N_per_mm2 : c1 ? c.c1_N_per_mm2 : c.mu;
      if (it == names.end() || !std::isfinite(v) || !(v > 0) || out.directions.size() >= kMaxDirections) continue;
      Direction d;
      d.kind = kind;
      d.label = std::uint8_t(label);
      out.directions.push_back(d);
      at.push_back(std::size_t(it - names.begin()));
      value.push_back(v);
    }
  const std::size_t m = at.size();
  out.cov_ln.resize(m * m);
  for (std::size_t a = 0; a < m; ++a)
    for (std::size_t b = 0; b < m; ++b) out.cov_ln[a * m + b] = fit.covariance.at(at[a], at[b]) / (value[a] * value[b]);
  return out;
}

}  // namespace burrbench::model
