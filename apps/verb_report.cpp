// `burrbench report DIR [--out FILE]`: the self-contained validation report of a calibrate
// or validate directory, from its prediction.h5 (the series and the run's context), its
// fit.json and its criteria.toml — never the sample or the recordings (docs/report.md).
// Without --out it goes to DIR/report/report.html, never into the current folder (whose
// fit.json or metrics.json might be a user's). The report's folder is an output folder
// like calibrate's: new or empty unless --overwrite, written whole or not at all.
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <memory>

#include "burrbench/analysis/report.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/output_folder.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "library_versions.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;

struct Options {
  std::string dir, out, assets;
  std::string context;
  bool overwrite = false;
};

// DIR's files as the report's inputs. A directory of the format before prediction 2.4
// (analysis.json, or a prediction without its context) is refused with what to rerun.
burrbench::analysis::ReportInputs read_inputs(const fs::path& dir) {
  using namespace burrbench;
  const fs::path pred = dir / "prediction.h5";
  const bool old_format = fs::exists(dir / "analysis.json") || !fs::exists(pred);
  analysis::ReportInputs in;
  if (!old_format) in.prediction = data_schema::read_prediction(pred);
  if (old_format || in.prediction.context.is_null())
    throw InputError(pred.string(), "/context",
                     "a prediction with its context (rerun `burrbench validate`, or `calibrate`, to write this "
                     "directory again: the report reads prediction.h5, fit.json and criteria.toml alone)",
                     fs::exists(dir / "analysis.json") ? "an analysis directory of the older format (analysis.json)"
                     : old_format                        ? "no prediction.h5"
                                                         : "a prediction without one");
  in.prediction_file = pred.string();
  in.verification = in.prediction.context.value("verification", nlohmann::json());
  // A validate run replayed fixed constants: a fit.json lying in its folder is its own only
  // when validate --fit put it there (the prediction's provenance names it by hash).
  if (fs::exists(dir / "fit.json")) {
    const std::string sha = sha256_file(dir / "fit.json");
    const auto& inputs = in.prediction.provenance.inputs;
    if (in.prediction.context.value("made_by", std::string()) == "calibrate" ||
        std::any_of(inputs.begin(), inputs.end(), [&](const InputFile& f) { return f.sha256 == sha; }))
      in.fit = data_schema::read_fit(dir / "fit.json");
  }
  if (fs::exists(dir / "criteria.toml")) {
    in.criteria = analysis::read_criteria(dir / "criteria.toml");
    in.criteria_sha256 = sha256_file(dir / "criteria.toml");
    // Named as validate read them (the prediction's provenance), when this is that copy.
    const auto& inputs = in.prediction.provenance.inputs;
    const auto it = std::find_if(inputs.begin(), inputs.end(),
                                 [&](const InputFile& f) { return f.sha256 == in.criteria_sha256; });
    in.criteria_path = it != inputs.end() ? it->path : (dir / "criteria.toml").string();
  }
  return in;
}

void run(const Options& o) {
  using namespace burrbench;
  std::error_code ec;
  // DIR first: a wrong DIR is the mistake to name, not the output folder.
  if (!fs::is_directory(o.dir, ec)) throw InputError(o.dir, "DIR", "a calibrate or validate directory", "not a directory");
  const fs::path out = o.out.empty() ? fs::path(o.dir) / "report" / "report.html" : fs::path(o.out);
  if (out.filename().empty() || fs::is_directory(out, ec))
    throw InputError(o.out, "--out", "a report file path (e.g. OUT/report.html)", "a folder");
  const analysis::ReportInputs in = read_inputs(o.dir);
  const fs::path parent = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  data_schema::OutputFolder folder(parent, "--out", o.overwrite);
  // DIR's files are inputs: a report written into DIR itself must not replace them.
  std::vector<fs::path> inputs;
  for (const char* f : {"prediction.h5", "fit.json", "params.toml", "criteria.toml"}) inputs.push_back(fs::path(o.dir) / f);
  folder.refuse_inputs({out.filename().string(), "fit.json", "residuals.csv", "metrics.json"}, inputs);
  analysis::ReportSummary s;
  folder.write([&](const fs::path& staging) {
    s = analysis::write_report(in, staging / out.filename(), {o.assets, o.context, nullptr, apps::library_versions()});
  });
  folder.commit();
  std::cout << "report: " << (folder.target() / out.filename()).string() << " (" << s.recordings << " recordings, "
            << s.samples << " samples)\n";
  if (s.has_criteria) std::cout << "acceptance criteria: " << (s.pass ? "PASS" : "FAIL") << "\n";
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("report", "Write the self-contained HTML validation report of an analysis directory");
  auto o = std::make_shared<Options>();
  cmd->add_option("DIR", o->dir, "calibrate or validate directory (prediction.h5, fit.json, criteria.toml)")
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
                  "context-of-use statement (when the prediction states none: calibrate's; validate stores its own)");
  cmd->callback([o] { run(*o); });
}

BURRBENCH_VERB("report", setup);

}  // namespace
