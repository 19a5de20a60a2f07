// Sections 4 and 5: the samples and recordings with their quality (what each session
// logged, what the replay found), the calibration's method and settings, and what the
// replay applied to each recording (lag, force bias, depth offset, and where each came from).
#include <algorithm>
#include <map>

#include "report_page.hpp"

namespace burrbench::analysis {

namespace {

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

std::string samples_table(const ReportData& in) {
  std::string b = "<h3>Samples</h3><table><tr><th>id</th><th>file</th><th>SHA-256</th><th>removed volume (mm³)</th></tr>";
  for (const auto& s : in.samples)
    b += "<tr>" + td(esc(s.id)) + td("<code>" + esc(s.path) + "</code>") +
         td("<span class=\"hash\">" + esc(s.sha256) + "</span>") + td(num(s.removed_volume_mm3), true) + "</tr>";
  return b + "</table>";
}

std::string recordings_table(const ReportData& in) {
  std::string b = "<h3>Recordings</h3><table><tr><th>id</th><th>sample</th><th>role</th><th>samples</th>"
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
  return b + "</table>";
}

}  // namespace

std::string data_section(const ReportPage& page) {
  return "<h2 id=\"data\">4. Data</h2>" + samples_table(page.in) + recordings_table(page.in) +
         data_quality_table(page.in);
}

std::string calibration_section(const ReportPage& page) {
  const ReportData& in = page.in;
  std::string b = "<h2 id=\"calib\">5. Calibration method and settings</h2>";
  b += in.calibration.empty() ? std::string("<p class=\"muted\">(none recorded)</p>") : kv_table(in.calibration);
  b += applied_table(in, page.fit_or_null());
  if (const json* fit = page.fit_or_null())
    for (const char* k : {"settings", "solver", "residuals_summary"})
      if (fit->contains(k) && fit->at(k).is_object()) b += std::string("<h3>") + k + "</h3>" + kv_table(fit->at(k));
  return b;
}

}  // namespace burrbench::analysis
