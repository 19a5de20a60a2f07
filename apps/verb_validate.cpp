// `burrbench validate`: the release gate. Replays an experiment with fixed parameters
// (no fitting), computes the metrics, compares them with acceptance criteria, writes the
// report, and exits 0 (pass), 1 (fail) or 2 (bad input). docs/report.md.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/output_folder.hpp"
#include "burrbench/analysis/criteria.hpp"
#include "burrbench/analysis/report.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/model/verification.hpp"
#include "report_prediction.hpp"
#include "library_versions.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;
using namespace burrbench;

struct Args {
  std::string experiment, params, criteria, out, assets, fit;
  std::string context = "Release gate of the voxel burr–bone drilling model: does the model, with "
                        "the given constants, reproduce the forces recorded on the rig well enough "
                        "for the simulator's intended use?";
  bool no_tare = false, no_verification = false, overwrite = false;
  int threads = 2;
};

// validate --fit: the parameter set must hold the constants that fit held at its optimum
// (as calibrate wrote them to params.toml), or the report would show another fit's
// intervals beside these constants.
void check_params_from_fit(const data_schema::ParameterSet& params, const std::string& params_file,
                           const data_schema::FitResult& fit, const std::string& fit_file) {
  for (const auto& [label, c] : params.classes)
    for (const char* name : {"alpha", "c1", "mu"}) {
      const auto* p = fit.parameter(label, name);
      if (!p) throw InputError(fit_file, "parameters", fmt::format("class {} ({}) {} of the parameter set", int(label), c.name, name), "missing");
      const double want = std::isfinite(p->held) ? p->held : p->estimate;
      const double have = std::string(name) == "alpha" ? c.alpha_N_per_mm2 : std::string(name) == "c1" ? c.c1_N_per_mm2 : c.mu;
      if (!(want == have || std::abs(have - want) <= 1e-9 * std::abs(want)))
        throw InputError(params_file, fmt::format("classes.{}.{}", c.name, name),
                         fmt::format("the value the fit held ({:.10g}; --fit {})", want, fit_file), fmt::format("{:.10g}", have));
    }
}

