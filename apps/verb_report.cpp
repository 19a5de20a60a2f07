// `burrbench report DIR [--out FILE]`: the self-contained validation report of an analysis
// directory (written by calibrate or validate; layout in docs/report.md). Without --out it
// goes to DIR/report/report.html, never into the current folder (whose fit.json or
// metrics.json might be a user's). The report's folder is an output folder like
// calibrate's: new or empty unless --overwrite, written whole or not at all.
#include <filesystem>
#include <iostream>
#include <memory>

#include "burrbench/analysis/report.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/output_folder.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "analysis_replay.hpp"
#include "burrbench/analysis/analysis_input.hpp"
#include "burrbench/data_schema/atomic_file.hpp"
#include "library_versions.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;

struct Options {
  std::string dir, out, assets;
  std::string context;
  bool overwrite = false;
};

void run(const Options& o) {
  using namespace burrbench;
  std::error_code ec;
  // DIR first: a wrong DIR is the mistake to name, not the output folder.
  if (!fs::is_directory(o.dir, ec)) throw InputError(o.dir, "DIR", "an analysis directory", "not a directory");
  const fs::path out = o.out.empty() ? fs::path(o.dir) / "report" / "report.html" : fs::path(o.out);
  if (out.filename().empty() || fs::is_directory(out, ec))
    throw InputError(o.out, "--out", "a report file path (e.g. OUT/report.html)", "a folder");
  const fs::path parent = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  data_schema::OutputFolder folder(parent, "--out", o.overwrite);
  // DIR's files are inputs: a report written into DIR itself must not replace them.
  std::vector<fs::path> inputs;
  for (const char* f : {"analysis.json", "predictions.csv", "wrench.csv", "band.csv", "fit.json", "params.toml", "criteria.toml"})
    inputs.push_back(fs::path(o.dir) / f);
  folder.refuse_inputs({out.filename().string(), "analysis.json", "predictions.csv", "wrench.csv", "band.csv",
                        "fit.json", "residuals.csv", "metrics.json", "prediction.h5"},
                       inputs);
  analysis::ReportSummary s;
  folder.write([&](const fs::path& staging) {
    fs::path dir = o.dir;
    if (!fs::exists(dir / "analysis.json") && fs::exists(dir / "fit.json")) {
      // An older calibrate directory: replay its fit into an analysis input and the
      // prediction file beside the report (the report itself only reads files), as
      // calibrate writes them today, then render that.
      model::ExperimentPrediction prediction;
      auto in = apps::replay_calibrate_directory(dir, o.context, &prediction);
      model::write_prediction(staging / "prediction.h5", prediction, in.provenance);
      analysis::write_analysis_input(staging, in);
      data_schema::copy_file_atomic(dir / "fit.json", staging / "fit.json");
      dir = staging;
    }
    s = analysis::write_report(dir, staging / out.filename(),
                               {o.assets, o.context, nullptr, apps::library_versions()});
  });
  folder.commit();
  std::cout << "report: " << (folder.target() / out.filename()).string() << " (" << s.recordings << " recordings, "
            << s.samples << " samples)\n";
  if (s.has_criteria) std::cout << "acceptance criteria: " << (s.pass ? "PASS" : "FAIL") << "\n";
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("report", "Write the self-contained HTML validation report of an analysis directory");
  auto o = std::make_shared<Options>();
  cmd->add_option("DIR", o->dir, "analysis directory (analysis.json, predictions.csv, fit.json, criteria.toml)")
      ->required();
  cmd->add_option("--out", o->out,
                  "report file, in a new or empty folder; CSVs, metrics.json and fit.json go beside it "
                  "(default: DIR/report/report.html)");
  cmd->add_flag("--overwrite", o->overwrite,
                "write into an existing folder, replacing the report's files of the same names");
  cmd->add_option("--assets", o->assets,
                  "report assets folder (template, JS, CSS, node_modules/uplot); default: "
                  "$BURRBENCH_REPORT_ASSETS, <bin>/../share/burrbench/report, or the source tree's analysis/report");
  cmd->add_option("--context-of-use", o->context,
                  "context-of-use statement (when DIR holds only fit.json; validate stores its own)");
  cmd->callback([o] { run(*o); });
}

BURRBENCH_VERB("report", setup);

}  // namespace
