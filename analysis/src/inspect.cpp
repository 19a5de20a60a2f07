#include "burrbench/analysis/inspect.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "burrbench/analysis/criteria.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/json_input.hpp"

namespace burrbench::analysis {
namespace {

std::string describe_criteria(const std::filesystem::path& path) {
  const auto c = read_criteria(path);
  std::string s = fmt::format("acceptance criteria (burrbench.criteria), {} criteria\n", c.criteria.size());
  for (const auto& k : c.criteria)
    s += fmt::format("  {}: {} [{}] of {}{}{}\n", k.name, k.metric, fmt::join(k.axes, ","),
                     k.recording.empty() ? k.data : "recording " + k.recording,
                     k.min ? fmt::format(" ≥ {}", *k.min) : "", k.max ? fmt::format(" ≤ {}", *k.max) : "");
  return s;
}

std::string describe_metrics(const std::filesystem::path& path) {
  const std::string file = path.string();
  const auto j = data_schema::read_json_file(path);
  data_schema::JsonView o(j, file, "");  // a summary: other keys are not checked here
  data_schema::check_version(file, "format_version", o.str("format_version"), 1);
  if (!j.contains("rows") || !j["rows"].is_array()) throw InputError(file, "rows", "an array of metric rows", "missing");
  std::string s = fmt::format("metrics (burrbench.metrics), {} rows", j["rows"].size());
  if (j.contains("pass") && j["pass"].is_boolean())
    s += fmt::format(", release gate {}", j["pass"].get<bool>() ? "PASS" : "FAIL");
  s += "\n";
  // Each check as `validate` printed it, so a reviewer reads the gate from the file alone.
  if (j.contains("criteria") && j["criteria"].is_array())
    for (const auto& c : j["criteria"]) {
      if (!c.is_object()) continue;
      const auto& v = c.contains("value") ? c["value"] : nlohmann::json();
      s += fmt::format("  {} {} [{}] = {}\n",
                       !c.contains("pass") || !c["pass"].is_boolean() ? "????" : c["pass"].get<bool>() ? "PASS" : "FAIL",
                       c.value("name", std::string("?")), c.value("axis", std::string("?")),
                       v.is_number() ? fmt::format("{:.4g}", v.get<double>()) : std::string("n/a"));
    }
  if (j.contains("criteria_predate_fit")) {
    const auto& d = j["criteria_predate_fit"];
    s += fmt::format("criteria fixed before the fit: {}\n", d.is_boolean() ? (d.get<bool>() ? "yes" : "NO (changed after it)")
                                                                         : "not established");
  }
  return s;
}

}  // namespace

std::optional<std::string> describe_file(const std::filesystem::path& path, const std::string& declared_format) {
  if (declared_format == "burrbench.criteria") return describe_criteria(path);
  if (declared_format == "burrbench.metrics") return describe_metrics(path);
  return std::nullopt;
}

}  // namespace burrbench::analysis
