// write_report: the report as a short list of stages. The page's parts are written by the
// files report_page.hpp lists, one concern each.
#include "burrbench/analysis/report.hpp"

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "report_page.hpp"
#include "report_wrench.hpp"

namespace burrbench::analysis {
namespace fs = std::filesystem;

namespace {

// Everything the sections read, computed once: the inputs' per-role view, the metrics, the
// criteria's verdicts (and whether they predate the fit), the fit as JSON, section 9's plots.
// The report never runs the model: everything it shows is in its inputs.
ReportPage evaluate(const ReportInputs& inputs, const fs::path& out_html, const ReportOptions& opt,
                    const fs::path& assets_dir) {
  ReportPage page;
  page.opt = &opt;
  page.out_html = out_html;
  page.out_dir = out_html.parent_path().empty() ? fs::path(".") : out_html.parent_path();
  page.assets_dir = assets_dir;
  page.in = report_data(inputs);
  if (page.in.context_of_use.empty()) page.in.context_of_use = opt.context_of_use;  // calibrate states none
  page.title = "burrbench validation report — " + page.in.experiment_name;
  page.rows = compute_metric_rows(page.in);
  ReportSummary& sum = page.sum;
  sum.html = out_html;
  sum.recordings = page.in.recordings.size();
  for (const auto& r : page.in.recordings) sum.samples += r.t_s.size();
  if (inputs.criteria) {
    sum.has_criteria = true;
    sum.criteria = *inputs.criteria;
    sum.results = evaluate_criteria(sum.criteria, page.rows, inputs.criteria_path);
    sum.pass = all_pass(sum.results);
  }
  if (inputs.fit) {
    page.fit = data_schema::fit_to_json(*inputs.fit);
    if (sum.has_criteria) criteria_predate(page.fit, page.in, sum);
  }
  add_residual_plots(page);
  return page;
}

// The page's body, section by section (docs/report.md "The report").
std::string render_body(const ReportPage& page) {
  return header_section(page) + context_section(page) + model_section(page) + verification_section(page) +
         data_section(page) + calibration_section(page) + parameter_section(page) + force_section(page) +
         "<h2 id=\"wrench\">8. Moments and the spindle's load</h2>" + wrench_section(page.in, page.fit_or_null()) +
         residual_section(page) + metrics_section(page) + cross_validation_section(page) +
         removed_bone_section(page) + acceptance_section(page) + limitations_section(page) +
         reproducibility_section(page) + signoff_section();
}

}  // namespace

ReportSummary write_report(const ReportInputs& inputs, const fs::path& out_html, const ReportOptions& opt) {
  const ReportAssets assets = load_assets(opt);  // a missing asset fails before any work
  const ReportPage page = evaluate(inputs, out_html, opt, assets.dir);
  fs::create_directories(page.out_dir);
  const std::string body = render_body(page);
  data_schema::write_file_atomic(out_html, fill_template(assets, page.title, body, plot_data(page)));
  write_side_files(page, inputs);  // residuals.csv, metrics.json, fit.json
  return page.sum;
}

}  // namespace burrbench::analysis
