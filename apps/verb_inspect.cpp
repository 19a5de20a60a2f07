// burrbench inspect FILE: summary + validation of any burrbench file (exit 2 if invalid).
#include <iostream>
#include <memory>

#include "burrbench/data_schema/inspect.hpp"
#include "verb_registry.hpp"

namespace {
void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "inspect", "Summarise a burrbench file (recording, sample, params, experiment, fit) and validate it");
  auto file = std::make_shared<std::string>();
  cmd->add_option("FILE", *file, "the file to inspect")->required();
  cmd->callback([file] {
    // describe_file validates fully; an invalid file raises InputError → one line, exit 2.
    std::cout << burrbench::data_schema::describe_file(*file) << "valid\n";
  });
}
BURRBENCH_VERB("inspect", setup);
}  // namespace
