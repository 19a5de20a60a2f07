#pragma once
// Standard errors, 95 % intervals and correlations of a fit, and the rules that declare a
// parameter NOT identifiable from the data (then it gets a reason and no number).
//
// Rules, checked in this order for every free physics parameter:
//  1. its class is never in contact in the used samples;
//  2. (α only) no bone of its class was removed in the replay: α has no effect;
//  3. the estimate sits at a bound (within 1 % in log space); and a constant that the
//     linearised fit with the bounds the data push against lifted moves by more than its
//     own interval (step_past_bounds) is held too;
//  4. the information matrix (JᵀJ, scaled to unit diagonal) has an eigenvalue below
//     1e-8 of the largest whose eigenvector loads on it (|v| > 0.5): a near-null direction;
//  5. its 95 % interval is wider than ×/÷ 10 (SE of ln θ > ln 10 / 1.96), or reaches
//     past a bound (the data then give only a one-sided limit).
// Flagged parameters are held at their estimate and the covariance of the rest is
// recomputed (conditional on them), so one undetermined constant does not blur the others.
#include <string>
#include <vector>

#include "burrbench/calibration/objective.hpp"
#include "burrbench/data_schema/fit_result.hpp"

namespace burrbench::calibration {

struct UncertaintyReport {
  std::vector<data_schema::FitParameter> parameters;  // physics, layout order
  std::vector<data_schema::FitNuisance> nuisance;
  data_schema::NamedMatrix covariance, correlation;   // identifiable free entries, natural units
  double residual_variance = 1;
  double inflation = 1;                               // noise-model factor on the covariance
  std::vector<bool> held;                             // x entries held as not identifiable
  // With channels besides the force: what they add (fit.json "channel_information").
  nlohmann::json channel_information;
};

// The linearised comparison at the optimum of what the channels besides the force add:
// per free physics parameter the SE of ln θ from (JᵀJ)⁻¹ over every row and over the
// force rows alone (same residual-variance and noise-model scale), the 95 % factors
// exp(1.96·SE), and per class the C1–α correlation both ways. Null when the fit used the
// force alone or the covariance failed.
nlohmann::json channel_information(const Layout& L, const CovarianceOutcome& cov);

// Parameters flagged before any interval is computed, with their reasons (x order).
struct Flags {
  std::vector<bool> held;
  std::vector<std::string> reason;
};

// Rules 1 and 2 (no contact; α without removed bone, or whose erosion changes no used
// sample's force by σ against no erosion): checks of the data, not of the cost.
Flags contact_checks(const Objective& obj, const std::vector<double>& x, const SampleWeights& w,
                     const Evaluation& at_x);

// An x entry at a bound, and which: +1 upper, −1 lower.
struct AtBound {
  std::size_t entry = 0;
  int side = 0;
};

// The entries at a bound: the physics entries `physics` (each at one of its bounds) and
// every nuisance at its bound (nuisances_at_bounds), with their sides.
std::vector<AtBound> held_at_bounds(const Layout& L, const std::vector<double>& x,
                                    const std::vector<std::size_t>& physics);

// Entries at a bound stop where the data would not let them stop when the cost's gradient
// points out of the box: they want a value beyond. Every entry that moves with them was
// fitted against them held there, and its interval (a profile re-optimises inside the
// bounds) holds them there too. The linearised fit with those bounds lifted is the Newton
// step from the gradient of the entries pulled outwards alone (the others are stationary at
// the optimum): Δx = −H⁻¹·g_B = −Σ·g_B / (residual variance × inflation). Returns Δx per x
// entry (size n, 0 for entries the covariance lacks), empty when the covariance failed or
// no entry at a bound is pulled outwards; `pulled` gets those that are.
std::vector<double> step_past_bounds(const CovarianceOutcome& cov, const std::vector<AtBound>& at, std::size_t n,
                                     std::vector<AtBound>* pulled = nullptr);
// The variance of entry i with the entries `held` held (Gaussian conditioning, the Schur
// complement Σ_ii − Σ_iB Σ_BB⁻¹ Σ_Bi), from a covariance with them free; NaN when i is not
// covered. The covariance rules weigh step_past_bounds against 1.96·√ of it.
double conditional_variance(const CovarianceOutcome& cov, std::size_t i, const std::vector<std::size_t>& held);
// The reason given to physics entry i, which that step moves by shift_log in ln θ against a
// 95 % half-width of half_log, for the entries `pulled` (physics or nuisances, at the sides
// held_at_bounds gave them).
std::string bound_partner_reason(const Layout& L, const std::vector<double>& x, std::size_t i,
                                 const std::vector<AtBound>& pulled, double shift_log, double half_log);

// `initial`: parameters already flagged (held, with reasons), e.g. by contact_checks or by
// their profiles. `covariance_rules`: also apply the α slice check and rules 3–5 (used
// when no profiles are computed); otherwise only the covariance of the rest is computed.
// `inflation`: the noise model's factor on the covariance and the α slice check's
// threshold (ar1_inflation; 1 = white residuals).
UncertaintyReport assess_uncertainty(const Objective& obj, const std::vector<double>& x,
                                     const SampleWeights& w, const Evaluation& at_x,
                                     Flags initial, bool covariance_rules = true,
                                     double inflation = 1);
// Every rule, 1–5 (no profiles).
inline UncertaintyReport assess_uncertainty(const Objective& obj, const std::vector<double>& x,
                                            const SampleWeights& w, const Evaluation& at_x) {
  return assess_uncertainty(obj, x, w, at_x, contact_checks(obj, x, w, at_x), true);
}

}  // namespace burrbench::calibration
