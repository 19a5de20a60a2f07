// Section 13: the acceptance criteria's verdicts, and whether the criteria were fixed
// before the fit (their SHA-256 and the time calibrate recorded them, beside the fit's start).
#include <cmath>
#include <ctime>
#include <iomanip>
#include <sstream>

#include "report_page.hpp"

namespace burrbench::analysis {

// When the fit started (UTC, ISO 8601, to the second): settings.started_utc, which
// calibrate records. Files before it: fit.json's provenance is stamped when its results
// are assembled — after every stage but the last, "overlaps" — so the start is that stamp
// less the solver's wall time without that stage, right within a second. "unknown" when
// neither is there or readable.
std::string fit_started_utc(const json& fit) {
  if (fit.contains("settings") && fit.at("settings").is_object() && fit.at("settings").contains("started_utc") &&
      fit.at("settings").at("started_utc").is_string())
    return fit.at("settings").at("started_utc").get<std::string>();
  if (!fit.contains("provenance") || !fit.at("provenance").is_object() || !fit.contains("solver") ||
      !fit.at("solver").is_object())
    return "unknown";
  std::tm tm{};
  std::istringstream in(fit.at("provenance").value("created_utc", std::string()));
  in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%SZ");
  const json& solver = fit.at("solver");
  double wall_s = solver.contains("wall_s") && solver.at("wall_s").is_number() ? solver.at("wall_s").get<double>() : NAN;
  if (solver.contains("stages") && solver.at("stages").is_array())
    for (const auto& st : solver.at("stages"))
      if (st.is_object() && st.value("stage", std::string()) == "overlaps" && st.contains("wall_s") &&
          st.at("wall_s").is_number())
        wall_s -= st.at("wall_s").get<double>();
  if (in.fail() || !(wall_s >= 0)) return "unknown";
  const std::time_t start = timegm(&tm) - std::time_t(std::floor(wall_s));
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

namespace {

std::string criteria_table(const ReportSummary& s) {
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

}  // namespace

std::string acceptance_section(const ReportPage& page) {
  return "<h2 id=\"accept\">13. Acceptance criteria</h2>" + criteria_table(page.sum);
}

}  // namespace burrbench::analysis
