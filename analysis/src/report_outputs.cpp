// Beside the report: the residuals (residuals.csv), the metrics and the criteria's verdicts
// (metrics.json), and the fit with its metrics (fit.json, unless the caller keeps its own).
#include <cmath>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "report_page.hpp"

namespace burrbench::analysis {

namespace {

json metrics_json(const ReportPage& page) {
  const ReportSummary& sum = page.sum;
  json mj = {{"format", "burrbench.metrics"}, {"format_version", "1.0"}, {"rows", metric_rows_to_json(page.rows)}};
  if (sum.has_criteria) {
    mj["pass"] = sum.pass;
    mj["criteria_predate_fit"] = sum.criteria_predate_fit ? json(*sum.criteria_predate_fit) : json(nullptr);
    mj["criteria"] = json::array();
    for (const auto& r : sum.results)
      mj["criteria"].push_back({{"index", r.index}, {"name", sum.criteria.criteria[r.index].name},
                                {"axis", r.axis},
                                {"value", std::isfinite(r.value) ? json(r.value) : json(nullptr)},
                                {"pass", r.pass}});
  }
  Provenance prov = make_provenance({});  // this run, over the inputs the analysis read
  prov.inputs = page.in.provenance.inputs;
  mj["provenance"] = data_schema::provenance_json(prov);
  return mj;
}

}  // namespace

void write_side_files(const ReportPage& page, const ReportInputs& inputs) {
  if (inputs.fit && page.opt->copy_fit) {
    // The copy beside the report carries the metrics (FitResult::metrics is analysis's
    // to fill); the calibrate directory's own fit.json is an input and stays as it is.
    auto f = *inputs.fit;
    f.metrics = {{"format", "burrbench.metrics"}, {"rows", metric_rows_to_json(page.rows)}};
    data_schema::write_fit(page.out_dir / "fit.json", f);
  }
  write_residuals_csv(page.out_dir / "residuals.csv", page.in);
  data_schema::write_file_atomic(page.out_dir / "metrics.json", metrics_json(page).dump(1) + "\n");
}

}  // namespace burrbench::analysis
