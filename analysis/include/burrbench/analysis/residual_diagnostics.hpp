#pragma once
// Residual diagnostics for the report's section "Residuals": a normal QQ plot and the
// autocorrelation function per role, pooled over the recordings of that role.
#include <string>

#include <nlohmann/json.hpp>

#include "burrbench/analysis/report_data.hpp"

namespace burrbench::analysis {

// Durbin–Watson outside [2 − 0.5, 2 + 0.5] (lag-1 autocorrelation beyond ±0.25): flagged.
inline constexpr double kDurbinWatsonTolerance = 0.5;

// Standard normal quantile Φ⁻¹(p), p ∈ (0, 1) (Newton on std::erfc; |error| < 1e-12).
double normal_quantile(double p);

// {role, qq: {theory[], sample[]} (standardised residuals of every used sample and axis,
// at most 2000 order statistics), acf: {lag[], r: [x[], y[], z[]]} (lags 0..50 over
// pairs of used samples within a recording)}; null when the role has no used sample.
nlohmann::json residual_diagnostics(const ReportData& in, const std::string& role);

}  // namespace burrbench::analysis
