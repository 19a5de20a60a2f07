// The JSON report.js draws the plots from: each recording's series (every k-th sample),
// section 9's histograms and QQ/autocorrelation data, the fit's waterfall and profiles.
#include <algorithm>
#include <cmath>

#include "burrbench/analysis/residual_diagnostics.hpp"
#include "report_page.hpp"
#include "report_wrench.hpp"

namespace burrbench::analysis {

namespace {

constexpr std::size_t kMaxPlotPoints = 6000;  // per recording; the CSVs keep every sample
constexpr int kHistBins = 40;

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

// The global search's final costs and the profile likelihoods, from fit.json.
void add_fit_plots(const json& fit, json& data) {
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

}  // namespace

void add_residual_plots(ReportPage& page) {
  for (const char* role : {"calibrate", "validate"}) {
    json h = histogram(page.in, role);
    if (!h.is_null()) page.histograms.push_back(std::move(h));
  }
  for (const char* role : {"calibrate", "validate"}) {
    json d = residual_diagnostics(page.in, role);
    if (!d.is_null()) page.diagnostics.push_back(std::move(d));
  }
}

json plot_data(const ReportPage& page) {
  // The overview plot (at a glance) shows the first held-out recording, else the first.
  std::size_t overview = 0;
  for (std::size_t i = 0; i < page.in.recordings.size(); ++i)
    if (page.in.recordings[i].role == "validate") {
      overview = i;
      break;
    }
  json data = {{"recordings", json::array()}, {"histograms", page.histograms}, {"overview", overview},
               {"diagnostics", page.diagnostics}};
  if (page.fit_or_null()) add_fit_plots(page.fit, data);
  for (const auto& r : page.in.recordings) data["recordings"].push_back(decimated(r));
  return data;
}

}  // namespace burrbench::analysis
