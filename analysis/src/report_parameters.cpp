// Section 6: the constants — the fit's estimates with their intervals and verdicts (a
// constant limited by discretization error says so in its verdict), the noise model, the
// global search and profiles, the correlation matrix and the nuisances; or, without a fit,
// the fixed constants replayed.
#include <algorithm>
#include <cmath>

#include "report_page.hpp"

namespace burrbench::analysis {

bool limited_by_discretization(const json& p) {
  return p.contains("discretization") && p.at("discretization").is_object() &&
         p.at("discretization").value("limited", false);
}

// The profile's verdict, and "limited by discretization error" beside it when the
// discretization check found it so: the table's "at 2l" column and the verdict agree.
std::string constant_verdict(const json& p) {
  const bool ident = p.value("identifiable", false);
  const std::string verdict = p.value("verdict", std::string(ident ? "identifiable" : "non_identifiable"));
  return limited_by_discretization(p) ? verdict + ", limited by discretization error" : verdict;
}

namespace {

// fit.json is rendered, not re-validated here: its reader (data_schema) validated it
// when calibrate wrote it; a type mismatch still becomes an InputError, never a crash.
// fit.json's discretization check of one parameter: the estimate at 2l and, when limited,
// the interval widened by the discretization error.
std::string discretization_cell(const json& p) {
  if (!p.contains("discretization") || !p.at("discretization").is_object()) return "—";
  const auto& d = p.at("discretization");
  auto n = [&](const char* k) { return d.contains(k) && d.at(k).is_number() ? num(d.at(k).get<double>()) : std::string("—"); };
  if (!d.value("limited", false)) return n("coarse_estimate");
  return n("coarse_estimate") + "<br><b>limited</b>: [" + n("ci95_low") + ", " + n("ci95_high") + "]";
}

// The fit's nuisance estimates that were free (per recording; a pose per sample mounting).
std::string nuisance_table(const json& fit) {
  if (!fit.contains("nuisance") || !fit.at("nuisance").is_array()) return {};
  std::string rows;
  for (const auto& n : fit.at("nuisance")) {
    if (n.value("fixed", false)) continue;
    auto v = [&](const char* k) { return n.contains(k) && n.at(k).is_number() ? num(n.at(k).get<double>()) : std::string("—"); };
    rows += "<tr>" + td(esc(n.value("recording_id", std::string()))) + td(esc(n.value("name", std::string()))) +
            td(esc(n.value("unit", std::string()))) + td(v("estimate"), true) + td(v("std_error"), true) +
            td("[" + v("ci95_low") + ", " + v("ci95_high") + "]", true) + "</tr>";
  }
  if (rows.empty()) return {};
  return "<h3>Nuisance estimates</h3><p class=\"muted\">Per recording (a registration's pose per sample "
         "mounting): what the fit estimated beside the constants.</p><div class=\"scroll\"><table id=\"nuisance-table\">"
         "<tr><th>recording</th><th>nuisance</th><th>unit</th><th>estimate</th><th>std. error</th><th>95 %</th></tr>" +
         rows + "</table></div>";
}

std::string fit_parameter_table(const json* fit) {
  std::string h;
  // The bootstrap's column only when it ran (`--bootstrap N`): else a column of blanks.
  const auto& ps = fit->at("parameters");
  const bool bootstrap = std::any_of(ps.begin(), ps.end(), [](const json& p) {
    return p.contains("bootstrap_ci95_low") && p.at("bootstrap_ci95_low").is_number();
  });
  h += std::string("<table><tr><th>class</th><th>parameter</th><th>unit</th><th>estimate</th>"
                   "<th>held at the optimum</th><th>profile 95 %</th><th>std. error</th><th>covariance 95 %</th>") +
       (bootstrap ? "<th>bootstrap 95 %</th>" : "") + "<th>at 2l (discretization)</th><th>fixed</th><th>verdict</th></tr>";
  for (const auto& p : fit->at("parameters")) {
    const auto n = [&](const char* k) {
      return p.contains(k) && p.at(k).is_number() ? num(p.at(k).get<double>()) : std::string("—");
    };
    // An interval neither of whose ends was computed is one dash, not "[—, —]".
    const auto interval = [&](const char* lo, const char* hi) {
      return n(lo) == "—" && n(hi) == "—" ? std::string("—") : "[" + n(lo) + ", " + n(hi) + "]";
    };
    const bool ident = p.value("identifiable", false);
    // An open side of a profile interval (null) means: not closed within the bounds.
    const auto side = [&](const char* k) {
      return p.contains(k) && p.at(k).is_number() ? num(p.at(k).get<double>()) : std::string("open");
    };
    const std::string prof = p.contains("profile") && p.at("profile").is_array() && !p.at("profile").empty()
                                 ? "[" + side("profile_ci95_low") + ", " + side("profile_ci95_high") + "]"
                                 : std::string("—");
    const std::string verdict = p.value("verdict", std::string(ident ? "identifiable" : "non_identifiable"));
    h += "<tr>" + td(esc(p.value("class_name", std::string()))) + td(esc(p.value("name", std::string()))) +
         td(esc(p.value("unit", std::string()))) + td(n("estimate"), true) + td(n("held"), true) +
         td(prof, true) + td(n("std_error"), true) +
         td(interval("ci95_low", "ci95_high"), true) +
         (bootstrap ? td(interval("bootstrap_ci95_low", "bootstrap_ci95_high"), true) : std::string()) +
         td(discretization_cell(p), true) + td(p.value("fixed", false) ? "yes" : "no") +
         td(ident && verdict != "imprecise" && !limited_by_discretization(p)
                ? esc(verdict)
                : "<b>" + esc(constant_verdict(p)) + "</b>" +
                      (p.value("reason", std::string()).empty() ? std::string()
                                                                : ": " + esc(p.value("reason", std::string()))) +
                      (limited_by_discretization(p) ? " (read the widened interval of the 2l column)" : "")) +
         "</tr>";
  }
  h += "</table>";
  return h;
}

// How the intervals treat correlated residuals (settings.noise_model, absent before it existed).
std::string noise_model_note(const json* fit) {
  std::string h;
  if (fit->contains("settings") && fit->at("settings").contains("noise_model")) {
    const auto& nm = fit->at("settings").at("noise_model");
    const double rho = nm.value("residual_lag1", 0.0), widen = nm.value("interval_widening", 1.0);
    h += nm.value("method", std::string()) == "white"
             ? fmt::format("<p class=\"muted\">Intervals assume white residuals (<code>--white-noise</code>); "
                           "the residuals' lag-1 autocorrelation is {:.3f}.</p>", rho)
             : fmt::format("<p class=\"muted\">Intervals and verdicts allow for correlated residuals: "
                           "lag-1 autocorrelation ρ = {:.3f}, every interval widened ×{:.4g} (AR(1) "
                           "factor (1+ρ)/(1−ρ) on the variance; docs/calibration.md).</p>", rho, widen);
  }
  return h;
}

// Global search (waterfall) and profile likelihoods, drawn by report.js.
std::string search_and_profiles(const json* fit) {
  std::string h;
  if (fit->contains("multistart") && fit->at("multistart").is_array() && !fit->at("multistart").empty())
    h += "<h3>Global search: waterfall</h3><p class=\"muted\">Final cost of every start, sorted "
         "(log scale), marked by how it ended: its local solve converged (a minimum of the cost), "
         "stopped before converging, or it was screened at its pre-fit. A flat first step = the best "
         "optimum found repeatedly; converged starts at distinct levels = local optima; stopped and "
         "screened starts say nothing against the optimum (docs/calibration.md).</p>"
         "<div class=\"plot\" id=\"plot-waterfall\"></div>";
  int k = 0;
  for (const auto& p : fit->at("parameters"))
    if (p.contains("profile") && p.at("profile").is_array() && !p.at("profile").empty()) {
      if (k == 0)
        h += "<h3>Profile likelihoods</h3><p class=\"muted\">Cost rise with every other parameter "
             "re-optimised; the dashed line is the 95 % threshold, the interval is where the curve "
             "lies below it.</p><div class=\"plotrow\">";
      h += fmt::format("<div class=\"plot\" id=\"plot-profile-{}\"></div>", k++);
    }
  if (k > 0) h += "</div>";
  return h;
}

// Columns numbered as the rows (the names would make a 24-column matrix wider than a
// printed page); correlations to two decimals.
std::string correlation_matrix(const json* fit) {
  std::string h;
  if (fit->contains("correlation") && fit->at("correlation").contains("names")) {
    const auto& c = fit->at("correlation");
    const auto& names = c.at("names");
    const auto& mat = c.at("matrix");
    const std::size_t k = names.size();
    h += "<h3>Parameter correlation matrix</h3><p class=\"muted\">Column k is the constant or nuisance of row k.</p>"
         "<div class=\"scroll\"><table id=\"correlation-table\" class=\"matrix\"><tr><th></th>";
    for (std::size_t j = 0; j < k; ++j)
      h += fmt::format("<th title=\"{}\">{}</th>", esc(names[j].get<std::string>()), j + 1);
    h += "</tr>";
    for (std::size_t i = 0; i < k; ++i) {
      h += fmt::format("<tr><th>{} {}</th>", i + 1, esc(names[i].get<std::string>()));
      for (std::size_t j = 0; j < k; ++j) {
        const auto& v = mat.is_array() && mat.size() == k * k ? mat[i * k + j]
                                                               : mat.at(i).at(j);
        const double x = v.is_number() ? v.get<double>() : NAN;
        const int shade = std::isfinite(x) ? int(255 - 120 * std::min(1.0, std::abs(x))) : 255;
        h += fmt::format("<td class=\"num\" style=\"background:rgb(255,{},{})\">{}</td>", shade, shade,
                         std::isfinite(x) ? fmt::format("{:.2f}", x) : std::string("n/a"));
      }
      h += "</tr>";
    }
    h += "</table></div>";
  }
  return h;
}

std::string fixed_parameters(const ReportData& in) {
  std::string h;
  h += "<p>Fixed parameters replayed (no fit in this run): <code>" + esc(in.params_path) +
       "</code>. Intervals and identifiability come from the calibration that produced them.</p>";
  h += "<table><tr><th>label</th><th>class</th><th>α (N/mm²)</th><th>C1 (N/mm²)</th><th>μ</th></tr>";
  for (const auto& p : in.parameters)
    h += "<tr>" + td(std::to_string(p.class_label), true) + td(esc(p.class_name)) +
         td(num(p.alpha_N_per_mm2, 6), true) + td(num(p.c1_N_per_mm2, 6), true) +
         td(num(p.mu, 6), true) + "</tr>";
  h += "</table>";
  return h;
}

}  // namespace

std::string parameter_section(const ReportPage& page) {
  const ReportData& in = page.in;
  const json* fit = page.fit_or_null();
  std::string h = "<h2 id=\"params\">6. Parameters</h2>";
  if (!fit || !fit->contains("parameters")) return h + fixed_parameters(in);
  h += fit_parameter_table(fit) + noise_model_note(fit) + search_and_profiles(fit) + correlation_matrix(fit) +
       nuisance_table(*fit);
  if (in.mode == "validate")
    h += "<p class=\"muted\" id=\"fit-replayed\">The constants replayed here are this fit's (given to validate "
         "with <code>--fit</code>; checked against the parameter set), at its nuisances: the lag, biases, pose "
         "correction and spindle terms it fitted per recording (section 5).</p>";
  return h;
}

}  // namespace burrbench::analysis
