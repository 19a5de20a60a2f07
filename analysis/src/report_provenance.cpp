// Sections 14–16: the limitations, what it takes to reproduce the report (command lines,
// versions, inputs by SHA-256, seeds, when the criteria were recorded and the fit started)
// and the sign-off.
#include <fstream>

#include "burrbench/data_schema/version.hpp"
#include "report_page.hpp"

namespace burrbench::analysis {
namespace fs = std::filesystem;

namespace {

std::string versions_table(const fs::path& assets, const std::vector<std::pair<std::string, std::string>>& given) {
  std::string uplot = "unknown";
  try {
    std::ifstream f(assets / "node_modules/uplot/package.json");
    uplot = json::parse(f).value("version", uplot);
  } catch (const json::exception&) {
  }
  json v = {{"burrbench", software_version()}};
  for (const auto& [name, version] : given) v[name] = version;
  v["uPlot (inlined)"] = uplot;
  return kv_table(v);
}

std::string command_lines(const ReportPage& page) {
  const ReportData& in = page.in;
  const json* fit = page.fit_or_null();
  return "<h3>Command lines</h3><pre>" +
         esc(in.provenance.command_line.empty() ? "(library call)" : in.provenance.command_line) + "\n" +
         esc(invocation().empty() ? "(report: library call)" : invocation()) +
         (fit && in.mode == "validate" && fit->contains("provenance") && fit->at("provenance").is_object()
              ? "\n" + esc(fit->at("provenance").value("command_line", std::string("(calibrate: not recorded)")))
              : std::string()) +
         "</pre>";
}

json seeds_and_settings(const ReportPage& page) {
  const ReportData& in = page.in;
  json seeds = {{"seed", in.seed},
                {"experiment", in.experiment_path},
                {"experiment sha256", in.experiment_sha256},
                {"params", in.params_path},
                {"params sha256", in.params_sha256},
                {"criteria", in.criteria_path},
                {"criteria sha256", in.criteria_sha256}};
  if (const json* fit = page.fit_or_null()) {
    const json& st = fit->contains("settings") ? fit->at("settings") : json::object();
    const json rec = st.contains("criteria") && st.at("criteria").is_object() ? st.at("criteria") : json::object();
    seeds["criteria sha256 recorded by the fit"] = rec.value("sha256", std::string("none"));
    seeds["criteria recorded by the fit (UTC)"] = rec.value("recorded_utc", std::string("none"));
    seeds["fit started (UTC)"] = fit_started_utc(*fit);
  }
  seeds["prediction created"] = in.provenance.created_utc;
  return seeds;
}

}  // namespace

std::string limitations_section(const ReportPage& page) {
  std::string b = "<h2 id=\"limits\">14. Limitations</h2><ul>";
  for (const auto& l : page.in.limitations) b += "<li>" + esc(l) + "</li>";
  return b + "<li>Metrics use only samples marked used (buried or excluded samples and spans outside used "
             "segments are left out).</li></ul>";
}

std::string reproducibility_section(const ReportPage& page) {
  std::string b = "<h2 id=\"repro\">15. Reproducibility</h2>" + command_lines(page);
  b += "<h3>Versions</h3>" + versions_table(page.assets_dir, page.opt->versions);
  b += "<h3>Inputs</h3><table><tr><th>file</th><th>SHA-256</th></tr>";
  for (const auto& f : page.in.provenance.inputs)
    b += "<tr>" + td("<code>" + esc(f.path) + "</code>") + td("<span class=\"hash\">" + esc(f.sha256) + "</span>") + "</tr>";
  return b + "</table><h3>Seeds and settings</h3>" + kv_table(seeds_and_settings(page));
}

// Left blank for the people who answer for the release (print, sign, date).
std::string signoff_section() {
  return "<h2 id=\"signoff\">16. Sign-off</h2><p class=\"muted\">This report, generated " +
         esc(make_provenance({}).created_utc) +
         " from the inputs listed in section 15 (SHA-256), is reviewed and accepted by:</p>"
         "<table class=\"signoff\" id=\"signoff-table\"><tr><th>role</th><th>name</th><th>signature</th><th>date</th></tr>"
         "<tr><td>prepared by</td><td></td><td></td><td></td></tr>"
         "<tr><td>reviewed by</td><td></td><td></td><td></td></tr>"
         "<tr><td>approved for release by</td><td></td><td></td><td></td></tr></table>";
}

}  // namespace burrbench::analysis
