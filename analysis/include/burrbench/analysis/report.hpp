#pragma once
// The self-contained HTML validation report (docs/report.md), written from ReportInputs
// held in memory (the prediction with its context, the fit, the criteria, the verification
// study): `validate` builds them from its replay, `burrbench report DIR` from DIR's
// prediction.h5, fit.json and criteria.toml. Beside the report it writes residuals.csv,
// metrics.json, removed-bone PNGs and a copy of the fit with its metrics.
#include <filesystem>
#include <optional>
#include <utility>
#include <vector>
#include <string>
#include <vector>

#include "burrbench/data_schema/html_text.hpp"
#include "burrbench/analysis/criteria.hpp"
#include "burrbench/analysis/report_data.hpp"
#include "burrbench/data_schema/progress.hpp"

namespace burrbench::analysis {

struct ReportOptions {
  // Folder with template.html, report.js, report.css and node_modules/uplot (npm ci).
  // Empty → default_assets_dir().
  std::filesystem::path assets_dir;
  std::string context_of_use;       // used when the analysis input states none (calibrate)
  Progress* progress = nullptr;     // unused: the report only reads files (kept for callers)
  // The reproducibility section's versions besides burrbench and uPlot (library name →
  // version), given by the caller that links them (apps/: Ceres, libmodbus, OpenCV, HDF5).
  std::vector<std::pair<std::string, std::string>> versions;
  // Write the fit, with its metrics, beside the report (validate keeps the --fit file's
  // exact copy in its folder instead: the prediction's provenance names it by hash).
  bool copy_fit = true;
};

struct ReportSummary {
  std::filesystem::path html;
  bool has_criteria = false;
  bool pass = true;  // all criteria pass (true when there are none)
  std::vector<CriterionResult> results;
  Criteria criteria;
  std::size_t recordings = 0, samples = 0;
  // Were the criteria fixed before the fit? Set when the report has both criteria and a
  // fit: true when the fit recorded (calibrate --criteria) the same file content, false
  // when it recorded other content; unset when the fit recorded none (not established).
  std::optional<bool> criteria_predate_fit;
  std::string criteria_predate_text;  // one sentence, for the report and the console
};

// $BURRBENCH_REPORT_ASSETS if set, else <exe dir>/../share/burrbench/report if it has
// node_modules, else the source tree's analysis/report (path compiled in).
std::filesystem::path default_assets_dir();

ReportSummary write_report(const ReportInputs& inputs, const std::filesystem::path& out_html,
                           const ReportOptions& opt = {});

// Escaping for text from files: HTML text/attributes (data_schema's, shared with the
// study report), and JSON placed in <script>.
using data_schema::html_escape;
std::string json_for_script(const nlohmann::json& j);

}  // namespace burrbench::analysis
