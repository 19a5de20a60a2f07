// burrbench inspect FILE: summary + validation of any burrbench file (exit 2 if invalid).
// data_schema knows its own formats; analysis's (criteria, metrics, analysis) are read
// here, where both folders are available.
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/analysis/analysis_input.hpp"
#include "burrbench/analysis/criteria.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/inspect.hpp"
#include "burrbench/data_schema/nesting.hpp"
#include "verb_registry.hpp"

namespace {
using namespace burrbench;

std::string describe_criteria(const std::string& file) {
  const auto c = analysis::read_criteria(file);
  std::string s = fmt::format("acceptance criteria (burrbench.criteria), {} criteria\n", c.criteria.size());
  for (const auto& k : c.criteria)
    s += fmt::format("  {}: {} [{}] of {}{}{}\n", k.name, k.metric, fmt::join(k.axes, ","),
                     k.recording.empty() ? k.data : "recording " + k.recording,
                     k.min ? fmt::format(" ≥ {}", *k.min) : "", k.max ? fmt::format(" ≤ {}", *k.max) : "");
  return s;
}

std::string describe_metrics(const std::string& file) {
  std::ifstream in(file, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  data_schema::check_json_nesting(text, file);
  const auto j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw InputError(file, "<file>", "a JSON object", "unparsable JSON");
  const auto v = j.value("format_version", std::string());
  if (v.rfind("1.", 0) != 0) throw InputError(file, "format_version", "1.x", "\"" + v + "\"");
  if (!j.contains("rows") || !j["rows"].is_array()) throw InputError(file, "rows", "an array of metric rows", "missing");
  std::string s = fmt::format("metrics (burrbench.metrics), {} rows", j["rows"].size());
  if (j.contains("pass") && j["pass"].is_boolean()) s += fmt::format(", release gate {}", j["pass"].get<bool>() ? "PASS" : "FAIL");
  return s + "\n";
}

std::string describe_analysis(const std::filesystem::path& file) {
  // analysis.json goes with predictions.csv in the same folder: both are read and checked.
  const auto in = analysis::read_analysis_input(file.parent_path().empty() ? "." : file.parent_path());
  std::size_t n = 0;
  for (const auto& r : in.recordings) n += r.t_s.size();
  return fmt::format("analysis directory (burrbench.analysis), {} recordings, {} samples, {} sample volumes\n",
                     in.recordings.size(), n, in.samples.size());
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "inspect", "Summarise and validate any burrbench file (recording, sample, params, experiment, fit, "
                 "prediction, criteria, metrics, analysis)");
  auto file = std::make_shared<std::string>();
  cmd->add_option("FILE", *file, "the file to inspect")->required();
  cmd->callback([file] {
    // Every reader validates fully; an invalid file raises InputError → one line, exit 2.
    const std::string name = data_schema::declared_format(*file);
    if (name == "burrbench.criteria") std::cout << describe_criteria(*file);
    else if (name == "burrbench.metrics") std::cout << describe_metrics(*file);
    else if (name == analysis::kAnalysisFormat) std::cout << describe_analysis(*file);
    else std::cout << data_schema::describe_file(*file);
    std::cout << "valid\n";
  });
}
BURRBENCH_VERB("inspect", setup);
}  // namespace
