// The top of the report — its title, the verdicts a reviewer must see first (the gate, the
// verification beside it, the constants that are not plainly identifiable), the contents
// and the figures at a glance — and sections 1 (context of use) and 2 (model and version).
#include "burrbench/data_schema/version.hpp"
#include "report_page.hpp"

namespace burrbench::analysis {

namespace {

// The top of the report: the gate, the verification beside it, and the constants that are
// not plainly identifiable (limited by discretization, imprecise, not identifiable), so a
// green gate cannot hide a red finding further down.
std::string verdicts_block(const ReportData& in, const ReportSummary& sum, const json* fit) {
  std::string h = "<div id=\"verdicts\"><p>";
  h += sum.has_criteria ? (sum.pass ? "<span class=\"verdict pass\" id=\"verdict\">ACCEPTANCE CRITERIA: PASS</span>"
                                    : "<span class=\"verdict fail\" id=\"verdict\">ACCEPTANCE CRITERIA: FAIL</span>")
                        : "<span class=\"verdict none\" id=\"verdict\">No acceptance criteria</span>";
  h += " " + verification_badge(in, fit);
  const json& v = in.verification;
  if (v.is_object() && !v.value("verdict", std::string()).empty())
    h += " <span class=\"muted\">" + esc(v.value("verdict", std::string())) + " (section 3)</span>";
  h += "</p>";
  if (fit && fit->contains("parameters")) {
    std::vector<std::string> flagged;
    std::size_t free = 0;
    for (const auto& p : fit->at("parameters")) {
      if (p.value("fixed", false)) continue;
      ++free;
      const std::string verdict = constant_verdict(p);
      if (verdict != "identifiable")
        flagged.push_back("<b>" + esc(p.value("class_name", std::string()) + " " + p.value("name", std::string())) +
                          "</b>: " + esc(verdict));
    }
    h += flagged.empty()
             ? fmt::format("<p id=\"constants-verdict\"><span class=\"verdict pass\">CONSTANTS</span> all {} "
                           "identifiable, none limited by discretization error (section 6).</p>", free)
             : fmt::format("<p id=\"constants-verdict\"><span class=\"verdict fail\">CONSTANTS</span> {} of {} not "
                           "plainly identifiable (section 6): {}.</p>", flagged.size(), free, fmt::join(flagged, "; "));
  }
  return h + "</div>";
}

std::string navigation() {
  return "<nav><a href=\"#glance\">At a glance</a><a href=\"#cou\">Context</a><a href=\"#model\">Model</a>"
         "<a href=\"#verif\">Verification</a><a href=\"#data\">Data</a><a href=\"#calib\">Calibration</a>"
         "<a href=\"#params\">Parameters</a><a href=\"#force\">Force</a><a href=\"#wrench\">Moments</a>"
         "<a href=\"#resid\">Residuals</a><a href=\"#metrics\">Metrics</a><a href=\"#cv\">Cross-validation</a>"
         "<a href=\"#bone\">Removed bone</a><a href=\"#accept\">Acceptance</a><a href=\"#limits\">Limitations</a>"
         "<a href=\"#repro\">Reproducibility</a><a href=\"#signoff\">Sign-off</a></nav>";
}

// Pooled |F| metrics per role, and the overview plot of one held-out recording.
std::string at_a_glance(const ReportPage& page) {
  std::string b = "<h2 id=\"glance\">At a glance</h2><table><tr><th>data</th><th>n</th><th>RMSE |F| (N)</th>"
                  "<th>NRMSE |F|</th><th>R² |F|</th><th>Sprague–Geers C |F|</th></tr>";
  for (const auto& r : page.rows)
    if (r.recording_id.empty() && r.segment == "all" && r.axis == std::string("magnitude"))
      b += "<tr>" + td(esc(r.role == "validate" ? "held-out (validate)" : "calibration")) +
           td(std::to_string(r.m.n), true) + td(num(r.m.rmse_N), true) + td(num(r.m.nrmse), true) +
           td(num(r.m.r2), true) + td(num(r.m.sg_combined), true) + "</tr>";
  b += "</table>";
  if (!page.in.recordings.empty()) b += "<div class=\"plot\" id=\"plot-overview\"></div>";
  return b;
}

}  // namespace

std::string header_section(const ReportPage& page) {
  return "<h1>" + esc(page.title) + "</h1>" +
         fmt::format("<p class=\"muted\">Mode: {} · generated {} by {}</p>", esc(page.in.mode),
                     esc(make_provenance({}).created_utc), esc(software_version())) +
         verdicts_block(page.in, page.sum, page.fit_or_null()) + navigation() + at_a_glance(page);
}

std::string context_section(const ReportPage& page) {
  const ReportData& in = page.in;
  const ReportSummary& sum = page.sum;
  std::string b = "<h2 id=\"cou\">1. Context of use</h2>";
  if (sum.has_criteria && sum.criteria.context) {
    const auto& c = *sum.criteria.context;
    b += "<table id=\"cou-table\"><tr><th>question of interest</th>" + td(esc(c.question_of_interest)) +
         "</tr><tr><th>context of use</th>" + td(esc(c.context_of_use)) + "</tr><tr><th>model influence</th>" +
         td(esc(c.model_influence)) + "</tr><tr><th>decision consequence</th>" + td(esc(c.decision_consequence)) +
         "</tr><tr><th>model risk</th>" +
         td("<b>" + esc(c.model_risk) + "</b>" +
            (c.risk_derived ? " (from influence and consequence, ASME V&amp;V 40 risk map)" : "")) +
         "</tr></table><p class=\"muted\">From the criteria's [context] table (" + esc(in.criteria_path) +
         "): fixed with the criteria.</p>";
  }
  b += "<p>" + esc(in.context_of_use.empty() ? "(not stated)" : in.context_of_use) + "</p>";
  if (!in.experiment_description.empty()) b += "<p>" + esc(in.experiment_description) + "</p>";
  return b;
}

std::string model_section(const ReportPage& page) {
  json model_info = {{"software", software_version()}};
  model_info.update(page.in.model);
  return "<h2 id=\"model\">2. Model and version</h2>" + kv_table(model_info);
}

}  // namespace burrbench::analysis
