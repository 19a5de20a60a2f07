#include "burrbench/analysis/criteria.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace burrbench::analysis {

std::string model_risk_from(const std::string& influence, const std::string& consequence) {
  auto rank = [](const std::string& l) { return l == "high" ? 2 : l == "medium" ? 1 : 0; };
  const int r = rank(influence) + rank(consequence);
  return r <= 1 ? "low" : r == 2 ? "medium" : "high";
}

Criteria read_criteria(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  const std::string file = path.string();
  const toml::table t = data_schema::parse_toml_file(path);
  const data_schema::TomlView root(t, file, "", "docs/report.md");
  root.allow({"format", "format_version", "criterion", "context"});
  data_schema::check_format(file, "format", root.str("format"), "burrbench.criteria");
  data_schema::check_version(file, "format_version", root.str("format_version"), 1);
  const auto tables = root.tables("criterion");
  if (tables.empty()) root.fail("criterion", "an array of ≥ 1 [[criterion]] tables", "none");

  const auto& names = metric_names();
  Criteria c;
  if (const auto ctx = root.opt_table("context")) {  // 1.1
    ctx->allow({"question_of_interest", "context_of_use", "model_influence", "decision_consequence", "model_risk"});
    auto level = [&](std::string_view key, bool required) {
      const auto v = required ? std::optional<std::string>(ctx->str(key)) : ctx->opt_str(key);
      if (v && *v != "low" && *v != "medium" && *v != "high") ctx->fail(key, "\"low\", \"medium\" or \"high\"", *v);
      return v.value_or("");
    };
    ContextOfUse u;
    u.question_of_interest = ctx->str("question_of_interest");
    u.context_of_use = ctx->str("context_of_use");
    u.model_influence = level("model_influence", true);
    u.decision_consequence = level("decision_consequence", true);
    u.model_risk = level("model_risk", false);
    if (u.model_risk.empty()) {
      u.model_risk = model_risk_from(u.model_influence, u.decision_consequence);
      u.risk_derived = true;
    }
    c.context = u;
  }
  for (const auto& tab : tables) {
    tab.allow({"name", "metric", "axis", "segment", "data", "recording", "min", "max"});
    Criterion cr;
    cr.metric = tab.str("metric");
    if (std::find(names.begin(), names.end(), cr.metric) == names.end())
      tab.fail("metric", "one of " + fmt::format("{}", fmt::join(names, ", ")), cr.metric);
    cr.name = tab.str_or("name", cr.metric);
    const toml::node* axis = tab.node("axis");
    if (!axis) tab.fail("axis", "x, y, z, magnitude or an array of them", "missing");
    if (axis->is_array()) cr.axes = tab.strings("axis");
    else cr.axes.push_back(tab.str("axis"));
    if (cr.axes.empty()) tab.fail("axis", "at least one axis");
    for (const auto& a : cr.axes)
      if (a != "x" && a != "y" && a != "z" && a != "magnitude") tab.fail("axis", "x, y, z or magnitude", a);
    cr.segment = tab.str_or("segment", cr.segment);
    if (tab.has("recording") && tab.has("data"))
      throw InputError(file, tab.path(), "either `data` or `recording`, not both");
    cr.recording = tab.str_or("recording", cr.recording);
    if (tab.has("data")) {
      cr.data = tab.str("data");
      if (cr.data != "calibrate" && cr.data != "validate")
        tab.fail("data", "\"calibrate\" or \"validate\"", cr.data);
    }
    cr.min = tab.opt_num("min");
    cr.max = tab.opt_num("max");
    if (!cr.min && !cr.max) throw InputError(file, tab.path(), "a `min` or `max` threshold");
    if (cr.min && cr.max && *cr.min > *cr.max) tab.fail("max", "max ≥ min");
    c.criteria.push_back(std::move(cr));
  }
  return c;
}

std::vector<CriterionResult> evaluate_criteria(const Criteria& c, const std::vector<MetricRow>& rows,
                                               const std::string& criteria_file) {
  std::vector<CriterionResult> out;
  for (std::size_t i = 0; i < c.criteria.size(); ++i) {
    const auto& cr = c.criteria[i];
    for (const auto& axis : cr.axes) {
      const MetricRow* row = nullptr;
      for (const auto& r : rows) {
        const bool scope = cr.recording.empty() ? (r.recording_id.empty() && r.role == cr.data)
                                                : r.recording_id == cr.recording;
        if (scope && r.segment == cr.segment && r.axis == axis) {
          row = &r;
          break;
        }
      }
      if (!row)
        throw InputError(criteria_file, fmt::format("criterion[{}]", i),
                         "data that exists (recording, role and segment of the experiment)",
                         cr.recording.empty() ? fmt::format("no {} data in segment \"{}\"", cr.data, cr.segment)
                                              : fmt::format("no recording \"{}\" with segment \"{}\"",
                                                            cr.recording, cr.segment));
      const double v = metric_value(row->m, cr.metric);
      // NaN (undefined metric, e.g. no samples) never passes.
      const bool pass = std::isfinite(v) && (!cr.min || v >= *cr.min) && (!cr.max || v <= *cr.max);
      out.push_back({i, axis, v, pass});
    }
  }
  return out;
}

}  // namespace burrbench::analysis
