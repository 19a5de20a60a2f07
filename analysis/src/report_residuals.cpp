// Sections 7, 9, 10 and 11: the measured against the predicted force, the residuals, the
// validation metrics and the cross-validation — the model's error as the data show it.
#include <algorithm>
#include <cmath>

#include "burrbench/analysis/residual_diagnostics.hpp"
#include "report_page.hpp"

namespace burrbench::analysis {

namespace {

// The rows whose Durbin–Watson statistic flags autocorrelated residuals, in words.
std::string durbin_watson_note(const std::vector<MetricRow>& rows) {
  std::string list;
  std::size_t n = 0;
  for (const auto& r : rows)
    if (r.segment == "all" && std::abs(r.m.durbin_watson - 2) > kDurbinWatsonTolerance) {
      if (n++ < 12)
        list += "<li>" + esc(r.recording_id.empty() ? "all " + r.role : r.recording_id) + ", " + esc(r.axis) +
                fmt::format(": DW = {} (lag-1 r = {})</li>", num(r.m.durbin_watson, 3), num(r.m.resid_lag1_autocorr, 3));
    }
  if (n == 0)
    return fmt::format("<p class=\"muted\" id=\"dw-note\">Durbin–Watson within 2 ± {} everywhere: no sign of "
                       "autocorrelated residuals.</p>", kDurbinWatsonTolerance);
  return fmt::format("<div id=\"dw-note\"><p><span class=\"verdict fail\">AUTOCORRELATED RESIDUALS</span> "
                     "Durbin–Watson outside 2 ± {} ({} rows, whole recordings): the residuals are not white, so "
                     "independent-noise intervals would be too narrow and the model misses some structure "
                     "in time (lag, dynamics).</p><ul>{}</ul></div>",
                     kDurbinWatsonTolerance, n, list + (n > 12 ? "<li>…</li>" : ""));
}

std::string metric_table_html(const std::vector<MetricRow>& rows, bool pooled) {
  std::string h =
      "<div class=\"scroll\"><table><tr><th>data</th><th>segment</th><th>axis</th><th>n</th>"
      "<th>RMSE (N)</th><th>NRMSE</th><th>R²</th><th>Theil U2</th><th>SG M</th><th>SG P</th>"
      "<th>SG C</th><th>peak meas. (N)</th><th>peak err. (N)</th><th>peak err. rel.</th>"
      "<th>resid. lag-1 r</th><th>Durbin–Watson</th></tr>";
  for (const auto& r : rows) {
    if (r.recording_id.empty() != pooled) continue;
    const auto& m = r.m;
    h += "<tr>" + td(esc(pooled ? "all " + r.role : r.recording_id + " (" + r.role + ")")) +
         td(esc(r.segment)) + td(esc(r.axis)) + td(std::to_string(m.n), true) +
         td(num(m.rmse_N), true) + td(num(m.nrmse), true) + td(num(m.r2), true) +
         td(num(m.theil_u2), true) + td(num(m.sg_magnitude), true) + td(num(m.sg_phase), true) +
         td(num(m.sg_combined), true) + td(num(m.peak_measured_N), true) +
         td(num(m.peak_error_N), true) + td(num(m.peak_error_rel), true) +
         td(num(m.resid_lag1_autocorr), true) +
         (std::abs(m.durbin_watson - 2) > kDurbinWatsonTolerance
              ? "<td class=\"num flag\" title=\"autocorrelated residuals\">⚑ " + num(m.durbin_watson) + "</td>"
              : td(num(m.durbin_watson), true)) +
         "</tr>";
  }
  return h + "</table></div>";
}

std::string cross_validation_tables(const std::vector<MetricRow>& rows, const json* fit) {
  std::string h =
      "<p>Pooled over all used samples of each role; calibration data and held-out "
      "(validate) data are kept apart.</p><table><tr><th>data</th><th>axis</th><th>n</th>"
      "<th>RMSE (N)</th><th>NRMSE</th><th>R²</th><th>SG C</th></tr>";
  for (const auto& r : rows)
    if (r.recording_id.empty() && r.segment == "all")
      h += "<tr>" + td(esc(r.role)) + td(esc(r.axis)) + td(std::to_string(r.m.n), true) +
           td(num(r.m.rmse_N), true) + td(num(r.m.nrmse), true) + td(num(r.m.r2), true) +
           td(num(r.m.sg_combined), true) + "</tr>";
  h += "</table>";
  if (fit && fit->contains("cross_validation") && !fit->at("cross_validation").empty()) {
    // Each fold: the recording left out, how the refit without it predicts it and its own
    // data (x, y, z together), the constants it refitted, how its solve ended.
    const json& folds = fit->at("cross_validation");
    std::vector<std::string> names;  // the refitted constants, in the order the folds give them
    for (const auto& cv : folds)
      if (cv.contains("metrics") && cv.at("metrics").contains("parameters") && cv.at("metrics").at("parameters").is_object())
        for (const auto& [k, _] : cv.at("metrics").at("parameters").items())
          if (std::find(names.begin(), names.end(), k) == names.end()) names.push_back(k);
    h += "<h3>Leave-one-out cross-validation (from the fit)</h3><p class=\"muted\">Each recording left out in "
         "turn: the constants refitted on the others (from the optimum), the left-out recording predicted with "
         "them; RMSE and R² over x, y, z together.</p><table><tr><th>held out</th><th>held-out n</th>"
         "<th>held-out RMSE (N)</th><th>held-out R²</th><th>refit n</th><th>refit RMSE (N)</th><th>refit R²</th>";
    for (const auto& n : names) h += "<th>" + esc(n) + "</th>";
    h += "<th>refit ended</th></tr>";
    const json none;
    for (const auto& cv : folds) {
      const json& m = cv.contains("metrics") && cv.at("metrics").is_object() ? cv.at("metrics") : none;
      auto at = [&](const char* group, const char* key) -> const json& {
        return m.is_object() && m.contains(group) && m.at(group).is_object() && m.at(group).contains(key)
                   ? m.at(group).at(key) : none;
      };
      auto cell = [&](const json& v) { return td(value_html(v), v.is_number()); };
      h += "<tr>" + td(esc(cv.value("held_out", std::string()))) + cell(at("held_out", "samples")) +
           cell(at("held_out", "rmse_xyz_N")) + cell(at("held_out", "r2_xyz")) + cell(at("calibration", "samples")) +
           cell(at("calibration", "rmse_xyz_N")) + cell(at("calibration", "r2_xyz"));
      for (const auto& n : names) h += cell(at("parameters", n.c_str()));
      h += td(esc(m.is_object() ? m.value("termination", std::string("—")) : std::string("—"))) + "</tr>";
    }
    h += "</table>";
  }
  return h;
}

}  // namespace

std::string force_section(const ReportPage& page) {
  std::string b =
      "<h2 id=\"force\">7. Measured vs predicted force</h2><p class=\"muted\">Sensor frame. "
      "With a fit, the shaded band around each predicted axis is its 95 % band from the fitted constants' "
      "covariance alone (delta method through the forward sensitivities: 1.96·√(gᵀCg), g = ∂F/∂ln θ); "
      "the sensor noise and the nuisances are not in it. "
      "Drag to zoom (x, or a box), double-click to reset; click a legend entry to hide a series. "
      "Plots show every k-th sample when a recording is long; predictions.csv has all.</p>";
  for (std::size_t i = 0; i < page.in.recordings.size(); ++i)
    b += fmt::format("<h3>{}</h3><div class=\"plot\" id=\"plot-force-{}\"></div>", esc(page.in.recordings[i].id), i);
  return b;
}

// The plots' ids follow page.histograms and page.diagnostics (add_residual_plots).
std::string residual_section(const ReportPage& page) {
  std::string b = "<h2 id=\"resid\">9. Residuals</h2><p class=\"muted\">e = measured − predicted.</p>";
  for (std::size_t i = 0; i < page.in.recordings.size(); ++i)
    b += fmt::format("<h3>{}</h3><div class=\"plotrow\"><div class=\"plot\" id=\"plot-resid-t-{}\"></div>"
                     "<div class=\"plot\" id=\"plot-resid-p-{}\"></div></div>",
                     esc(page.in.recordings[i].id), i, i);
  for (std::size_t i = 0; i < page.histograms.size(); ++i)
    b += fmt::format("<div class=\"plot\" id=\"plot-hist-{}\"></div>", i);
  if (!page.diagnostics.empty())
    b += "<h3>Normality and independence</h3><p class=\"muted\">QQ plot: standardised residuals "
         "(every used sample and axis) against the normal quantiles; on the diagonal when the noise is "
         "Gaussian, heavy tails bend away at the ends. Autocorrelation: r(k) per axis over pairs of used "
         "samples k apart within a recording; white residuals stay near 0 beyond lag 0 (±1.96/√n dashed). "
         "The fit's intervals assume white residuals unless widened for r(1) (section 6).</p>";
  for (std::size_t i = 0; i < page.diagnostics.size(); ++i)
    b += fmt::format("<div class=\"plotrow\"><div class=\"plot\" id=\"plot-qq-{0}\"></div>"
                     "<div class=\"plot\" id=\"plot-acf-{0}\"></div></div>", i);
  return b;
}

std::string metrics_section(const ReportPage& page) {
  return "<h2 id=\"metrics\">10. Validation metrics</h2><p class=\"muted\">NRMSE is normalised by the "
         "measured range (max − min) of the same series; R² = 1 − SSE/SST; Theil U2 = √(Σe²/Σm²); "
         "SG = Sprague–Geers; definitions in docs/report.md. Only used samples count.</p>"
         "<h3>Per recording</h3>" + metric_table_html(page.rows, false) + "<h3>Pooled by role</h3>" +
         metric_table_html(page.rows, true) + durbin_watson_note(page.rows);
}

std::string cross_validation_section(const ReportPage& page) {
  return "<h2 id=\"cv\">11. Cross-validation</h2>" + cross_validation_tables(page.rows, page.fit_or_null());
}

}  // namespace burrbench::analysis
