#include "burrbench/analysis/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <iomanip>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "bone_image.hpp"
#include "report_html.hpp"
#include "burrbench/analysis/residual_diagnostics.hpp"
#include "report_wrench.hpp"
#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "burrbench/data_schema/version.hpp"


namespace burrbench::analysis {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr std::size_t kMaxPlotPoints = 6000;  // per recording; the CSVs keep every sample
constexpr int kHistBins = 40;

std::string read_text(const fs::path& p, const std::string& what) {
  std::ifstream f(p, std::ios::binary);
  if (!f)
    throw InputError(p.string(), "file", what + " (report assets: see docs/report.md)", "cannot open");
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// The library's licence header names its home page; no http(s) reference may remain in
// a report that must open offline, so the scheme is dropped (the text stays).
std::string strip_url_schemes(std::string s) {
  for (const std::string scheme : {"https://", "http://"})
    for (auto pos = s.find(scheme); pos != std::string::npos; pos = s.find(scheme, pos))
      s.erase(pos, scheme.size());
  return s;
}

using html::esc;
using html::num;
using html::td;

std::string kv_table(const json& j);

// Whether every element (of a list) or value (of an object) is a record with the same
// non-empty set of fields as the first: then they read best as one table.
bool like_records(const json& v) {
  if (v.empty() || !v.begin()->is_object() || v.begin()->empty()) return false;
  const json& first = *v.begin();
  return std::all_of(v.begin(), v.end(), [&](const json& e) {
    if (!e.is_object() || e.size() != first.size()) return false;
    for (const auto& [k, _] : first.items())
      if (!e.contains(k)) return false;
    return true;
  });
}

std::string value_html(const json& v);

// Records as a table, their fields as columns; each row headed by its name (an object's
// key) or by nothing (a list's element).
std::string records_table(const json& v) {
  const json& first = *v.begin();
  std::string h = "<table><tr>";
  if (v.is_object()) h += "<th></th>";
  for (const auto& [k, _] : first.items()) h += "<th>" + esc(k) + "</th>";
  h += "</tr>";
  for (auto it = v.begin(); it != v.end(); ++it) {
    h += "<tr>";
    if (v.is_object()) h += "<th>" + esc(it.key()) + "</th>";
    for (const auto& [k, _] : first.items()) h += td(value_html(it->at(k)), it->at(k).is_number());
    h += "</tr>";
  }
  return h + "</table>";
}

// One value of a settings table as a reader takes it in: a real number to 6 significant
// digits (the JSON file keeps every digit), null as "—", a flag as yes/no, an object as a
// nested table, a list of texts (warnings) as a list, records of the same fields (the
// stages, the registration of each recording) as one table. Anything else stays JSON.
std::string value_html(const json& v) {
  if (v.is_null()) return "—";
  if (v.is_string()) return esc(v.get<std::string>());
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_float()) return num(v.get<double>(), 6);
  if (v.is_number()) return v.dump();
  if (v.empty()) return v.is_object() ? "—" : "none";
  if ((v.is_array() || v.size() >= 2) && like_records(v)) return records_table(v);
  if (v.is_object()) return kv_table(v);
  const auto all = [&](auto pred) { return std::all_of(v.begin(), v.end(), pred); };
  if (all([](const json& e) { return e.is_string(); })) {
    std::string h = "<ul>";
    for (const auto& e : v) h += "<li>" + esc(e.get<std::string>()) + "</li>";
    return h + "</ul>";
  }
  if (all([](const json& e) { return e.is_primitive(); })) {
    std::string h;
    for (const auto& e : v) h += (h.empty() ? "" : ", ") + value_html(e);
    return h;
  }
  return "<code>" + esc(v.dump()) + "</code>";
}

std::string kv_table(const json& j) {
  std::string h = "<table>";
  for (const auto& [k, v] : j.items()) h += "<tr><th>" + esc(k) + "</th>" + td(value_html(v)) + "</tr>";
  return h + "</table>";
}

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

// Every k-th sample so a plot stays light; k ≥ 1.
json decimated(const RecordingSeries& r) {
  const std::size_t n = r.t_s.size();
  const std::size_t k = std::max<std::size_t>(1, (n + kMaxPlotPoints - 1) / kMaxPlotPoints);
  json t = json::array(), m = json::array({json::array(), json::array(), json::array()}),
       p = m;
  for (std::size_t i = 0; i < n; i += k) {
    t.push_back(r.t_s[i]);
    for (int a = 0; a < 3; ++a) {
      m[a].push_back(r.measured_N[i][a]);
      p[a].push_back(r.predicted_N[i][a]);
    }
  }
  json rec = {{"id", r.id}, {"role", r.role}, {"t", t}, {"m", m}, {"p", p}, {"stride", k}};
  if (!r.band95_N.empty()) {
    json bnd = json::array({json::array(), json::array(), json::array()});
    for (std::size_t i = 0; i < n; i += k)
      for (int a = 0; a < 3; ++a) bnd[a].push_back(r.band95_N[i][a]);
    rec["band"] = bnd;
  }
  add_wrench_plot_data(r, k, rec);
  return rec;
}

json histogram(const ReportData& in, const std::string& role) {
  double lo = INFINITY, hi = -INFINITY;
  for (const auto& r : in.recordings)
    if (r.role == role)
      for (std::size_t i = 0; i < r.t_s.size(); ++i)
        if (r.used[i])
          for (int a = 0; a < 3; ++a) {
            const double e = r.measured_N[i][a] - r.predicted_N[i][a];
            lo = std::min(lo, e);
            hi = std::max(hi, e);
          }
  if (!(lo <= hi)) return nullptr;
  if (hi - lo < 1e-12) { lo -= 0.5; hi += 0.5; }
  const double w = (hi - lo) / kHistBins;
  std::vector<std::vector<int>> counts(3, std::vector<int>(kHistBins, 0));
  for (const auto& r : in.recordings)
    if (r.role == role)
      for (std::size_t i = 0; i < r.t_s.size(); ++i)
        if (r.used[i])
          for (int a = 0; a < 3; ++a) {
            const double e = r.measured_N[i][a] - r.predicted_N[i][a];
            counts[a][std::min(kHistBins - 1, int((e - lo) / w))]++;
          }
  json centres = json::array();
  for (int b = 0; b < kHistBins; ++b) centres.push_back(lo + (b + 0.5) * w);
  return {{"role", role}, {"centres", centres}, {"counts", counts}};
}

// What each session logged about itself and what the replay found: dropped and stale
// rows, buried samples, and the events (gaps, reconnects, faults) with their times.
std::string data_quality_table(const ReportData& in) {
  std::string h =
      "<h3>Data quality</h3><p class=\"muted\">Per recording: force samples dropped by the alignment "
      "(stale or non-increasing timestamps), stale rows per device stream (the device repeated a value; "
      "never used), samples where the burr was buried (excluded or down-weighted by the fit's policy) "
      "and the session's events.</p><table id=\"quality-table\"><tr><th>recording</th><th>force samples "
      "dropped</th><th>stale rows</th><th>buried samples</th><th>events</th></tr>";
  std::string details;
  for (const auto& r : in.recordings) {
    if (r.id.ends_with("@validate")) continue;  // the same session as its calibrate part
    const auto& q = r.quality;
    std::string stale;
    for (const auto& [stream, n] : q.stale_rows)
      if (n > 0) stale += esc(stream) + fmt::format(": {}<br>", n);
    std::map<std::string, std::size_t> kinds;
    for (const auto& e : q.events) ++kinds[e.kind];
    std::string ev;
    for (const auto& [kind, n] : kinds) ev += fmt::format("{} × {}<br>", esc(kind), n);
    // Flagged: the session's gaps, and the silent stretches the replay followed the stage through.
    const auto count = [&](const char* kind) { return kinds.count(kind) ? kinds.at(kind) : std::size_t(0); };
    const std::size_t gaps = count("gap") + count("force_silent");
    h += "<tr>" + td(esc(r.id)) + td(std::to_string(q.dropped_force_samples), true) +
         td(stale.empty() ? "none" : stale) +
         td(fmt::format("{} ({}%)", q.buried_samples,
                        num(r.t_s.empty() ? 0.0 : 100.0 * double(q.buried_samples) / double(r.t_s.size()), 3)),
            true) +
         (gaps > 0 ? "<td class=\"flag\">" + ev + "</td>" : td(ev.empty() ? "none" : ev)) + "</tr>";
    if (q.events.empty()) continue;
    details += "<details><summary>" + esc(r.id) + fmt::format(": {} events</summary>", q.events.size()) +
               "<table><tr><th>t (s)</th><th>kind</th><th>stream</th><th>detail</th></tr>";
    std::size_t shown = 0;
    for (const auto& e : q.events) {
      if (++shown > 200) {
        details += fmt::format("<tr><td colspan=\"4\">… {} more (the recording file has all)</td></tr>",
                               q.events.size() - 200);
        break;
      }
      details += "<tr>" + td(num(e.t_s, 6), true) + td(esc(e.kind)) + td(esc(e.stream)) + td(esc(e.detail)) + "</tr>";
    }
    details += "</table></details>";
  }
  return h + "</table>" + details;
}

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

// What the replay applied to each recording: the lag (the fit's where it fitted one, else
// the manifest's lag_ms), the force bias and its source, the depth offset.
std::string applied_table(const ReportData& in, const json* fit) {
  const auto lag_fitted = [&](const std::string& id) {
    if (!fit || !fit->contains("nuisance") || !fit->at("nuisance").is_array()) return false;
    return std::any_of(fit->at("nuisance").begin(), fit->at("nuisance").end(), [&](const json& n) {
      return n.value("recording_id", std::string()) == id && n.value("name", std::string()) == "lag" &&
             !n.value("fixed", false);
    });
  };
  std::string h = "<h3>Applied per recording</h3><table id=\"applied-table\"><tr><th>recording</th><th>lag (ms)</th>"
                  "<th>lag from</th><th>force bias (N)</th><th>force bias from</th><th>depth offset (mm)</th></tr>";
  for (const auto& r : in.recordings) {
    if (r.id.ends_with("@validate")) continue;  // the same replay as its calibrate part
    h += "<tr>" + td(esc(r.id)) + td(num(r.lag_ms), true) + td(lag_fitted(r.id) ? "fit.json" : "manifest") +
         td(fmt::format("{}, {}, {}", num(r.force_bias_N.x), num(r.force_bias_N.y), num(r.force_bias_N.z)), true) +
         td(r.force_bias_source == "fit" ? "fit.json" : esc(r.force_bias_source)) + td(num(r.depth_offset_mm), true) +
         "</tr>";
  }
  return h + "</table>";
}

// A constant's verdict as the report states it: the profile's verdict, and "limited by
// discretization error" beside it when the discretization check found it so — the table's
// "at 2l" column and the verdict must not disagree.
bool limited(const json& p) {
  return p.contains("discretization") && p.at("discretization").is_object() &&
         p.at("discretization").value("limited", false);
}

std::string constant_verdict(const json& p) {
  const bool ident = p.value("identifiable", false);
  const std::string verdict = p.value("verdict", std::string(ident ? "identifiable" : "non_identifiable"));
  return limited(p) ? verdict + ", limited by discretization error" : verdict;
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

std::string parameter_section(const ReportData& in, const json* fit) {
  std::string h;
  if (fit && fit->contains("parameters")) {
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
           td(ident && verdict != "imprecise" && !limited(p)
                  ? esc(verdict)
                  : "<b>" + esc(constant_verdict(p)) + "</b>" +
                        (p.value("reason", std::string()).empty() ? std::string()
                                                                  : ": " + esc(p.value("reason", std::string()))) +
                        (limited(p) ? " (read the widened interval of the 2l column)" : "")) +
           "</tr>";
    }
    h += "</table>";
    // How the intervals treat correlated residuals (settings.noise_model, absent before it existed).
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
    // Global search (waterfall) and profile likelihoods, drawn by report.js.
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
    if (fit->contains("correlation") && fit->at("correlation").contains("names")) {
      const auto& c = fit->at("correlation");
      const auto& names = c.at("names");
      const auto& mat = c.at("matrix");
      const std::size_t k = names.size();
      // Columns numbered as the rows (the names would make a 24-column matrix wider than a
      // printed page); correlations to two decimals.
      h += "<h3>Parameter correlation matrix</h3><p class=\"muted\">Column k is the entry of row k.</p>"
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
    h += nuisance_table(*fit);
    if (in.mode == "validate")
      h += "<p class=\"muted\" id=\"fit-replayed\">The constants replayed here are this fit's (given to validate "
           "with <code>--fit</code>; checked against the parameter set), at its nuisances: the lag, biases, pose "
           "correction and spindle terms it fitted per recording (section 5).</p>";
  } else {
    h += "<p>Fixed parameters replayed (no fit in this run): <code>" + esc(in.params_path) +
         "</code>. Intervals and identifiability come from the calibration that produced them.</p>";
    h += "<table><tr><th>label</th><th>class</th><th>α (N/mm²)</th><th>C1 (N/mm²)</th><th>μ</th></tr>";
    for (const auto& p : in.parameters)
      h += "<tr>" + td(std::to_string(p.class_label), true) + td(esc(p.class_name)) +
           td(num(p.alpha_N_per_mm2, 6), true) + td(num(p.c1_N_per_mm2, 6), true) +
           td(num(p.mu, 6), true) + "</tr>";
    h += "</table>";
  }
  return h;
}

// The convergence study (validate), or the calibration's discretization check (calibrate):
// whether the model's discretization error is below the sensor noise, in words first.
std::string verification_section(const ReportData& in, const json* fit) {
  std::string h;
  const json& v = in.verification;
  if (v.is_object() && v.contains("recordings")) {
    const bool known = v.contains("below_noise") && v.at("below_noise").is_boolean();
    const bool below = known && v.at("below_noise").get<bool>();
    h += fmt::format("<p id=\"verification-verdict\"><span class=\"verdict {}\">{}</span> {}.</p>",
                     !known ? "none" : below ? "pass" : "fail",
                     !known ? "NOISE UNKNOWN" : below ? "DISCRETIZATION ERROR BELOW NOISE" : "DISCRETIZATION ERROR ABOVE NOISE",
                     esc(v.value("verdict", std::string())));
    h += "<p class=\"muted\">Every recording replayed with the same constants at the sample's voxel size l, "
         "at l/2 (each voxel split into 8), at 2l (blocks of 8 merged) and at half the replay step. Change: "
         "RMS over the used samples and the three axes against (l, Δt), comparable with the per-axis sensor "
         "noise σ = " + (v.contains("sigma_N") && v.at("sigma_N").is_number() ? num(v.at("sigma_N").get<double>()) + " N"
                                                                              : std::string("unknown")) +
         " (" + esc(v.value("sigma_source", std::string())) + "). Error at l: Richardson from 2l, l, l/2 with the "
         "observed order (clamped to [0.5, 4]); the step's error assumes first order (docs/calibration.md).</p>";
    if (v.contains("reach") && v.at("reach").is_array() && !v.at("reach").empty()) {  // since the twentieth session
      std::vector<std::string> parts;
      auto dims = [](const json& d) {
        return d.is_array() && d.size() == 3 ? fmt::format("{}×{}×{}", d[0].dump(), d[1].dump(), d[2].dump()) : std::string("?");
      };
      for (const auto& r : v.at("reach"))
        parts.push_back(fmt::format("{} {} of its {} voxels", esc(r.value("sample", std::string())),
                                    dims(r.value("replayed_dims", json())), dims(r.value("dims", json()))));
      h += "<p class=\"muted\" id=\"verification-reach\">Replayed at every level: the part of each sample within "
           "reach of the burr (its radius and 4 voxels round every centre; the same figures as the whole sample to "
           "rounding): " + fmt::format("{}", fmt::join(parts, "; ")) + ".</p>";
    }
    std::vector<std::string> classes;
    h += "<div class=\"scroll\"><table><tr><th>recording</th><th>level</th><th>voxel (mm)</th><th>step (µs)</th>"
         "<th>RMS change (N)</th><th>largest change (N)</th><th>peak |F| (N)</th>";
    if (!v.at("recordings").empty())
      for (const auto& [name, _] : v.at("recordings")[0].at("levels")[0].at("removed_mm3").items()) {
        classes.push_back(name);
        h += "<th>removed " + esc(name) + " (mm³)</th>";
      }
    h += "</tr>";
    for (const auto& r : v.at("recordings")) {
      for (const auto& L : r.at("levels")) {
        h += "<tr>" + td(esc(r.value("id", std::string()))) + td(esc(L.value("level", std::string()))) +
             td(num(L.value("voxel_mm", NAN)), true) + td(num(L.value("step_us", NAN)), true) +
             td(num(L.value("rms_change_N", NAN)), true) + td(num(L.value("max_change_N", NAN)), true) +
             td(num(L.value("peak_N", NAN)), true);
        for (const auto& c : classes)
          h += td(num(L.at("removed_mm3").value(c, NAN), 5), true);
        h += "</tr>";
      }
      const auto& ord = r.at("voxel_order");
      h += "<tr class=\"total\">" + td(esc(r.value("id", std::string()))) + td("<b>error at l</b>") +
           td("order " + (ord.is_number() ? num(ord.get<double>(), 3) : std::string("not observed"))) +
           td("step " + num(r.value("step_error_N", NAN), 3) + " N") +
           td("<b>" + num(r.value("error_N", NAN), 3) + "</b>", true) + td("") + td("");
      for (const auto& c : classes)
        h += td("± " + num(r.at("removed_error").at(c).value("error_mm3", NAN), 3), true);
      h += "</tr>";
    }
    h += "</table></div>";
  } else if (fit && fit->contains("settings") && fit->at("settings").contains("discretization_check") &&
             fit->at("settings").at("discretization_check").value("computed", false)) {
    std::size_t limited = 0;
    for (const auto& p : fit->at("parameters"))
      if (p.contains("discretization") && p.at("discretization").value("limited", false)) ++limited;
    h += fmt::format("<p>The calibration refitted every constant on the sample with its voxels merged by 2 "
                     "(voxel {} mm): <b>{} constant(s) limited by discretization error</b>, i.e. moved by more "
                     "than half their 95 % interval. Their intervals hold for the model at the fit's voxel "
                     "size; as physical constants read the widened interval (section 6, "
                     "docs/calibration.md). For the force, run <code>burrbench verify</code>.</p>",
                     num(fit->at("settings").at("discretization_check").value("coarse_voxel_mm", NAN)), limited);
  } else {
    h += "<p class=\"muted\">Not computed in this run (<code>validate --no-verification</code>, or a calibration "
         "with <code>--no-discretization-check</code>). <code>burrbench verify</code> makes the study.</p>";
  }
  return h;
}

// The verification's verdict in one badge and a clause, for the top of the report beside
// the gate: the convergence study's (validate), else the fit's discretization check.
std::string verification_badge(const ReportData& in, const json* fit) {
  const json& v = in.verification;
  if (v.is_object() && v.contains("recordings")) {
    const bool known = v.contains("below_noise") && v.at("below_noise").is_boolean();
    const bool below = known && v.at("below_noise").get<bool>();
    return fmt::format("<span class=\"verdict {}\" id=\"verification-badge\">{}</span>",
                       !known ? "none" : below ? "pass" : "fail",
                       !known ? "VERIFICATION: NOISE UNKNOWN"
                       : below ? "VERIFICATION: DISCRETIZATION ERROR BELOW NOISE"
                               : "VERIFICATION: DISCRETIZATION ERROR ABOVE NOISE");
  }
  if (fit && fit->contains("settings") && fit->at("settings").contains("discretization_check") &&
      fit->at("settings").at("discretization_check").value("computed", false)) {
    std::size_t n = 0;
    for (const auto& p : fit->at("parameters")) n += limited(p);
    return fmt::format("<span class=\"verdict {}\" id=\"verification-badge\">DISCRETIZATION CHECK: {}</span>",
                       n ? "fail" : "pass", n ? fmt::format("{} CONSTANT(S) LIMITED", n) : std::string("NO CONSTANT LIMITED"));
  }
  return "<span class=\"verdict none\" id=\"verification-badge\">VERIFICATION NOT COMPUTED</span>";
}

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

std::string cross_validation_section(const std::vector<MetricRow>& rows, const json* fit) {
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

// When the fit started (UTC, ISO 8601): fit.json's provenance is stamped when its results
// are assembled, after the search, so the start is that time less the solver's wall time.
// "unknown" when either is missing or unreadable.
std::string fit_started_utc(const json& fit) {
  if (!fit.contains("provenance") || !fit.at("provenance").is_object() || !fit.contains("solver") ||
      !fit.at("solver").is_object())
    return "unknown";
  std::tm tm{};
  std::istringstream in(fit.at("provenance").value("created_utc", std::string()));
  in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  const double wall_s = fit.at("solver").value("wall_s", NAN);
  if (in.fail() || !std::isfinite(wall_s)) return "unknown";
  const std::time_t start = timegm(&tm) - std::time_t(std::ceil(wall_s));
  std::tm utc{};
  gmtime_r(&start, &utc);
  return fmt::format("{:04}-{:02}-{:02}T{:02}:{:02}:{:02}Z", utc.tm_year + 1900, utc.tm_mon + 1, utc.tm_mday,
                     utc.tm_hour, utc.tm_min, utc.tm_sec);
}

// Were the criteria fixed before the fit? calibrate --criteria records their SHA-256 and
// the time it read them in fit.json (settings.criteria); the criteria of this report must
// be that same content, and the time is shown beside the fit's own start.
void criteria_predate(const json& fit, const ReportData& in, ReportSummary& sum) {
  const json* rec = nullptr;
  if (fit.contains("settings") && fit.at("settings").contains("criteria") && fit.at("settings").at("criteria").is_object())
    rec = &fit.at("settings").at("criteria");
  const std::string when = fmt::format("recorded {}; the fit started {}",
                                       rec ? rec->value("recorded_utc", std::string("at a time not recorded"))
                                           : std::string("never"),
                                       fit_started_utc(fit));
  if (!rec || !rec->contains("sha256")) {
    sum.criteria_predate_text =
        "Not established: the fit recorded no criteria (run calibrate with --criteria to fix them before the fit).";
    return;
  }
  const std::string sha = rec->value("sha256", std::string());
  sum.criteria_predate_fit = sha == in.criteria_sha256;
  sum.criteria_predate_text =
      *sum.criteria_predate_fit
          ? fmt::format("Fixed before the fit: calibrate recorded these criteria (SHA-256 {}) before it fitted the "
                        "constants ({}).", sha.substr(0, 12), when)
          : fmt::format("Changed after the fit: calibrate recorded criteria with SHA-256 {} ({}, {}); the criteria "
                        "used here have {}.", sha.substr(0, 12), rec->value("path", std::string("?")), when,
                        in.criteria_sha256.substr(0, 12));
}

std::string criteria_section(const ReportSummary& s) {
  if (!s.has_criteria) return "<p class=\"muted\">No acceptance criteria were given for this run.</p>";
  std::string h;
  if (!s.criteria_predate_text.empty())
    h += fmt::format("<p id=\"criteria-predate\"><span class=\"verdict {}\">{}</span> {}</p>",
                     !s.criteria_predate_fit ? "none" : *s.criteria_predate_fit ? "pass" : "fail",
                     !s.criteria_predate_fit ? "CRITERIA NOT SHOWN TO PREDATE THE FIT"
                     : *s.criteria_predate_fit ? "CRITERIA FIXED BEFORE THE FIT"
                                               : "CRITERIA CHANGED AFTER THE FIT",
                     esc(s.criteria_predate_text));
  h +=
      "<table><tr><th>#</th><th>criterion</th><th>metric</th><th>data</th><th>segment</th>"
      "<th>axis</th><th>threshold</th><th>value</th><th>result</th></tr>";
  for (const auto& r : s.results) {
    const auto& c = s.criteria.criteria[r.index];
    std::string thr;
    if (c.min) thr += "≥ " + num(*c.min, 6);
    if (c.max) thr += std::string(thr.empty() ? "" : ", ") + "≤ " + num(*c.max, 6);
    h += "<tr>" + td(std::to_string(r.index + 1), true) + td(esc(c.name)) + td(esc(c.metric)) +
         td(esc(c.recording.empty() ? "all " + c.data : "recording " + c.recording)) +
         td(esc(c.segment)) + td(esc(r.axis)) + td(thr) + td(num(r.value, 5), true) +
         td(r.pass ? "<span class=\"verdict pass\">PASS</span>"
                   : "<span class=\"verdict fail\">FAIL</span>") +
         "</tr>";
  }
  return h + "</table>";
}

void replace_once(std::string& s, const std::string& key, const std::string& value) {
  const auto pos = s.find(key);
  if (pos == std::string::npos)
    throw InputError("template.html", key, "the placeholder in the report template", "missing");
  s.replace(pos, key.size(), value);
}

}  // namespace

fs::path default_assets_dir() {
  if (const char* env = std::getenv("BURRBENCH_REPORT_ASSETS"); env && *env) return env;
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / "share" / "burrbench" / "report";
    if (fs::exists(installed / "node_modules", ec)) return installed;
  }
  // This file lives at <source>/analysis/src/report.cpp (CMake passes absolute paths).
  return fs::path(__FILE__).parent_path().parent_path() / "report";
}

ReportSummary write_report(const ReportInputs& inputs, const fs::path& out_html, const ReportOptions& opt) {
  const fs::path out_dir = out_html.parent_path().empty() ? fs::path(".") : out_html.parent_path();
  std::error_code ec;
  // Assets first: a missing one should fail before any work.
  const fs::path assets = opt.assets_dir.empty() ? default_assets_dir() : opt.assets_dir;
  const std::string tmpl = read_text(assets / "template.html", "template.html");
  const std::string css = read_text(assets / "report.css", "report.css") + "\n" +
                          read_text(assets / "node_modules/uplot/dist/uPlot.min.css", "uPlot CSS (npm ci)");
  const std::string js =
      strip_url_schemes(read_text(assets / "node_modules/uplot/dist/uPlot.iife.min.js", "uPlot (npm ci)")) +
      "\n" + read_text(assets / "report.js", "report.js");

  // The report never runs the model: everything it shows is in its inputs.
  ReportData in = report_data(inputs);
  const bool has_fit = inputs.fit.has_value();
  if (in.context_of_use.empty()) in.context_of_use = opt.context_of_use;  // calibrate states none
  const auto rows = compute_metric_rows(in);

  ReportSummary sum;
  sum.html = out_html;
  sum.recordings = in.recordings.size();
  for (const auto& r : in.recordings) sum.samples += r.t_s.size();
  if (inputs.criteria) {
    sum.has_criteria = true;
    sum.criteria = *inputs.criteria;
    sum.results = evaluate_criteria(sum.criteria, rows, inputs.criteria_path);
    sum.pass = all_pass(sum.results);
  }
  json fit;
  if (has_fit) {
    fit = data_schema::fit_to_json(*inputs.fit);
    if (sum.has_criteria) criteria_predate(fit, in, sum);
  }

  fs::create_directories(out_dir);

  std::string b;
  const std::string title = "burrbench validation report — " + in.experiment_name;
  b += "<h1>" + esc(title) + "</h1>";
  b += fmt::format("<p class=\"muted\">Mode: {} · generated {} by {}</p>", esc(in.mode),
                   esc(make_provenance({}).created_utc), esc(software_version()));
  b += verdicts_block(in, sum, has_fit ? &fit : nullptr);
  b += "<nav><a href=\"#glance\">At a glance</a><a href=\"#cou\">Context</a><a href=\"#model\">Model</a><a href=\"#verif\">Verification</a><a href=\"#data\">Data</a>"
       "<a href=\"#calib\">Calibration</a><a href=\"#params\">Parameters</a><a href=\"#force\">Force</a><a href=\"#wrench\">Moments</a>"
       "<a href=\"#resid\">Residuals</a><a href=\"#metrics\">Metrics</a><a href=\"#cv\">Cross-validation</a>"
       "<a href=\"#bone\">Removed bone</a><a href=\"#accept\">Acceptance</a><a href=\"#limits\">Limitations</a>"
       "<a href=\"#repro\">Reproducibility</a><a href=\"#signoff\">Sign-off</a></nav>";

  // At a glance: the verdict, pooled |F| metrics per role and one held-out recording.
  std::size_t overview = 0;
  for (std::size_t i = 0; i < in.recordings.size(); ++i)
    if (in.recordings[i].role == "validate") {
      overview = i;
      break;
    }
  b += "<h2 id=\"glance\">At a glance</h2><table><tr><th>data</th><th>n</th><th>RMSE |F| (N)</th>"
       "<th>NRMSE |F|</th><th>R² |F|</th><th>Sprague–Geers C |F|</th></tr>";
  for (const auto& r : rows)
    if (r.recording_id.empty() && r.segment == "all" && r.axis == std::string("magnitude"))
      b += "<tr>" + td(esc(r.role == "validate" ? "held-out (validate)" : "calibration")) +
           td(std::to_string(r.m.n), true) + td(num(r.m.rmse_N), true) + td(num(r.m.nrmse), true) +
           td(num(r.m.r2), true) + td(num(r.m.sg_combined), true) + "</tr>";
  b += "</table>";
  if (!in.recordings.empty()) b += "<div class=\"plot\" id=\"plot-overview\"></div>";

  b += "<h2 id=\"cou\">1. Context of use</h2>";
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

  json model_info = {{"software", software_version()}};
  model_info.update(in.model);
  b += "<h2 id=\"model\">2. Model and version</h2>" + kv_table(model_info);

  b += "<h2 id=\"verif\">3. Solution verification</h2>" + verification_section(in, has_fit ? &fit : nullptr);

  b += "<h2 id=\"data\">4. Data</h2><h3>Samples</h3><table><tr><th>id</th><th>file</th><th>SHA-256</th>"
       "<th>removed volume (mm³)</th></tr>";
  for (const auto& s : in.samples)
    b += "<tr>" + td(esc(s.id)) + td("<code>" + esc(s.path) + "</code>") +
         td("<span class=\"hash\">" + esc(s.sha256) + "</span>") + td(num(s.removed_volume_mm3), true) + "</tr>";
  b += "</table><h3>Recordings</h3><table><tr><th>id</th><th>sample</th><th>role</th><th>samples</th>"
       "<th>used</th><th>duration (s)</th><th>segments</th><th>registration</th><th>file</th><th>SHA-256</th>"
       "<th>notes</th></tr>";
  for (const auto& r : in.recordings) {
    std::size_t used = 0;
    for (auto u : r.used) used += u;
    std::string segs;
    for (const auto& s : r.segments)
      segs += esc(s.label) + fmt::format(" [{}, {}) s<br>", num(s.start_s), num(s.end_s));
    b += "<tr>" + td(esc(r.id)) + td(esc(r.sample_id)) + td(esc(r.role)) +
         td(std::to_string(r.t_s.size()), true) + td(std::to_string(used), true) +
         td(r.t_s.empty() ? "—" : num(r.t_s.back() - r.t_s.front()), true) +
         td(segs.empty() ? "whole recording" : segs) + td(esc(r.registration)) +
         td("<code>" + esc(r.path) + "</code>") +
         td("<span class=\"hash\">" + esc(r.sha256) + "</span>") + td(esc(r.notes)) + "</tr>";
  }
  b += "</table>" + data_quality_table(in);

  b += "<h2 id=\"calib\">5. Calibration method and settings</h2>";
  b += in.calibration.empty() ? std::string("<p class=\"muted\">(none recorded)</p>") : kv_table(in.calibration);
  b += applied_table(in, has_fit ? &fit : nullptr);
  if (has_fit) {
    for (const char* k : {"settings", "solver", "residuals_summary"})
      if (fit.contains(k) && fit.at(k).is_object()) b += std::string("<h3>") + k + "</h3>" + kv_table(fit.at(k));
  }

  b += "<h2 id=\"params\">6. Parameters</h2>" + parameter_section(in, has_fit ? &fit : nullptr);

  b += "<h2 id=\"force\">7. Measured vs predicted force</h2><p class=\"muted\">Sensor frame. "
       "With a fit, the shaded band around each predicted axis is its 95 % band from the fitted constants' "
       "covariance alone (delta method through the forward sensitivities: 1.96·√(gᵀCg), g = ∂F/∂ln θ); "
       "the sensor noise and the nuisances are not in it. "
       "Drag to zoom (x, or a box), double-click to reset; click a legend entry to hide a series. "
       "Plots show every k-th sample when a recording is long; predictions.csv has all.</p>";
  for (std::size_t i = 0; i < in.recordings.size(); ++i)
    b += fmt::format("<h3>{}</h3><div class=\"plot\" id=\"plot-force-{}\"></div>", esc(in.recordings[i].id), i);

  b += "<h2 id=\"wrench\">8. Moments and the spindle's load</h2>" + wrench_section(in, has_fit ? &fit : nullptr);

  b += "<h2 id=\"resid\">9. Residuals</h2><p class=\"muted\">e = measured − predicted.</p>";
  for (std::size_t i = 0; i < in.recordings.size(); ++i)
    b += fmt::format("<h3>{}</h3><div class=\"plotrow\"><div class=\"plot\" id=\"plot-resid-t-{}\"></div>"
                     "<div class=\"plot\" id=\"plot-resid-p-{}\"></div></div>",
                     esc(in.recordings[i].id), i, i);
  json hists = json::array(), diagnostics = json::array();
  for (const char* role : {"calibrate", "validate"}) {
    json h = histogram(in, role);
    if (!h.is_null()) {
      b += fmt::format("<div class=\"plot\" id=\"plot-hist-{}\"></div>", hists.size());
      hists.push_back(std::move(h));
    }
  }
  for (const char* role : {"calibrate", "validate"}) {
    json d = residual_diagnostics(in, role);
    if (d.is_null()) continue;
    if (diagnostics.empty())
      b += "<h3>Normality and independence</h3><p class=\"muted\">QQ plot: standardised residuals "
           "(every used sample and axis) against the normal quantiles; on the diagonal when the noise is "
           "Gaussian, heavy tails bend away at the ends. Autocorrelation: r(k) per axis over pairs of used "
           "samples k apart within a recording; white residuals stay near 0 beyond lag 0 (±1.96/√n dashed). "
           "The fit's intervals assume white residuals unless widened for r(1) (section 6).</p>";
    b += fmt::format("<div class=\"plotrow\"><div class=\"plot\" id=\"plot-qq-{0}\"></div>"
                     "<div class=\"plot\" id=\"plot-acf-{0}\"></div></div>", diagnostics.size());
    diagnostics.push_back(std::move(d));
  }

  b += "<h2 id=\"metrics\">10. Validation metrics</h2><p class=\"muted\">NRMSE is normalised by the "
       "measured range (max − min) of the same series; R² = 1 − SSE/SST; Theil U2 = √(Σe²/Σm²); "
       "SG = Sprague–Geers; definitions in docs/report.md. Only used samples count.</p>"
       "<h3>Per recording</h3>" + metric_table_html(rows, false) + "<h3>Pooled by role</h3>" +
       metric_table_html(rows, true) + durbin_watson_note(rows);

  b += "<h2 id=\"cv\">11. Cross-validation</h2>" + cross_validation_section(rows, has_fit ? &fit : nullptr);

  b += "<h2 id=\"bone\">12. Removed bone</h2><p class=\"muted\">Depth map: thickness of bone "
       "removed by the replay in each (x, y) column of the volume (plan view, y up).</p>";
  for (const auto& s : in.samples) {
    const auto png = render_removed_depth_png(s);
    if (png.empty()) {
      b += "<p>" + esc(s.id) + ": no depth map recorded.</p>";
      continue;
    }
    data_schema::write_file_atomic(out_dir / fmt::format("removed_{}.png", &s - in.samples.data()),
                                   std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
    b += "<h3>" + esc(s.id) + "</h3><img class=\"bone\" alt=\"removed bone depth map\" src=\"data:image/png;base64," +
         base64(png) + "\">";
    const auto classes = render_removed_class_png(s);
    if (!classes.empty())
      b += "<p class=\"muted\">Bone class removed: per column, the class of most removed bone.</p>"
           "<img class=\"bone\" alt=\"removed bone class map\" src=\"data:image/png;base64," +
           base64(classes) + "\">";
  }

  b += "<h2 id=\"accept\">13. Acceptance criteria</h2>" + criteria_section(sum);

  b += "<h2 id=\"limits\">14. Limitations</h2><ul>";
  for (const auto& l : in.limitations) b += "<li>" + esc(l) + "</li>";
  b += "<li>Metrics use only samples marked used (buried or excluded samples and spans outside used "
       "segments are left out).</li></ul>";

  b += "<h2 id=\"repro\">15. Reproducibility</h2><h3>Command lines</h3><pre>" +
       esc(in.provenance.command_line.empty() ? "(library call)" : in.provenance.command_line) + "\n" +
       esc(invocation().empty() ? "(report: library call)" : invocation()) +
       (has_fit && in.mode == "validate" && fit.contains("provenance") && fit.at("provenance").is_object()
            ? "\n" + esc(fit.at("provenance").value("command_line", std::string("(calibrate: not recorded)")))
            : std::string()) +
       "</pre>";
  b += "<h3>Versions</h3>" + versions_table(assets, opt.versions);
  b += "<h3>Inputs</h3><table><tr><th>file</th><th>SHA-256</th></tr>";
  for (const auto& f : in.provenance.inputs)
    b += "<tr>" + td("<code>" + esc(f.path) + "</code>") + td("<span class=\"hash\">" + esc(f.sha256) + "</span>") + "</tr>";
  b += "</table>";
  json seeds = {{"seed", in.seed},
               {"experiment", in.experiment_path},
               {"experiment sha256", in.experiment_sha256},
               {"params", in.params_path},
               {"params sha256", in.params_sha256},
               {"criteria", in.criteria_path},
               {"criteria sha256", in.criteria_sha256}};
  if (has_fit) {
    const json& st = fit.contains("settings") ? fit.at("settings") : json::object();
    const json rec = st.contains("criteria") && st.at("criteria").is_object() ? st.at("criteria") : json::object();
    seeds["criteria sha256 recorded by the fit"] = rec.value("sha256", std::string("none"));
    seeds["criteria recorded by the fit (UTC)"] = rec.value("recorded_utc", std::string("none"));
    seeds["fit started (UTC)"] = fit_started_utc(fit);
  }
  seeds["prediction created"] = in.provenance.created_utc;
  b += "<h3>Seeds and settings</h3>" + kv_table(seeds);

  // Sign-off: left blank for the people who answer for the release (print, sign, date).
  b += "<h2 id=\"signoff\">16. Sign-off</h2><p class=\"muted\">This report, generated " +
       esc(make_provenance({}).created_utc) +
       " from the inputs listed in section 15 (SHA-256), is reviewed and accepted by:</p>"
       "<table class=\"signoff\" id=\"signoff-table\"><tr><th>role</th><th>name</th><th>signature</th><th>date</th></tr>"
       "<tr><td>prepared by</td><td></td><td></td><td></td></tr>"
       "<tr><td>reviewed by</td><td></td><td></td><td></td></tr>"
       "<tr><td>approved for release by</td><td></td><td></td><td></td></tr></table>";

  json data = {{"recordings", json::array()}, {"histograms", hists}, {"overview", overview},
               {"diagnostics", diagnostics}};
  if (has_fit) {
    json costs = json::array();
    if (fit.contains("multistart") && fit.at("multistart").is_array())
      for (const auto& e : fit.at("multistart"))
        if (e.contains("cost") && e.at("cost").is_number())
          costs.push_back({{"cost", e.at("cost")}, {"ending", e.value("ending", std::string())}});
    data["waterfall"] = costs;
    json profiles = json::array();
    const double thr = fit.contains("settings") && fit.at("settings").contains("profiles")
                           ? fit.at("settings").at("profiles").value("threshold_cost", 0.0)
                           : 0.0;
    if (fit.contains("parameters"))
      for (const auto& p : fit.at("parameters"))
        if (p.contains("profile") && p.at("profile").is_array() && !p.at("profile").empty()) {
          json v = json::array(), d = json::array();
          for (const auto& q : p.at("profile")) {
            v.push_back(q.value("value", 0.0));
            d.push_back(q.contains("delta_cost") && q.at("delta_cost").is_number() ? q.at("delta_cost") : json(nullptr));
          }
          profiles.push_back({{"name", p.value("class_name", std::string()) + "." + p.value("name", std::string())},
                              {"unit", p.value("unit", std::string())}, {"value", v}, {"delta", d},
                              {"threshold", thr}});
        }
    data["profiles"] = profiles;
  }
  for (const auto& r : in.recordings) data["recordings"].push_back(decimated(r));

  std::string html = tmpl;
  replace_once(html, "<!--BURRBENCH:TITLE-->", esc(title));
  replace_once(html, "<!--BURRBENCH:CSS-->", css);
  replace_once(html, "<!--BURRBENCH:BODY-->", b);
  replace_once(html, "<!--BURRBENCH:DATA-->", json_for_script(data));
  replace_once(html, "<!--BURRBENCH:JS-->", js);
  data_schema::write_file_atomic(out_html, html);

  // Beside the report: the residuals, the metrics and the fit.
  if (inputs.fit && opt.copy_fit) {
    // The copy beside the report carries the metrics (FitResult::metrics is analysis's
    // to fill); the calibrate directory's own fit.json is an input and stays as it is.
    auto f = *inputs.fit;
    f.metrics = {{"format", "burrbench.metrics"}, {"rows", metric_rows_to_json(rows)}};
    data_schema::write_fit(out_dir / "fit.json", f);
  }
  write_residuals_csv(out_dir / "residuals.csv", in);
  json mj = {{"format", "burrbench.metrics"}, {"format_version", "1.0"},
             {"rows", metric_rows_to_json(rows)}};
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
  prov.inputs = in.provenance.inputs;
  mj["provenance"] = data_schema::provenance_json(prov);
  data_schema::write_file_atomic(out_dir / "metrics.json", mj.dump(1) + "\n");
  return sum;
}

}  // namespace burrbench::analysis
