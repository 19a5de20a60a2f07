#include "burrbench/analysis/metric_table.hpp"

#include "burrbench/analysis/report_data.hpp"

#include <cmath>
#include <map>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::analysis {
namespace {

// Used samples of one recording that fall in [start, end) (or all when span is null).
struct Series {
  std::vector<double> t;
  std::vector<double> m[4], p[4];
  void add(double ti, const glm::dvec3& mi, const glm::dvec3& pi) {
    t.push_back(ti);
    for (int a = 0; a < 3; ++a) {
      m[a].push_back(mi[a]);
      p[a].push_back(pi[a]);
    }
    m[3].push_back(glm::length(mi));
    p[3].push_back(glm::length(pi));
  }
  void append(const Series& o) {
    for (int a = 0; a < 4; ++a) {
      m[a].insert(m[a].end(), o.m[a].begin(), o.m[a].end());
      p[a].insert(p[a].end(), o.p[a].begin(), o.p[a].end());
    }
    t.insert(t.end(), o.t.begin(), o.t.end());
  }
};

Series select(const RecordingSeries& r, const SegmentSpan* span) {
  Series s;
  for (std::size_t i = 0; i < r.t_s.size(); ++i) {
    if (!r.used[i]) continue;
    if (span && (r.t_s[i] < span->start_s || r.t_s[i] >= span->end_s)) continue;
    s.add(r.t_s[i], r.measured_N[i], r.predicted_N[i]);
  }
  return s;
}

void emit(std::vector<MetricRow>& rows, const std::string& rec, const std::string& role,
          const std::string& seg, const Series& s, bool use_time) {
  for (int a = 0; a < 4; ++a) {
    // Pooled series concatenate recordings: their times are not one time base, so the
    // Sprague–Geers integrals use equal weights there.
    rows.push_back({rec, role, seg, kAxes[a],
                    compute_axis_metrics(use_time ? std::span<const double>(s.t)
                                                  : std::span<const double>(),
                                         s.m[a], s.p[a])});
  }
}

}  // namespace

std::vector<MetricRow> compute_metric_rows(const ReportData& in) {
  std::vector<MetricRow> rows;
  // role → segment label → pooled series (std::map: stable, sorted output order)
  std::map<std::string, std::map<std::string, Series>> pooled;
  for (const auto& r : in.recordings) {
    const Series all = select(r, nullptr);
    emit(rows, r.id, r.role, "all", all, true);
    pooled[r.role]["all"].append(all);
    std::map<std::string, Series> by_label;  // a label may span several segments
    for (const auto& span : r.segments) by_label[span.label].append(select(r, &span));
    for (const auto& [label, s] : by_label) {
      emit(rows, r.id, r.role, label, s, true);
      pooled[r.role][label].append(s);
    }
  }
  for (const auto& [role, segs] : pooled)
    for (const auto& [label, s] : segs) emit(rows, "", role, label, s, false);
  return rows;
}

const std::vector<std::string>& metric_names() {
  static const std::vector<std::string> names = {
      "n",           "rmse_N",        "nrmse",          "r2",
      "theil_u2",    "sg_magnitude",  "sg_phase",       "sg_combined",
      "peak_measured_N", "peak_predicted_N", "peak_error_N", "peak_error_rel",
      "resid_lag1_autocorr", "durbin_watson", "measured_range_N"};
  return names;
}

double metric_value(const AxisMetrics& m, const std::string& name) {
  static const std::map<std::string, double AxisMetrics::*> fields = {
      {"rmse_N", &AxisMetrics::rmse_N},
      {"nrmse", &AxisMetrics::nrmse},
      {"r2", &AxisMetrics::r2},
      {"theil_u2", &AxisMetrics::theil_u2},
      {"sg_magnitude", &AxisMetrics::sg_magnitude},
      {"sg_phase", &AxisMetrics::sg_phase},
      {"sg_combined", &AxisMetrics::sg_combined},
      {"peak_measured_N", &AxisMetrics::peak_measured_N},
      {"peak_predicted_N", &AxisMetrics::peak_predicted_N},
      {"peak_error_N", &AxisMetrics::peak_error_N},
      {"peak_error_rel", &AxisMetrics::peak_error_rel},
      {"resid_lag1_autocorr", &AxisMetrics::resid_lag1_autocorr},
      {"durbin_watson", &AxisMetrics::durbin_watson},
      {"measured_range_N", &AxisMetrics::measured_range_N}};
  if (name == "n") return double(m.n);
  const auto it = fields.find(name);
  BURRBENCH_CHECK(it != fields.end(), "unknown metric " + name);
  return m.*(it->second);
}

nlohmann::json metric_rows_to_json(const std::vector<MetricRow>& rows) {
  auto out = nlohmann::json::array();
  for (const auto& r : rows) {
    nlohmann::json j = {{"recording", r.recording_id}, {"role", r.role},
                        {"segment", r.segment}, {"axis", r.axis}};
    for (const auto& name : metric_names()) {
      const double v = metric_value(r.m, name);
      j[name] = std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);  // NaN → null
    }
    out.push_back(std::move(j));
  }
  return out;
}

}  // namespace burrbench::analysis
