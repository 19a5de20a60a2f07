// burrbench inspect FILE: summary + validation of any burrbench file (exit 2 if invalid).
// data_schema describes its formats, analysis its own (criteria, metrics, analysis).
#include <iostream>
#include <memory>

#include "burrbench/analysis/inspect.hpp"
#include "burrbench/data_schema/inspect.hpp"
#include "verb_registry.hpp"

namespace {
void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "inspect", "Summarise and validate any burrbench file (recording, sample, params, experiment, fit, "
                 "prediction, criteria, metrics, analysis)");
  auto file = std::make_shared<std::string>();
  cmd->add_option("FILE", *file, "the file to inspect")->required();
  cmd->callback([file] {
    using namespace burrbench;
    // Every reader validates fully; an invalid file raises InputError → one line, exit 2.
    const auto analysis_summary = analysis::describe_file(*file, data_schema::declared_format(*file));
    std::cout << (analysis_summary ? *analysis_summary : data_schema::describe_file(*file)) << "valid\n";
  });
}
BURRBENCH_VERB("inspect", setup);
}  // namespace
