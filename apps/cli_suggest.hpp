#pragma once
// Command-line typos get a suggestion: CLI11 reports "A subcommand is required" for
// `burrbench calibrat` and "--experiment is required" for `--experment`; the user needs
// to hear which word was not understood and what was probably meant.
#include <string>

#include <CLI/CLI.hpp>

namespace burrbench::apps {

// Edit distance (insertions, deletions, substitutions, adjacent swaps).
std::size_t edit_distance(const std::string& a, const std::string& b);

// The message for a failed parse: an unknown verb or option (with the nearest known one
// when it is close), else CLI11's own message, naming the verb it concerns.
std::string explain_parse_error(const CLI::App& app, const CLI::ParseError& e, int argc, char** argv);

}  // namespace burrbench::apps