void run(const Args& a) {
  std::error_code ec;
  // Everything that can be checked cheaply is checked before the replay. Each file is
  // hashed as it is read: the report records those SHA-256s, and none may change before
  // it is written (check_unchanged).
  std::vector<InputFile> read;  // criteria, parameters, fit
  const auto criteria = read_hashed(a.criteria, read, analysis::read_criteria);
  const auto params = read_hashed(a.params, read, data_schema::read_params);
  const auto manifest = data_schema::read_manifest(a.experiment);
  std::optional<data_schema::FitResult> fit;
  if (!a.fit.empty()) {
    fit = read_hashed(a.fit, read, data_schema::read_fit);
    check_params_from_fit(params, a.params, *fit, a.fit);
  }
  // Written whole at the end, or not at all (a failed or interrupted replay leaves nothing).
  data_schema::OutputFolder folder(a.out, "--out", a.overwrite);
  // The criteria and parameters are copied beside the report, unless they already are
  // the folder's own (a re-run with --overwrite): then they stay as they are.
  const bool criteria_there = fs::equivalent(a.criteria, folder.target() / "criteria.toml", ec);
  const bool params_there = fs::equivalent(a.params, folder.target() / "params.toml", ec);
  {
    std::vector<fs::path> inputs{manifest.file};
    for (const auto& s : manifest.samples) inputs.push_back(s.path);
    for (const auto& r : manifest.recordings) inputs.push_back(r.path);
    std::vector<std::string> names{"report.html", "residuals.csv", "metrics.json", "prediction.h5"};
    if (!criteria_there) {
      names.push_back("criteria.toml");
      inputs.push_back(a.criteria);
    }
    if (!params_there) {
      names.push_back("params.toml");
      inputs.push_back(a.params);
    }
    if (!a.fit.empty()) {
      names.push_back("fit.json");
      inputs.push_back(a.fit);
    }
    folder.refuse_inputs(names, inputs);
  }

  TerminalProgress progress("validate");
  // The report's inputs, in memory: the prediction (at the fit's nuisances with --fit)
  // with its context, the fit, the criteria and the verification study. The same
  // prediction goes to prediction.h5, from which `burrbench report DIR` renders it again.
  analysis::ReportInputs in;
  in.prediction = apps::predict_for_report(a.experiment, params,
                                           {"validate", fit ? &*fit : nullptr, !a.no_tare, a.context, &progress,
                                            a.params, a.threads, true});
  in.prediction_file = (folder.target() / "prediction.h5").string();
  in.criteria = criteria;
  in.criteria_path = fs::absolute(a.criteria).string();
  in.criteria_sha256 = read[0].sha256;
  // A criterion that selects data this experiment lacks is bad input, named by its file
  // (before the verification's replays).
  (void)analysis::evaluate_criteria(criteria, analysis::compute_metric_rows(analysis::report_data(in)), a.criteria);
  if (!a.no_verification) {
    // Solution verification: the same constants at l/2, 2l and half the step.
    TerminalProgress vp("verify");
    model::VerifyOptions vo;
    vo.threads = a.threads;
    // Read again: a file changed since the prediction read it shows at the check below.
    in.verification = model::to_json(model::verify_convergence(model::load_experiment(a.experiment),
                                                               model::ModelParams::from(params), vo, &vp));
    in.prediction.context["verification"] = in.verification;
  }
  auto& prov = in.prediction.provenance.inputs;
  in.prediction.context["params"] = {{"path", fs::absolute(a.params).string()}, {"sha256", read[1].sha256}};
  prov.push_back({fs::absolute(a.params).string(), read[1].sha256});
  prov.push_back({in.criteria_path, in.criteria_sha256});
  if (fit) {
    in.fit = fit;
    prov.push_back({fs::absolute(a.fit).string(), read[2].sha256});
  }
  analysis::ReportSummary s;
  folder.write([&](const fs::path& dir) {
    check_unchanged(prov, "validate");  // else the report names files it did not come from
    data_schema::write_prediction(dir / "prediction.h5", in.prediction);
    if (!criteria_there) data_schema::copy_file_atomic(a.criteria, dir / "criteria.toml");
    if (!params_there) data_schema::copy_file_atomic(a.params, dir / "params.toml");
    if (!a.fit.empty()) data_schema::copy_file_atomic(a.fit, dir / "fit.json");
    analysis::ReportOptions ro{a.assets, a.context, nullptr, apps::library_versions()};
    ro.copy_fit = false;  // the folder keeps the --fit file's exact copy (provenance names its hash)
    s = analysis::write_report(in, dir / "report.html", ro);
  });
  folder.commit();
  progress.finish(fmt::format("{} recordings, {} samples", s.recordings, s.samples));

  std::size_t failed = 0;
  for (const auto& r : s.results) failed += !r.pass;
  for (const auto& [id, r] : in.prediction.context.at("recordings").items())
    if (!r.value("registration", std::string()).empty())
      std::cout << fmt::format("  {}: {}\n", id, r.value("registration", std::string()));
  std::cout << fmt::format("report: {}\n", (folder.target() / "report.html").string());
  for (const auto& r : s.results) {
    const auto& c = s.criteria.criteria[r.index];
    std::cout << fmt::format("  {} {} [{}] {} = {:.4g}\n", r.pass ? "PASS" : "FAIL", c.name, r.axis,
                             c.metric, r.value);
  }
  if (!s.criteria_predate_text.empty()) std::cout << "criteria: " << s.criteria_predate_text << "\n";
  if (in.verification.is_object()) std::cout << "verification: " << in.verification.value("verdict", std::string()) << "\n";
  std::cout << fmt::format("gate: {} ({} of {} checks failed)\n", s.pass ? "PASS" : "FAIL", failed,
                           s.results.size());
  apps::set_exit_code(s.pass ? 0 : 1);
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand(
      "validate", "Release gate: replay with fixed parameters, check acceptance criteria, write the "
                  "report; exit 0 pass, 1 fail, 2 bad input");
  auto a = std::make_shared<Args>();
  cmd->add_option("EXPERIMENT,--experiment", a->experiment, "experiment manifest (.toml), as --experiment E.toml or just E.toml")->required();
  cmd->add_option("--params", a->params, "parameter set (.toml, burrbench.params)")->required();
  cmd->add_option("--criteria", a->criteria, "acceptance criteria (.toml, burrbench.criteria)")->required();
  cmd->add_option("--out", a->out, "output directory (report.html, prediction.h5, residuals.csv, metrics.json): new or empty")
      ->required();
  cmd->add_flag("--overwrite", a->overwrite, "write into an existing --out folder, replacing the files of the same names");
  cmd->add_option("--assets", a->assets, "report assets folder (see `burrbench report --help`)");
  cmd->add_option("--fit", a->fit,
                  "the fit.json the parameters came from: the replay applies its nuisances (lag, biases, pose "
                  "correction, spindle terms) and the report shows its intervals, correlations, search and "
                  "whether the criteria were fixed before it (calibrate --criteria)");
  cmd->add_option("--context-of-use", a->context, "context-of-use statement for the report");
  cmd->add_option("--threads", a->threads, "replays run at once (recordings; in the verification, recordings and levels)")->capture_default_str()->check(CLI::Range(1, model::kMaxThreads));
  cmd->add_flag("--no-tare", a->no_tare, "do not subtract the no-contact mean force (sensor bias)");
  cmd->add_flag("--no-verification", a->no_verification,
                "skip the solution verification (replays at l/2, 2l and half the step; the report's section 3)");
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("validate", setup);

}  // namespace
