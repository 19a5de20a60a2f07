// burrbench: thin entry point. Verbs live in verb_*.cpp, one file per verb.
#include <algorithm>
#include <csignal>
#include <exception>
#include <filesystem>
#include <iostream>
#include <new>

#include <CLI/CLI.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/version.hpp"
#include "cli_suggest.hpp"
#include "verb_registry.hpp"

namespace burrbench::apps {
std::vector<VerbEntry>& verb_registry() {
  static std::vector<VerbEntry> v;
  return v;
}
namespace {
int g_exit_code = 0;
}
void set_exit_code(int code) { g_exit_code = code; }
int exit_code() { return g_exit_code; }
}  // namespace burrbench::apps

int main(int argc, char** argv) {
  using namespace burrbench;
  set_invocation(argc, argv);
  // A file-size limit (ulimit -f) must be a write error naming the file, not a kill.
  std::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"burrbench — validate and calibrate a voxel burr–bone drilling model "
               "against a physical drilling rig"};
  app.set_version_flag("--version", std::string(software_version()));
  app.require_subcommand(1);
  auto& verbs = apps::verb_registry();
  std::sort(verbs.begin(), verbs.end(), [](auto& a, auto& b) { return a.name < b.name; });
  for (const auto& v : verbs) v.setup(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
    // One line, prefixed like every other error, with the nearest verb or option when the
    // mistake looks like a typo ("calibrat", "--experment").
    std::cerr << "burrbench: " << apps::explain_parse_error(app, e, argc, argv) << "\n";
    return 2;
  } catch (const InputError& e) {
    std::cerr << "burrbench: " << e.what() << "\n";
    return 2;
  } catch (const std::bad_alloc&) {
    const std::string& f = file_being_read();
    std::cerr << "burrbench: " << (f.empty() ? std::string("error") : f)
              << ": out of memory" << (f.empty() ? "" : " while reading it")
              << " (a memory limit, or an input too large for this machine)\n";
    return 3;
  } catch (const std::filesystem::filesystem_error& e) {
    // One line naming the path and the system's reason, not the library's raw text
    // ("filesystem error: cannot create directories: ... [path]"): issue 59, N7.
    std::string op = e.what();
    if (const auto p = op.find("filesystem error: "); p != std::string::npos) op = op.substr(p + 18);
    if (const auto p = op.find(": "); p != std::string::npos) op = op.substr(0, p);
    std::cerr << "burrbench: " << (e.path1().empty() ? std::string("error") : e.path1().string()) << ": " << op
              << ": " << e.code().message() << "\n";
    return 3;
  } catch (const InvariantError& e) {
    std::cerr << "burrbench: " << e.what() << " — please report this\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "burrbench: error: " << e.what() << "\n";
    return 3;
  }
  return apps::exit_code();
}
