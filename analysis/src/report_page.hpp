#pragma once
// The report's page as its sections read it (ReportPage: built once by write_report's
// evaluate stage, report.cpp) and the writers of its parts, one file per concern:
//   report_assets.cpp        template, styles and scripts; filling the template
//   report_settings_table.cpp  JSON settings as tables
//   report_header.cpp        title, the verdicts beside the gate, at a glance, §1–2
//   report_verification.cpp  §3 solution verification, and its badge at the top
//   report_data_section.cpp  §4 data and their quality, §5 calibration and what was applied
//   report_parameters.cpp    §6 constants, their verdicts, search, correlations, nuisances
//   report_residuals.cpp     §7 force, §9 residuals, §10 metrics, §11 cross-validation
//   report_wrench.cpp        §8 moments and the spindle's load
//   report_bone.cpp          §12 removed bone
//   report_acceptance.cpp    §13 criteria (and whether they predate the fit)
//   report_provenance.cpp    §14 limitations, §15 reproducibility, §16 sign-off
//   report_plot_data.cpp     the JSON report.js draws the plots from
//   report_outputs.cpp       metrics.json, fit.json and residuals.csv beside the report
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/analysis/metric_table.hpp"
#include "burrbench/analysis/report.hpp"
#include "report_html.hpp"

namespace burrbench::analysis {

struct ReportPage {
  const ReportOptions* opt = nullptr;
  std::filesystem::path out_html, out_dir, assets_dir;
  std::string title;
  ReportData in;                 // the sections' view of the inputs (report_data)
  std::vector<MetricRow> rows;   // every metric row (compute_metric_rows)
  ReportSummary sum;             // the criteria's verdicts, returned to the caller
  nlohmann::json fit;            // fit.json as JSON (data_schema::fit_to_json); null without a fit
  // Section 9's histograms and QQ/autocorrelation data, in the order of their plots' ids.
  nlohmann::json histograms = nlohmann::json::array(), diagnostics = nlohmann::json::array();
  const nlohmann::json* fit_or_null() const { return fit.is_null() ? nullptr : &fit; }
};

// report_assets.cpp: the template, the styles and the scripts (uPlot inlined), read before
// any work so a missing one fails first; the page filled into the template.
struct ReportAssets {
  std::filesystem::path dir;
  std::string tmpl, css, js;
};
ReportAssets load_assets(const ReportOptions& opt);
std::string fill_template(const ReportAssets& assets, const std::string& title, const std::string& body,
                          const nlohmann::json& data);

// report_settings_table.cpp
std::string value_html(const nlohmann::json& v);
std::string kv_table(const nlohmann::json& j);

// Sections, in the page's order.
std::string header_section(const ReportPage& page);        // title, verdicts, nav, at a glance
std::string context_section(const ReportPage& page);       // 1
std::string model_section(const ReportPage& page);         // 2
std::string verification_section(const ReportPage& page);  // 3
std::string verification_badge(const ReportData& in, const nlohmann::json* fit);
std::string data_section(const ReportPage& page);          // 4
std::string calibration_section(const ReportPage& page);   // 5
std::string parameter_section(const ReportPage& page);     // 6
std::string force_section(const ReportPage& page);         // 7
std::string residual_section(const ReportPage& page);      // 9
std::string metrics_section(const ReportPage& page);       // 10
std::string cross_validation_section(const ReportPage& page);  // 11
std::string removed_bone_section(const ReportPage& page);  // 12 (writes removed_<i>.png beside the report)
std::string acceptance_section(const ReportPage& page);    // 13
std::string limitations_section(const ReportPage& page);   // 14
std::string reproducibility_section(const ReportPage& page);  // 15
std::string signoff_section();                             // 16

// report_parameters.cpp: a fitted constant (fit.json parameters[i]) limited by
// discretization error, and its verdict as the report states it.
bool limited_by_discretization(const nlohmann::json& p);
std::string constant_verdict(const nlohmann::json& p);

// report_acceptance.cpp: when the fit started (UTC), and whether the criteria predate it.
std::string fit_started_utc(const nlohmann::json& fit);
void criteria_predate(const nlohmann::json& fit, const ReportData& in, ReportSummary& sum);

// report_plot_data.cpp: section 9's plot data (into page.histograms, page.diagnostics),
// and everything report.js draws.
void add_residual_plots(ReportPage& page);
nlohmann::json plot_data(const ReportPage& page);

// report_outputs.cpp: residuals.csv, metrics.json and (opt.copy_fit) fit.json with its metrics.
void write_side_files(const ReportPage& page, const ReportInputs& inputs);

}  // namespace burrbench::analysis
