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

// The structured context of use (ASME V&V 40), from the criteria's optional [context]
// table: what the model is asked, for what, how much the decision leans on it and what a
// wrong decision costs. Levels are "low" | "medium" | "high".
struct ContextOfUse {
  std::string question_of_interest, context_of_use;
  std::string model_influence, decision_consequence;
  std::string model_risk;  // given, or derived from influence and consequence
  bool risk_derived = false;
};

// V&V 40's risk map, in its simplest form: the two levels' ranks (0, 1, 2) summed, 0–1 →
// low, 2 → medium, 3–4 → high.
std::string model_risk_from(const std::string& influence, const std::string& consequence);

struct Criteria {
  std::vector<Criterion> criteria;
  std::optional<ContextOfUse> context;  // format 1.1
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
