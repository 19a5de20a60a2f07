// burrbench replay: the simulated burr follows every recording of an experiment;
// predicted forces (on the burr and at the sensor) with diagnostics, beside the measured.
#include <fmt/format.h>

#include <chrono>
#include <map>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/output_files.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/model/experiment.hpp"
#include "output_paths.hpp"
#include "quadrature_option.hpp"
#include "step_option.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;
using namespace burrbench;

struct Args {
  std::string experiment, params, out, csv;
  double step_us = 0;
  bool no_erosion = false, overwrite = false;
  int threads = 2;
  std::string quadrature = "lens";
};

void run(const Args& a) {
  apps::check_step_us(a.step_us);
  const model::Quadrature quadrature = apps::quadrature_option(a.quadrature);
  const auto t0 = std::chrono::steady_clock::now();
  const model::Experiment e = model::load_experiment(a.experiment);
  std::vector<InputFile> params_file;  // hashed as it is read, as e's files
  const auto params = read_hashed(a.params, params_file, data_schema::read_params);
  const model::ModelParams mp = model::ModelParams::from(params);
  model::check_covers(params, e.samples, a.params);
  std::vector<fs::path> inputs{a.experiment, a.params};
  for (const auto& s : e.manifest.samples) inputs.push_back(s.path);
  for (const auto& r : e.manifest.recordings) inputs.push_back(r.path);
  {
    const std::vector<std::string> ins(inputs.begin(), inputs.end());
    apps::refuse_output_over_inputs(a.out, "--out", ins);
    apps::refuse_output_over_inputs(a.csv, "--csv", ins);
    apps::refuse_same_outputs(a.out, "--out", a.csv, "--csv");
    apps::refuse_existing(a.out, "--out", a.overwrite);
    apps::refuse_existing(a.csv, "--csv", a.overwrite);
  }
  // The files as read; the same order as before (experiment, parameters, samples, recordings).
  std::vector<InputFile> hashed{e.inputs.front(), params_file.front()};
  hashed.insert(hashed.end(), e.inputs.begin() + 1, e.inputs.end());
  const Provenance prov = make_provenance_hashed(hashed);
  model::PredictOptions opt;  // a plain replay: the manifest's lag, nothing added
  opt.replay.step_s = a.step_us * 1e-6;
  opt.replay.erosion = !a.no_erosion;
  opt.replay.quadrature = quadrature;
  opt.exclude_buried = e.manifest.fit.buried == data_schema::BuriedPolicy::kExclude;
  opt.threads = a.threads;

  TerminalProgress progress("replay");
  opt.progress = &progress;
  const auto prediction = apps::with_step_option(
      a.step_us, [&] { return model::predict_experiment(e, mp, opt); });
  const auto& preds = prediction.recordings;
  std::size_t samples = 0, buried = 0;
  std::array<double, model::kMaxClasses> removed{};
  for (std::size_t i = 0; i < preds.size(); ++i) {
    const auto& p = preds[i];
    std::size_t b = 0;
    for (auto x : p.buried) b += x;
    samples += p.t_s.size();
    buried += b;
    for (int k = 0; k < model::kMaxClasses; ++k)
      removed[std::size_t(k)] += p.removed_mm3[std::size_t(k)];
    std::cout << fmt::format("  {}: {}\n", e.recordings[i].id, e.recordings[i].registration.text());
  }
  for (const model::RemovedOverlap& o : prediction.overlaps) fmt::print(stderr, "warning: {}\n", o.text());
  for (const std::string& w : model::alignment_warnings(e)) fmt::print(stderr, "warning: {}\n", w);
  data_schema::OutputFiles outputs;  // --out and --csv appear together or not at all
  outputs.write(a.out, [&](const fs::path& p) { model::write_prediction(p, prediction, prov); });
  if (!a.csv.empty()) outputs.write(a.csv, [&](const fs::path& p) { model::write_prediction_csv(p, preds); });
  check_unchanged(prov.inputs, "replay");  // else the prediction would name files it did not come from
  outputs.commit(a.overwrite);
  std::string rem;
  for (int k = 1; k < model::kMaxClasses; ++k) {
    if (removed[std::size_t(k)] == 0) continue;
    std::string name = std::to_string(k);
    for (const auto& [id, s] : e.samples)
      if (auto c = s.classes.find(std::uint8_t(k)); c != s.classes.end()) name = c->second;
    rem += fmt::format(" {}={:.6g}", name, removed[std::size_t(k)]);
  }
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  fmt::print("replay: {} recordings, {} samples, {} buried, removed mm³:{}, wall {:.2f} s\n",
             preds.size(), samples, buried, rem.empty() ? " none" : rem, wall);
  fmt::print("wrote {}{}\n", a.out, a.csv.empty() ? "" : " and " + a.csv);
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("replay",
                                  "Replay an experiment's recordings through the model: "
                                  "predicted force at every sample");
  auto a = std::make_shared<Args>();
  cmd->add_option("EXPERIMENT,--experiment", a->experiment, "experiment manifest (.toml), as --experiment E.toml or just E.toml")->required();
  cmd->add_option("--params", a->params, "parameter set (.toml)")->required();
  cmd->add_option("--out", a->out, "prediction file to write (.h5, format burrbench.prediction)")
      ->required();
  cmd->add_option("--csv", a->csv, "also write the prediction as CSV");
  cmd->add_flag("--overwrite", a->overwrite, "replace an existing --out or --csv file (refused otherwise)");
  cmd->add_option("--step-us", a->step_us, "replay step (µs; 0 = half the sample period; at most the sample period)")
      ->capture_default_str();
  cmd->add_flag("--no-erosion", a->no_erosion, "forces only, the volume is not eroded");
  apps::add_quadrature_option(cmd, a->quadrature);
  cmd->add_option("--threads", a->threads, "recordings replayed at once")->capture_default_str()->check(CLI::Range(1, model::kMaxThreads));
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("replay", setup);

}  // namespace
