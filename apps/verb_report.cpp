// `burrbench report DIR [--out FILE]`: the self-contained validation report of an analysis
// directory (written by calibrate or validate; layout in docs/report.md). Without --out it
// goes to DIR/report/report.html, never into the current folder (whose fit.json or
// metrics.json might be a user's).
#include <filesystem>
#include <iostream>
#include <memory>

#include "burrbench/analysis/report.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "verb_registry.hpp"

namespace {

struct Options {
  std::string dir, out, assets;
  std::string context;
};

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("report", "Write the self-contained HTML validation report of an analysis directory");
  auto o = std::make_shared<Options>();
  cmd->add_option("DIR", o->dir, "analysis directory (analysis.json, predictions.csv, fit.json, criteria.toml)")
      ->required();
  cmd->add_option("--out", o->out,
                  "report file; CSVs, metrics.json and fit.json go beside it (default: DIR/report/report.html)");
  cmd->add_option("--assets", o->assets,
                  "report assets folder (template, JS, CSS, node_modules/uplot); default: "
                  "$BURRBENCH_REPORT_ASSETS, <bin>/../share/burrbench/report, or the source tree's analysis/report");
  cmd->add_option("--context-of-use", o->context,
                  "context-of-use statement (when DIR holds only fit.json; validate stores its own)");
  cmd->callback([o] {
    using namespace burrbench::analysis;
    burrbench::TerminalProgress progress("report");
    const std::string out = o->out.empty() ? (std::filesystem::path(o->dir) / "report" / "report.html").string() : o->out;
    const auto s = write_report(o->dir, out, {o->assets, o->context, &progress});
    std::cout << "report: " << s.html.string() << " (" << s.recordings << " recordings, " << s.samples
              << " samples)\n";
    if (s.has_criteria) std::cout << "acceptance criteria: " << (s.pass ? "PASS" : "FAIL") << "\n";
  });
}

BURRBENCH_VERB("report", setup);

}  // namespace
