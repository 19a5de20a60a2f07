#include "burrbench/analysis/criteria.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::analysis {
namespace {

std::string as_string(const toml::node* n, const std::string& file, const std::string& field) {
  if (!n || !n->is_string()) throw InputError(file, field, "a string");
  return n->as_string()->get();
}

double as_number(const toml::node* n, const std::string& file, const std::string& field) {
  if (!n || !(n->is_floating_point() || n->is_integer())) throw InputError(file, field, "a number");
  const double v = n->value<double>().value();
  if (!std::isfinite(v)) throw InputError(file, field, "a finite number");
  return v;
}

}  // namespace

Criteria read_criteria(const std::filesystem::path& path) {
  const std::string file = path.string();
  toml::table t;
  try {
    t = toml::parse_file(file);
  } catch (const toml::parse_error& e) {
    throw InputError(file, fmt::format("line {}", e.source().begin.line), "valid TOML",
                     std::string(e.description()));
  }
  for (const auto& [k, v] : t)
    if (k != "format" && k != "format_version" && k != "criterion")
      throw InputError(file, std::string(k.str()), "a known key (format, format_version, criterion)",
                       "unknown key");
  if (as_string(t.get("format"), file, "format") != "burrbench.criteria")
    throw InputError(file, "format", "\"burrbench.criteria\"");
  const std::string ver = as_string(t.get("format_version"), file, "format_version");
  if (ver.rfind("1.", 0) != 0) throw InputError(file, "format_version", "1.x", ver);
  const auto* arr = t.get_as<toml::array>("criterion");
  if (!arr || arr->empty()) throw InputError(file, "criterion", "an array of ≥ 1 [[criterion]] tables");

  const auto& names = metric_names();
  const std::set<std::string> known = {"name", "metric", "axis", "segment", "data",
                                       "recording", "min", "max"};
  Criteria c;
  for (std::size_t i = 0; i < arr->size(); ++i) {
    const std::string where = fmt::format("criterion[{}]", i);
    const auto* tab = (*arr)[i].as_table();
    if (!tab) throw InputError(file, where, "a table");
    for (const auto& [k, v] : *tab)
      if (!known.count(std::string(k.str())))
        throw InputError(file, where + "." + std::string(k.str()), "a known key", "unknown key");
    Criterion cr;
    cr.metric = as_string(tab->get("metric"), file, where + ".metric");
    if (std::find(names.begin(), names.end(), cr.metric) == names.end())
      throw InputError(file, where + ".metric", "one of " + fmt::format("{}", fmt::join(names, ", ")),
                       cr.metric);
    cr.name = tab->contains("name") ? as_string(tab->get("name"), file, where + ".name")
                                    : cr.metric;
    const auto* axis = tab->get("axis");
    if (!axis) throw InputError(file, where + ".axis", "x, y, z, magnitude or an array of them");
    if (const auto* a = axis->as_array()) {
      for (std::size_t k = 0; k < a->size(); ++k)
        cr.axes.push_back(as_string(a->get(k), file, fmt::format("{}.axis[{}]", where, k)));
    } else {
      cr.axes.push_back(as_string(axis, file, where + ".axis"));
    }
    if (cr.axes.empty()) throw InputError(file, where + ".axis", "at least one axis");
    for (const auto& a : cr.axes)
      if (a != "x" && a != "y" && a != "z" && a != "magnitude")
        throw InputError(file, where + ".axis", "x, y, z or magnitude", a);
    if (tab->contains("segment")) cr.segment = as_string(tab->get("segment"), file, where + ".segment");
    if (tab->contains("recording") && tab->contains("data"))
      throw InputError(file, where, "either `data` or `recording`, not both");
    if (tab->contains("recording"))
      cr.recording = as_string(tab->get("recording"), file, where + ".recording");
    if (tab->contains("data")) {
      cr.data = as_string(tab->get("data"), file, where + ".data");
      if (cr.data != "calibrate" && cr.data != "validate")
        throw InputError(file, where + ".data", "\"calibrate\" or \"validate\"", cr.data);
    }
    if (tab->contains("min")) cr.min = as_number(tab->get("min"), file, where + ".min");
    if (tab->contains("max")) cr.max = as_number(tab->get("max"), file, where + ".max");
    if (!cr.min && !cr.max) throw InputError(file, where, "a `min` or `max` threshold");
    if (cr.min && cr.max && *cr.min > *cr.max) throw InputError(file, where + ".max", "max ≥ min");
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
