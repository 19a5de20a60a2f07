#pragma once
// All metrics of an analysis input: per recording, per segment ("all" = every used
// sample) and per axis (x, y, z of the sensor frame and "magnitude" = |F|), and pooled
// per role ("calibrate" data kept apart from held-out "validate" data).
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/analysis/metrics.hpp"

namespace burrbench::analysis {

struct ReportData;  // report_data.hpp (which includes this header through criteria.hpp)

inline constexpr const char* kAxes[] = {"x", "y", "z", "magnitude"};

struct MetricRow {
  std::string recording_id;  // "" for the pooled row of a role
  std::string role;          // calibrate | validate
  std::string segment;       // "all" or a segment label
  std::string axis;          // x | y | z | magnitude
  AxisMetrics m;
};

std::vector<MetricRow> compute_metric_rows(const ReportData& in);

// Metric names as used in criteria files and JSON ("rmse_N", "nrmse", "r2", ...).
const std::vector<std::string>& metric_names();
double metric_value(const AxisMetrics& m, const std::string& name);  // name must be known

nlohmann::json metric_rows_to_json(const std::vector<MetricRow>& rows);

}  // namespace burrbench::analysis
