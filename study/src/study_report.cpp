#include "burrbench/study/study_report.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/html_text.hpp"

namespace burrbench::study {
namespace ds = data_schema;
using nlohmann::json;

namespace {

json number(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

std::string text(std::string_view s) { return ds::html_escape(s); }

std::string g4(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : "—"; }

// One forest plot as inline SVG on a log axis: each specimen's estimate with its 95 %
// interval, the population mean as a diamond spanning its interval.
std::string forest_svg(const PopulationEstimate& p) {
  std::vector<double> xs;
  for (const auto& s : p.used) xs.insert(xs.end(), {s.ci95_low, s.ci95_high, s.estimate});
  if (p.estimable()) xs.insert(xs.end(), {p.ci95_low, p.ci95_high});
  xs.erase(std::remove_if(xs.begin(), xs.end(), [](double v) { return !(v > 0) || !std::isfinite(v); }), xs.end());
  if (xs.empty()) return "<p>No specimen gives an estimate.</p>";
  double lo = std::log(*std::min_element(xs.begin(), xs.end())), hi = std::log(*std::max_element(xs.begin(), xs.end()));
  const double pad = std::max(0.05 * (hi - lo), 1e-3);
  lo -= pad;
  hi += pad;
  const double W = 640, left = 120, right = 20, row = 22;
  const double H = row * double(p.used.size() + 2) + 30;
  auto X = [&](double v) { return left + (W - left - right) * (std::log(v) - lo) / (hi - lo); };
  std::string svg = fmt::format(R"(<svg class="forest" width="{}" height="{}" viewBox="0 0 {} {}" role="img" aria-label="forest plot of {}.{}">)",
                                W, H, W, H, text(p.class_name), text(p.parameter));
  double y = 20;
  for (const auto& s : p.used) {
    svg += fmt::format(R"(<text x="4" y="{:.1f}" font-size="12">{}</text>)", y + 4, text(s.specimen));
    svg += fmt::format(R"(<line x1="{:.1f}" x2="{:.1f}" y1="{:.1f}" y2="{:.1f}" stroke="#333"/>)", X(s.ci95_low),
                       X(s.ci95_high), y, y);
    svg += fmt::format(R"(<rect class="specimen" x="{:.1f}" y="{:.1f}" width="6" height="6" fill="#1f6fb2"/>)",
                       X(s.estimate) - 3, y - 3);
    y += row;
  }
  if (p.estimable()) {
    const double m = X(p.mean), a = X(p.ci95_low), b = X(p.ci95_high);
    svg += fmt::format(R"(<text x="4" y="{:.1f}" font-size="12" font-weight="bold">population</text>)", y + 4);
    svg += fmt::format(R"(<polygon class="population" points="{:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f} {:.1f},{:.1f}" fill="#c0392b"/>)",
                       a, y, m, y - 6, b, y, m, y + 6);
    svg += fmt::format(R"(<line x1="{:.1f}" x2="{:.1f}" y1="10" y2="{:.1f}" stroke="#c0392b" stroke-dasharray="3,3"/>)", m, m, y + 8);
  }
  // The axis: its two end values (natural units on a log scale) and the unit.
  const double ya = H - 12;
  svg += fmt::format(R"(<line x1="{}" x2="{}" y1="{:.1f}" y2="{:.1f}" stroke="#999"/>)", left, W - right, ya - 10, ya - 10);
  for (double v : {std::exp(lo + pad), std::exp(hi - pad)})
    svg += fmt::format(R"(<text x="{:.1f}" y="{:.1f}" font-size="11" text-anchor="middle">{}</text>)", X(v), ya + 2, g4(v));
  svg += fmt::format(R"(<text x="4" y="{:.1f}" font-size="11">{}, log axis</text>)", ya + 2, text(p.unit));
  svg += "</svg>";
  return svg;
}

}  // namespace

json population_json(const StudyManifest& study, const std::vector<PopulationEstimate>& pop,
                     const std::vector<SpecimenRow>& specimens) {
  json j;
  j["format"] = kPopulationFormat;
  j["format_version"] = ds::version_string(1, 0);
  j["study"] = {{"name", study.name}, {"path", study.file.string()}};
  j["method"] = "random effects on ln θ: DerSimonian–Laird τ², Hartung–Knapp–Sidik–Jonkman 95 % interval "
                "(t, k − 1 dof; never narrower than DL's); mean = exp(pooled ln θ), the geometric mean";
  j["estimates"] = json::array();
  for (const auto& p : pop) {
    json e = {{"class_name", p.class_name}, {"parameter", p.parameter}, {"unit", p.unit}, {"k", p.k},
              {"mean", number(p.mean)}, {"ci95_low", number(p.ci95_low)}, {"ci95_high", number(p.ci95_high)},
              {"ln_mean", number(p.ln_mean)}, {"ln_se", number(p.ln_se)}, {"tau_ln", number(p.tau_ln)},
              {"q", number(p.q)}, {"i2", number(p.i2)}, {"specimens", json::array()}, {"excluded", json::array()}};
    for (const auto& s : p.used)
      e["specimens"].push_back({{"id", s.specimen}, {"estimate", s.estimate}, {"ln_se", s.ln_se},
                                {"ci95_low", number(s.ci95_low)}, {"ci95_high", number(s.ci95_high)},
                                {"se_source", s.se_source}});
    for (const auto& [id, why] : p.excluded) e["excluded"].push_back({{"id", id}, {"reason", why}});
    j["estimates"].push_back(std::move(e));
  }
  j["specimen_gates"] = json::object();
  for (const auto& s : specimens) j["specimen_gates"][s.id] = s.gate.empty() ? json(nullptr) : json(s.gate);
  return j;
}

ds::ParameterSet population_params(const std::vector<PopulationEstimate>& pop, const ds::FitResult& first) {
  ds::ParameterSet ps = ds::parameter_set_from(first, "fit.json");
  ps.not_identifiable.clear();
  for (const auto& p : pop)
    for (auto& [label, c] : ps.classes) {
      if (c.name != p.class_name) continue;
      double* v = p.parameter == "alpha" ? &c.alpha_N_per_mm2 : p.parameter == "c1" ? &c.c1_N_per_mm2
                                                               : p.parameter == "mu" ? &c.mu : nullptr;
      if (!v) continue;
      if (p.estimable()) *v = p.mean;
      else ps.not_identifiable[label].push_back(p.parameter);
    }
  ps.notes = "Population constants: random-effects geometric means across the study's specimens "
             "(burrbench study summarize; population.json has the intervals and the between-specimen SD).";
  return ps;
}

std::string study_report_html(const StudyManifest& study, const std::vector<PopulationEstimate>& pop,
                              const std::vector<SpecimenRow>& specimens) {
  std::string h = "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>Study: " + text(study.name) +
                  "</title><style>body{font:14px/1.4 system-ui,sans-serif;margin:2em;max-width:1000px}"
                  "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
                  "td:first-child,th:first-child,td.text{text-align:left}.pass{color:#1a7f37}.fail{color:#b42318}"
                  "@media print{a{color:inherit}}</style></head><body>";
  h += "<h1>Study: " + text(study.name) + "</h1><p>" + text(study.description) + "</p>";
  h += "<p>Study manifest: <code>" + text(study.file.string()) + "</code>. " + std::to_string(specimens.size()) +
       " specimens.</p>";
  h += "<h2 id=\"population\">Population estimates</h2><p>Random effects on ln θ per class and constant: "
       "DerSimonian–Laird between-specimen variance, Hartung–Knapp–Sidik–Jonkman 95 % interval (t with k − 1 "
       "degrees of freedom). The mean is exp(pooled ln θ), the population's geometric mean; τ is the "
       "between-specimen SD of ln θ (×e^τ as a factor). Specimens whose fit calls the constant not identifiable "
       "are excluded and listed.</p><table id=\"population-table\"><tr><th>class</th><th>constant</th><th>unit</th>"
       "<th>k</th><th>mean</th><th>95 % low</th><th>95 % high</th><th>τ (ln)</th><th>I²</th><th>excluded</th></tr>";
  for (const auto& p : pop) {
    std::string ex;
    for (const auto& [id, why] : p.excluded) ex += (ex.empty() ? "" : "; ") + text(id) + ": " + text(why);
    h += fmt::format("<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td>"
                     "<td>{}</td><td class=\"text\">{}</td></tr>",
                     text(p.class_name), text(p.parameter), text(p.unit), p.k, g4(p.mean), g4(p.ci95_low),
                     g4(p.ci95_high), p.estimable() ? g4(p.tau_ln) : "—", p.estimable() ? fmt::format("{:.0f} %", 100 * p.i2) : "—",
                     ex.empty() ? "none" : ex);
  }
  h += "</table><h2 id=\"forest\">Forest plots</h2>";
  for (const auto& p : pop)
    h += "<h3>" + text(p.class_name) + " " + text(p.parameter) + " (" + text(p.unit) + ")</h3>" + forest_svg(p);
  h += "<h2 id=\"specimens\">Specimens</h2><table id=\"specimen-table\"><tr><th>specimen</th><th>experiment</th>"
       "<th>release gate</th><th>fit</th><th>report</th></tr>";
  for (const auto& s : specimens) {
    const std::string gate = s.gate.empty() ? "not validated"
                                            : "<span class=\"" + std::string(s.gate == "PASS" ? "pass" : "fail") +
                                                  "\">" + s.gate + "</span>";
    auto link = [](const std::string& href, const char* label) {
      return href.empty() ? std::string("—") : "<a href=\"" + text(href) + "\">" + label + "</a>";
    };
    h += "<tr><td>" + text(s.id) + "</td><td><code>" + text(s.experiment) + "</code></td><td>" + gate + "</td><td>" +
         link(s.fit_link, "fit.json") + "</td><td>" + link(s.report_link, "report") + "</td></tr>";
  }
  h += "</table></body></html>\n";
  return h;
}

}  // namespace burrbench::study
