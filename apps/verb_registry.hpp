#pragma once
// Each verb file registers itself with BURRBENCH_VERB(name, setup): setup adds a
// subcommand to the root app with its options and a callback that does the work.
// The callback may throw InputError (exit 2) or call set_exit_code (e.g. gate fail = 1).
#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace burrbench::apps {

using VerbSetup = void (*)(CLI::App& root);

struct VerbEntry {
  std::string name;
  VerbSetup setup;
};

std::vector<VerbEntry>& verb_registry();

struct VerbRegistration {
  VerbRegistration(const char* name, VerbSetup setup) { verb_registry().push_back({name, setup}); }
};

void set_exit_code(int code);
int exit_code();

}  // namespace burrbench::apps

#define BURRBENCH_VERB_CAT2(a, b) a##b
#define BURRBENCH_VERB_CAT(a, b) BURRBENCH_VERB_CAT2(a, b)
#define BURRBENCH_VERB(name, setup) \
  static const ::burrbench::apps::VerbRegistration BURRBENCH_VERB_CAT(verb_reg_, __LINE__)(name, setup)
