#include "burrbench/calibration/uncertainty.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include <Eigen/Dense>

#include <fmt/format.h>

#include "burrbench/data_schema/fit_result.hpp"

namespace burrbench::calibration {
namespace {

constexpr double kZ95 = 1.959963984540054;
constexpr double kMaxLogSE = 1.1748;  // ln(10)/1.96: interval wider than ×/÷ 10
constexpr double kNullRatio = 1e-8;

bool class_touched(const Evaluation& ev, const SampleWeights& w, std::uint8_t label) {
  for (std::size_t r = 0; r < ev.predictions.size(); ++r) {
    const auto& p = ev.predictions[r];
    for (std::size_t j = 0; j < p.class_mask.size(); ++j)
      if (w[r][j] > 0 && (p.class_mask[j] >> label & 1u)) return true;
  }
  return false;
}

double removed(const Evaluation& ev, std::uint8_t label) {
  double s = 0;
  for (const auto& p : ev.predictions) s += p.removed_mm3[label];
  return s;
}

// Slice check at the far end of α: moving α alone to its upper bound (next to "no
// erosion") must worsen the fit by more than the 95 % χ²(1) quantile, else the data only
// bound α from below. The local covariance cannot see this: far out, the cost is flat but
// the curvature at the estimate can still look finite. A slice, not a profile (C1 and μ
// are not re-fitted), so it can miss a bound that a re-fit would reach (docs/calibration.md).
bool alpha_bound_not_excluded(const Objective& obj, const std::vector<double>& x,
                              const SampleWeights& w, const Evaluation& at_x, std::size_t i,
                              double inflation) {
  const double dof = double(at_x.residuals_used) - double(x.size());
  if (dof <= 0) return false;
  const double s2 = std::max(2.0 * at_x.cost / dof, 1e-12);  // residual variance
  std::vector<double> far = x;
  far[i] = obj.layout().upper(i);
  const Evaluation ev = obj.evaluate(far, w);
  return 2.0 * (ev.cost - at_x.cost) / (s2 * inflation) < 3.841458820694124;
}

}  // namespace

Flags contact_checks(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                     const Evaluation& at_x) {
  const Layout& L = obj.layout();
  Flags f;
  f.held.assign(L.size(), false);
  f.reason.assign(L.size(), "");
  for (const auto& p : L.physics()) {
    if (p.index < 0) continue;
    const std::size_t i = std::size_t(p.index);
    if (!class_touched(at_x, w, p.label)) {
      f.held[i] = true;
      f.reason[i] = fmt::format("class '{}' is never in contact in the used samples", p.class_name);
    } else if (p.kind == PhysKind::kAlpha && !(removed(at_x, p.label) > 0)) {
      f.held[i] = true;
      f.reason[i] = fmt::format("no '{}' bone is removed in the replay: alpha has no effect on "
                                "the predicted force", p.class_name);
    } else if (p.kind == PhysKind::kAlpha) {
      // Erosion at the estimate against (almost) none: α at its upper bound, and at least
      // 1000 times the estimate (a bound set below the bone's α would otherwise compare the
      // estimate at that bound with itself). When that changes no used sample's predicted
      // force by as much as the sensor noise σ, the erosion is invisible sample by sample and
      // α is not identifiable, whatever a fit to the noise may suggest (erosion-free data
      // settle at ~1e5 N/mm² this way).
      std::vector<double> far = x;
      far[i] = std::max(L.upper(i), x[i] + std::log(1e3));
      const Evaluation ev = obj.evaluate(far, w);
      double largest = 0;
      for (std::size_t r = 0; r < ev.predictions.size(); ++r)
        for (std::size_t j = 0; j < ev.predictions[r].force_sensor_N.size(); ++j)
          if (w[r][j] > 0 && (at_x.predictions[r].class_mask[j] >> p.label & 1u))
            largest = std::max(largest, glm::length(ev.predictions[r].force_sensor_N[j] -
                                                    at_x.predictions[r].force_sensor_N[j]));
      if (largest < obj.settings().sigma_N) {
        f.held[i] = true;
        f.reason[i] = fmt::format("the erosion of '{}' bone at this alpha changes no predicted force by "
                                  "as much as the sensor noise (largest {:.3g} N < sigma {:.3g} N against "
                                  "no erosion): alpha is not seen in these data",
                                  p.class_name, largest, obj.settings().sigma_N);
      }
    }
  }
  return f;
}

std::vector<AtBound> held_at_bounds(const Layout& L, const std::vector<double>& x,
                                    const std::vector<std::size_t>& physics) {
  std::vector<AtBound> at;
  for (std::size_t j : physics) at.push_back({j, L.upper(j) - x[j] < x[j] - L.lower(j) ? 1 : -1});
  for (const auto& b : nuisances_at_bounds(L, x)) at.push_back({b.index, b.upper ? 1 : -1});
  return at;
}

std::vector<double> step_past_bounds(const CovarianceOutcome& cov, const std::vector<AtBound>& at, std::size_t n,
                                     std::vector<AtBound>* pulled) {
  const std::size_t m = cov.indices.size();
  if (pulled) pulled->clear();
  if (!cov.ok || cov.gradient.size() != m) return {};
  const double scale = cov.residual_variance * cov.inflation;
  std::vector<double> step(n, 0.0);
  bool any = false;
  for (const AtBound& b : at) {
    const std::size_t c = cov.position(b.entry);
    // Outwards: the cost falls beyond the bound (an upper bound with ∂cost/∂x < 0).
    if (c == m || !(-cov.gradient[c] * b.side > 0)) continue;
    any = true;
    if (pulled) pulled->push_back(b);
    for (std::size_t a = 0; a < m; ++a)
      if (cov.indices[a] < n) step[cov.indices[a]] -= cov.cov[a * m + c] * cov.gradient[c] / scale;
  }
  return any ? step : std::vector<double>{};
}

double conditional_variance(const CovarianceOutcome& cov, std::size_t i, const std::vector<std::size_t>& held) {
  const std::size_t m = cov.indices.size(), a = cov.position(i);
  if (!cov.ok || a == m) return NAN;
  const Eigen::Map<const Eigen::MatrixXd> S(cov.cov.data(), Eigen::Index(m), Eigen::Index(m));
  std::vector<Eigen::Index> b;  // the held entries' positions
  for (std::size_t j : held)
    if (const std::size_t c = cov.position(j); c != m && c != a) b.push_back(Eigen::Index(c));
  Eigen::MatrixXd Sbb(b.size(), b.size());
  Eigen::VectorXd sib(b.size());
  for (std::size_t u = 0; u < b.size(); ++u) {
    sib(Eigen::Index(u)) = S(Eigen::Index(a), b[u]);
    for (std::size_t v = 0; v < b.size(); ++v) Sbb(Eigen::Index(u), Eigen::Index(v)) = S(b[u], b[v]);
  }
  const double v = S(Eigen::Index(a), Eigen::Index(a)) - (b.empty() ? 0.0 : sib.dot(Sbb.ldlt().solve(sib)));
  return std::max(0.0, v);
}

std::string bound_partner_reason(const Layout& L, const std::vector<double>& x, std::size_t i,
                                 const std::vector<AtBound>& pulled, double shift_log, double half_log) {
  std::string who, widen;
  for (std::size_t k = 0; k < pulled.size(); ++k) {
    const std::size_t j = pulled[k].entry;
    const PhysicsParam* pj = L.physics_at(j);
    const bool up = pulled[k].side > 0;
    who += (k == 0 ? "" : k + 1 == pulled.size() ? " and " : ", ") + L.name(j) +
           (pj ? fmt::format(" (at its {} bound, {:.4g}{})", up ? "upper" : "lower", std::exp(x[j]),
                             data_schema::unit_suffix(unit_of(pj->kind)))
               : fmt::format(" (at its {} bound: see the warnings)", up ? "upper" : "lower"));
    const std::string entry = pj ? fmt::format("[fit.classes.{}] {}", pj->class_name, to_string(pj->kind))
                              : L.name(j).ends_with(".lag") ? std::string("[fit.nuisance] lag_bounds_ms")
                                                            : std::string();  // the warning says what to check
    if (!entry.empty() && widen.find(entry) == std::string::npos) widen += (widen.empty() ? "" : ", ") + entry;
  }
  const double a = std::abs(shift_log);
  const std::string by =
      a <= std::log(2.0)    ? fmt::format("by {:+.3g} %", 100 * std::expm1(shift_log))
      : a <= std::log(1e3) ? fmt::format("{} by a factor of {:.3g}", shift_log > 0 ? "up" : "down", std::exp(a))
                           : fmt::format("{} by more than a factor of 1000, beyond what a linearised step tells",
                                         shift_log > 0 ? "up" : "down");
  const PhysicsParam* pi = L.physics_at(i);
  const std::string to = pi && a <= std::log(10.0)
                             ? fmt::format(" (to about {:.4g}{})", std::exp(x[i] + shift_log),
                                           data_schema::unit_suffix(unit_of(pi->kind)))
                             : std::string();
  return fmt::format("moves with {}, which the data pull beyond {}: with {} lifted, the linearised fit "
                     "moves this constant {}{}, more than its 95 % interval's ±{:.3g} %, which holds {} at "
                     "the bound{}",
                     who, pulled.size() > 1 ? "their bounds" : "its bound", pulled.size() > 1 ? "those" : "that",
                     by, to, 100 * std::expm1(half_log), pulled.size() > 1 ? "them" : "it",
                     widen.empty() ? std::string() : ": widen " + widen);
}

namespace {

// The x entries held as not identifiable and why; `rules` false: the covariance's rules
// flag nothing (the profiles decided).
struct HoldList {
  std::vector<bool> held;
  std::vector<std::string> reason;
  bool rules;
  bool flag(int i, std::string why) {
    if (!rules || i < 0 || held[std::size_t(i)]) return false;
    held[std::size_t(i)] = true;
    reason[std::size_t(i)] = std::move(why);
    return true;
  }
};

// The variance of x entry i's estimate (NaN when the covariance failed or leaves it out).
double entry_variance(const CovarianceOutcome& cov, std::size_t i) {
  const std::size_t a = cov.position(i), m = cov.indices.size();
  return cov.ok && a != m ? cov.cov[a * m + a] : NAN;
}

// Rules at the bounds: an estimate at a bound, and α whose upper bound the data cannot
// exclude. Returns the entries at their bounds.
std::vector<std::size_t> flag_at_bounds(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                                        const Evaluation& at_x, double inflation, HoldList& hold) {
  const Layout& L = obj.layout();
  std::vector<std::size_t> at_bounds;
  for (const auto& p : L.physics()) {
    if (p.index < 0 || !hold.rules || hold.held[std::size_t(p.index)]) continue;
    const std::size_t i = std::size_t(p.index);
    if (x[i] - L.lower(i) < 0.01 || L.upper(i) - x[i] < 0.01) {
      hold.flag(p.index, fmt::format("estimate at its {} bound ({:.4g}{})",
                                x[i] - L.lower(i) < 0.01 ? "lower" : "upper", std::exp(x[i]),
                                data_schema::unit_suffix(unit_of(p.kind))));
      at_bounds.push_back(i);
    } else if (p.kind == PhysKind::kAlpha && alpha_bound_not_excluded(obj, x, w, at_x, i, inflation)) {
      hold.flag(p.index, fmt::format("the data cannot exclude alpha at its upper bound ({:.4g}{}{}): they "
                                "give only a lower limit",
                                std::exp(L.upper(i)), data_schema::unit_suffix(unit_of(p.kind)),
                                L.upper(i) - x[i] >= std::log(1e3) ? ", next to no erosion" : ""));
    }
  }
  return at_bounds;
}

// Rule 3's partners, and those of the nuisances at their bounds: the covariance with
// them free gives the step past the bounds and, conditioned on them (Schur complement),
// each constant's half-width with them held, against which that step is weighed.
void flag_bound_partners(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                         double inflation, const std::vector<bool>& before_bounds,
                         const std::vector<std::size_t>& at_bounds, HoldList& hold) {
  const Layout& L = obj.layout();
  const std::vector<AtBound> at = held_at_bounds(L, x, at_bounds);
  if (!hold.rules || at.empty()) return;
  const CovarianceOutcome free = obj.covariance(x, w, before_bounds, inflation);
  std::vector<AtBound> pulled;
  const std::vector<double> step = step_past_bounds(free, at, L.size(), &pulled);
  std::vector<std::size_t> pulled_entries;
  for (const AtBound& b : pulled) pulled_entries.push_back(b.entry);
  for (const auto& p : L.physics()) {
    if (step.empty() || p.index < 0 || hold.held[std::size_t(p.index)]) continue;
    const std::size_t i = std::size_t(p.index);
    const double half = kZ95 * std::sqrt(conditional_variance(free, i, pulled_entries));
    if (std::abs(step[i]) > half) hold.flag(int(i), bound_partner_reason(L, x, i, pulled, step[i], half));
  }
}

// The covariance's rules, re-applied (up to 4 rounds) until holding the flagged entries
// flags no more: zero sensitivity, a near-null direction, an interval too wide or past a bound.
CovarianceOutcome flag_by_covariance(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                                     double inflation, HoldList& hold) {
  const Layout& L = obj.layout();
  CovarianceOutcome cov;
  for (int round = 0; round < 4; ++round) {
    cov = obj.covariance(x, w, hold.held, inflation);
    bool more = false;
    const std::size_t m = cov.indices.size();
    if (m == 0) break;
    const double lmax = cov.eig_values.empty() ? 0 : cov.eig_values.back();
    for (std::size_t a = 0; a < m; ++a) {
      const std::size_t i = cov.indices[a];
      const PhysicsParam* p = L.physics_at(i);
      if (!p) continue;
      if (!(cov.info_diag[a] > 0)) {
        more |= hold.flag(int(i), "the predicted force does not depend on it (zero sensitivity)");
        continue;
      }
      for (std::size_t e = 0; e < m; ++e)
        if (cov.eig_values[e] < kNullRatio * lmax && std::abs(cov.eig_vectors[e][a]) > 0.5) {
          std::string partners;
          for (std::size_t b = 0; b < m; ++b)
            if (b != a && std::abs(cov.eig_vectors[e][b]) > 0.2)
              partners += (partners.empty() ? "" : ", ") + L.name(cov.indices[b]);
          more |= hold.flag(int(i), fmt::format("lies in a near-null direction of the information "
                                           "matrix{}", partners.empty() ? "" : " (with " + partners + ")"));
        }
      const double se = cov.ok ? std::sqrt(std::max(0.0, cov.cov[a * m + a])) : NAN;
      if (cov.ok && se > kMaxLogSE) {
        more |= hold.flag(int(i), fmt::format("95 % interval wider than a factor 10 either way "
                                         "(SE of ln = {:.3g})", se));
      } else if (cov.ok && (x[i] + kZ95 * se > L.upper(i) || x[i] - kZ95 * se < L.lower(i))) {
        const bool up = x[i] + kZ95 * se > L.upper(i);
        more |= hold.flag(int(i), fmt::format("95 % interval reaches past its {} bound ({:.4g}{}): "
                                         "the data give only a {} limit ({} {:.4g})",
                                         up ? "upper" : "lower", std::exp(up ? L.upper(i) : L.lower(i)),
                                         data_schema::unit_suffix(unit_of(p->kind)), up ? "lower" : "upper", up ? ">=" : "<=",
                                         std::exp(up ? x[i] - kZ95 * se : x[i] + kZ95 * se)));
      }
    }
    if (!more) break;
  }
  return cov;
}

std::vector<data_schema::FitParameter> fit_parameters(const Layout& L, const std::vector<double>& x,
                                                      const CovarianceOutcome& cov, const HoldList& hold) {
  std::vector<data_schema::FitParameter> out;
  for (const auto& p : L.physics()) {
    data_schema::FitParameter f;
    f.class_id = p.label;
    f.class_name = p.class_name;
    f.name = to_string(p.kind);
    f.unit = unit_of(p.kind);
    f.fixed = p.index < 0;
    if (f.fixed) {
      f.estimate = p.spec.initial;
      f.held = p.spec.initial;
      f.verdict = "fixed";
    } else if (hold.held[std::size_t(p.index)]) {
      f.identifiable = false;
      f.reason = hold.reason[std::size_t(p.index)];
      f.held = std::exp(x[std::size_t(p.index)]);
    } else {
      const double xi = x[std::size_t(p.index)];
      const double se_log = std::sqrt(std::max(0.0, entry_variance(cov, std::size_t(p.index))));
      f.estimate = std::exp(xi);
      f.held = f.estimate;
      f.std_error = f.estimate * se_log;  // delta method
      f.ci95_low = std::exp(xi - kZ95 * se_log);  // interval on ln θ, mapped back
      f.ci95_high = std::exp(xi + kZ95 * se_log);
    }
    out.push_back(std::move(f));
  }
  return out;
}

std::vector<data_schema::FitNuisance> fit_nuisances(const Layout& L, const std::vector<double>& x,
                                                    const CovarianceOutcome& cov) {
  std::vector<data_schema::FitNuisance> out;
  auto add_to = [&](const std::string& owner, const char* name, const char* unit, int i, double fixed_value) {
    data_schema::FitNuisance n;
    n.recording_id = owner;
    n.name = name;
    n.unit = unit;
    n.fixed = i < 0;
    n.estimate = i < 0 ? fixed_value : x[std::size_t(i)];
    if (i >= 0) {
      const double se = std::sqrt(std::max(0.0, entry_variance(cov, std::size_t(i))));
      n.std_error = se;
      n.ci95_low = n.estimate - kZ95 * se;
      n.ci95_high = n.estimate + kZ95 * se;
    }
    out.push_back(std::move(n));
  };
  for (const auto& r : L.recordings()) {
    auto add = [&](const char* name, const char* unit, int i, double fixed_value) {
      add_to(r.recording_id, name, unit, i, fixed_value);
    };
    add("bias_x", "N", r.bias, 0.0);
    add("bias_y", "N", r.bias < 0 ? -1 : r.bias + 1, 0.0);
    add("bias_z", "N", r.bias < 0 ? -1 : r.bias + 2, 0.0);
    add("lag", "ms", r.lag, r.lag_fixed_ms);
    add("depth_offset", "mm", r.depth, 0.0);
    if (r.torque_bias >= 0) {
      add("torque_bias_x", "N*mm", r.torque_bias, 0.0);
      add("torque_bias_y", "N*mm", r.torque_bias + 1, 0.0);
      add("torque_bias_z", "N*mm", r.torque_bias + 2, 0.0);
    }
    if (r.spindle >= 0) {
      add("spindle_idle", "N*mm", r.spindle, 0.0);
      add("spindle_viscous", "N*mm per 1000 rpm", r.spindle + 1, 0.0);
    }
    if (r.spindle_lag >= 0) add("spindle_lag", "ms", r.spindle_lag, 0.0);
  }
  // A mounting's pose correction, listed under the mounting's name (its sample id).
  static const char* kPose[6] = {"pose_rx", "pose_ry", "pose_rz", "pose_tx", "pose_ty", "pose_tz"};
  for (const auto& m : L.mountings())
    for (int k = 0; k < 6; ++k) add_to(m.name, kPose[k], k < 3 ? "rad" : "mm", m.offset + k, 0.0);
  return out;
}

// Natural-unit covariance of the identifiable free entries (delta method) and correlation.
void covariance_tables(const Layout& L, const std::vector<double>& x, const CovarianceOutcome& cov,
                       UncertaintyReport& rep) {
  if (!cov.ok) return;
  const std::size_t m = cov.indices.size();
  std::vector<double> g(m);
  for (std::size_t a = 0; a < m; ++a) {
    rep.covariance.names.push_back(L.name(cov.indices[a]));
    g[a] = L.dnatural(cov.indices[a], x[cov.indices[a]]);
  }
  rep.correlation.names = rep.covariance.names;
  for (std::size_t a = 0; a < m; ++a)
    for (std::size_t b = 0; b < m; ++b) {
      const double c = cov.cov[a * m + b];
      rep.covariance.matrix.push_back(g[a] * g[b] * c);
      const double den = std::sqrt(cov.cov[a * m + a] * cov.cov[b * m + b]);
      rep.correlation.matrix.push_back(den > 0 ? c / den : (a == b ? 1.0 : 0.0));
    }
}

}  // namespace

UncertaintyReport assess_uncertainty(const Objective& obj, const std::vector<double>& x,
                                     const SampleWeights& w, const Evaluation& at_x,
                                     Flags initial, bool covariance_rules, double inflation) {
  const Layout& L = obj.layout();
  HoldList hold{std::move(initial.held), std::move(initial.reason), covariance_rules};
  hold.held.resize(L.size(), false);
  hold.reason.resize(L.size());
  const std::vector<bool> before_bounds = hold.held;
  const std::vector<std::size_t> at_bounds = flag_at_bounds(obj, x, w, at_x, inflation, hold);
  flag_bound_partners(obj, x, w, inflation, before_bounds, at_bounds, hold);
  const CovarianceOutcome cov = flag_by_covariance(obj, x, w, inflation, hold);
  UncertaintyReport rep;
  rep.residual_variance = cov.residual_variance;
  rep.inflation = inflation;
  rep.parameters = fit_parameters(L, x, cov, hold);
  rep.nuisance = fit_nuisances(L, x, cov);
  rep.channel_information = channel_information(L, cov);
  covariance_tables(L, x, cov, rep);
  rep.held = std::move(hold.held);
  return rep;
}

namespace {

// Pseudo-inverse of the information restricted to `keep` (entries the rows inform), by
// the eigen-decomposition of its unit-diagonal form; eigenvalues below 1e-14 of the
// largest count as null (Ceres's DENSE_SVD covariance uses the same bound).
Eigen::MatrixXd pseudo_inverse(const std::vector<double>& info, std::size_t m, const std::vector<std::size_t>& keep) {
  const Eigen::Index k = Eigen::Index(keep.size());
  Eigen::MatrixXd H(k, k);
  for (Eigen::Index a = 0; a < k; ++a)
    for (Eigen::Index b = 0; b < k; ++b) H(a, b) = info[keep[std::size_t(a)] * m + keep[std::size_t(b)]];
  const Eigen::VectorXd s = H.diagonal().cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd Hn = s.asDiagonal() * H * s.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hn);
  const double lmax = es.eigenvalues().maxCoeff();
  Eigen::VectorXd inv = es.eigenvalues().unaryExpr([&](double l) { return l > 1e-14 * lmax ? 1 / l : 0.0; });
  return s.asDiagonal() * es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose() * s.asDiagonal();
}

}  // namespace

