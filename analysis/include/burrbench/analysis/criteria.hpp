#pragma once
// Acceptance criteria (TOML, format "burrbench.criteria"; docs/report.md) and their
// evaluation against the metric table: the release gate's pass/fail.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "burrbench/analysis/metric_table.hpp"

namespace burrbench::analysis {

struct Criterion {
  std::string name;                // free text shown in the report
  std::string metric;              // one of metric_names()
  std::vector<std::string> axes;   // each must pass
  std::string segment = "all";
  std::string data = "validate";   // pooled role: calibrate | validate
  std::string recording;           // instead of `data`: one recording id
  std::optional<double> min, max;  // at least one
};

struct Criteria {
  std::vector<Criterion> criteria;
};

struct CriterionResult {
  std::size_t index = 0;  // into Criteria::criteria
  std::string axis;
  double value = 0;       // NaN when undefined (always a fail)
  bool pass = false;
};

// InputError (file, field, expectation) on unknown keys, metrics, axes, bad thresholds.
Criteria read_criteria(const std::filesystem::path& path);
// InputError naming `criteria_file` when a criterion selects data that is not there
// (unknown recording or segment, no data of that role).
std::vector<CriterionResult> evaluate_criteria(const Criteria& c, const std::vector<MetricRow>& rows,
                                               const std::string& criteria_file);
inline bool all_pass(const std::vector<CriterionResult>& r) {
  for (const auto& x : r)
    if (!x.pass) return false;
  return true;
}

}  // namespace burrbench::analysis