nlohmann::json channel_information(const Layout& L, const CovarianceOutcome& cov) {
  const std::size_t m = cov.indices.size();
  if (!cov.ok || m == 0 || cov.info.size() != m * m || cov.info_force.size() != m * m) return nullptr;
  const double scale = cov.residual_variance * cov.inflation;
  std::vector<std::size_t> all(m), informed;
  for (std::size_t a = 0; a < m; ++a) {
    all[a] = a;
    if (cov.info_force[a * m + a] > 0) informed.push_back(a);  // the moment bias and spindle terms drop out
  }
  const Eigen::MatrixXd Ca = pseudo_inverse(cov.info, m, all) * scale;
  const Eigen::MatrixXd Cf = pseudo_inverse(cov.info_force, m, informed) * scale;
  auto pos = [&](int x_index, const std::vector<std::size_t>& set) -> Eigen::Index {
    for (std::size_t k = 0; k < set.size(); ++k)
      if (int(cov.indices[set[k]]) == x_index) return Eigen::Index(k);
    return -1;
  };
  auto se = [](const Eigen::MatrixXd& C, Eigen::Index k) { return k < 0 ? double(NAN) : std::sqrt(std::max(0.0, C(k, k))); };
  auto factor = [](double s) { return std::isfinite(s) ? std::exp(kZ95 * s) : NAN; };
  auto json_num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  const Channels& ch = L.channels();
  nlohmann::json channels = nlohmann::json::array({"force"});
  if (ch.torque) channels.push_back("torque");
  if (ch.spindle) channels.push_back("spindle");
  nlohmann::json j = {
      {"channels", channels},
      {"method", "linearised at the optimum: SE of ln(theta) from (J^T J)^-1 x residual variance x noise factor, "
                 "over the rows of every channel and over the force rows alone (registration priors in both); "
                 "the profile intervals are the fit's, this compares the information"},
      {"parameters", nlohmann::json::array()},
      {"correlations", nlohmann::json::array()}};
  std::map<std::uint8_t, std::array<int, 2>> c1_alpha;  // label → x index of c1, alpha
  for (const auto& p : L.physics()) {
    if (p.index < 0) continue;
    const double sa = se(Ca, pos(p.index, all)), sf = se(Cf, pos(p.index, informed));
    if (!std::isfinite(sa)) continue;  // held as not identifiable: not in the covariance
    j["parameters"].push_back({{"class_id", p.label}, {"class_name", p.class_name}, {"name", to_string(p.kind)},
                               {"se_log_all", json_num(sa)}, {"se_log_force", json_num(sf)},
                               {"ci95_factor_all", json_num(factor(sa))}, {"ci95_factor_force", json_num(factor(sf))}});
    auto& pair = c1_alpha.try_emplace(p.label, std::array<int, 2>{-1, -1}).first->second;
    if (p.kind == PhysKind::kC1) pair[0] = p.index;
    if (p.kind == PhysKind::kAlpha) pair[1] = p.index;
  }
  auto corr = [&](const Eigen::MatrixXd& C, const std::vector<std::size_t>& set, int i, int k) {
    const Eigen::Index a = pos(i, set), b = pos(k, set);
    if (a < 0 || b < 0 || !(C(a, a) > 0) || !(C(b, b) > 0)) return double(NAN);
    return C(a, b) / std::sqrt(C(a, a) * C(b, b));
  };
  for (const auto& [label, pair] : c1_alpha) {
    if (pair[0] < 0 || pair[1] < 0) continue;
    std::string name;
    for (const auto& p : L.physics())
      if (p.label == label) name = p.class_name;
    j["correlations"].push_back({{"class_id", label}, {"class_name", name}, {"pair", "c1-alpha"},
                                 {"all", json_num(corr(Ca, all, pair[0], pair[1]))},
                                 {"force", json_num(corr(Cf, informed, pair[0], pair[1]))}});
  }
  return j;
}

}  // namespace burrbench::calibration
