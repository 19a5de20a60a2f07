// burrbench calibrate: fit α, C1, μ per bone class (and the recordings' nuisances) to the
// recorded forces of an experiment; writes DIR/fit.json and DIR/params.toml.
#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "burrbench/analysis/criteria.hpp"
#include "burrbench/calibration/calibrate.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/output_folder.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "report_prediction.hpp"
#include "library_versions.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;
using namespace burrbench;

struct Args {
  std::string experiment, out, criteria;
  calibration::CalibrateOptions options;
  bool no_cv = false, no_profiles = false, white_noise = false, no_discretization = false, no_depth = false,
       overwrite = false;
  std::string derivatives = "sensitivities";
};

void run(const Args& a) {
  calibration::CalibrateOptions o = a.options;
  o.cross_validate = !a.no_cv;
  o.profiles = !a.no_profiles;
  o.noise_inflation = !a.white_noise;
  o.discretization_check = !a.no_discretization;
  o.depth_check = !a.no_depth;
  o.derivatives = a.derivatives == "fd" ? calibration::Derivatives::kFiniteDifferences
                                        : calibration::Derivatives::kSensitivities;
  calibration::validate(o);  // before any output folder is made
  const auto manifest = data_schema::read_manifest(a.experiment);
  // Criteria fixed before the fit: checked now, their hash recorded in fit.json.
  std::string criteria_sha, criteria_utc;
  if (!a.criteria.empty()) {
    (void)analysis::read_criteria(a.criteria);
    criteria_sha = sha256_file(a.criteria);
    criteria_utc = make_provenance({}).created_utc;  // when they were fixed: before the fit starts
  }
  std::vector<fs::path> inputs{manifest.file};
  for (const auto& s : manifest.samples) inputs.push_back(s.path);
  for (const auto& r : manifest.recordings) inputs.push_back(r.path);
  // The criteria are an input too: --overwrite never replaces them (issue 59, N1).
  if (!a.criteria.empty()) inputs.emplace_back(a.criteria);
  // Written whole at the end, or not at all (a failed or interrupted fit leaves nothing).
  data_schema::OutputFolder folder(a.out, "--out", a.overwrite);
  folder.refuse_inputs(
      {"fit.json", "params.toml", "prediction.h5"}, inputs);
  TerminalProgress progress("calibrate");
  o.progress = &progress;
  auto res = calibration::calibrate(a.experiment, o);
  if (!a.criteria.empty()) {
    if (sha256_file(a.criteria) != criteria_sha)
      throw InputError(a.criteria, "file", "unchanged during the fit (criteria are fixed before it)", "changed");
    const std::string path = fs::absolute(a.criteria).string();
    res.fit.settings["criteria"] = {{"path", path}, {"sha256", criteria_sha}, {"recorded_utc", criteria_utc}};
    res.fit.provenance.inputs.push_back({path, criteria_sha});
  }
  folder.write([&](const fs::path& dir) {
    data_schema::write_fit(dir / "fit.json", res.fit);
    data_schema::write_params(dir / "params.toml", res.params);
    // The prediction at the optimum (fitted constants and nuisances, the band) with its
    // context: `burrbench report DIR` renders it without replaying, so the report needs
    // neither the sample nor the recordings.
    auto prediction = apps::predict_for_report(
        a.experiment, res.params, {"calibrate", &res.fit, true, "", nullptr, "params.toml", o.threads, false});
    for (const char* name : {"fit.json", "params.toml"}) {
      const std::string path = fs::absolute(folder.target() / name).string(), sha = sha256_file(dir / name);
      prediction.provenance.inputs.push_back({path, sha});
      if (std::string(name) == "params.toml") prediction.context["params"] = {{"path", path}, {"sha256", sha}};
    }
    data_schema::write_prediction(dir / "prediction.h5", prediction);
  });
  folder.commit();
  const fs::path fit = folder.target() / "fit.json", params = folder.target() / "params.toml";
  // Replays and time are the whole calibration's; the iterations the optimum's refinement's
  // (fit.json solver.iterations), not the starts', profiles' or checks' solves.
  progress.finish(fmt::format("done: {} replays in {:.1f} s (refinement of the optimum: {} iterations)",
                              res.fit.solver.replays, res.fit.solver.wall_s, res.fit.solver.iterations));
  std::cout << res.summary
            << fmt::format("wrote {} and {} (with prediction.h5 at the optimum for `burrbench report {}`)\n", fit.string(),
                           params.string(), folder.target().string());
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("calibrate", "Fit alpha, C1 and mu per bone class to an "
                                               "experiment's recorded forces, with intervals");
  auto a = std::make_shared<Args>();
  cmd->add_option("EXPERIMENT,--experiment", a->experiment, "experiment manifest (.toml), as --experiment E.toml or just E.toml")->required();
  cmd->add_option("--out", a->out, "output directory (fit.json, params.toml): new or empty")->required();
  cmd->add_flag("--overwrite", a->overwrite, "write into an existing --out folder, replacing fit.json and params.toml");
  cmd->add_option("--criteria", a->criteria,
                  "acceptance criteria (.toml) fixed before the fit: their SHA-256 goes into fit.json, and "
                  "validate --fit reports whether the criteria it uses are these");
  cmd->add_option("--threads", a->options.threads, "replay threads")->capture_default_str();
  cmd->add_option("--max-iterations", a->options.max_iterations, "Ceres iterations")->capture_default_str();
  cmd->add_option("--bootstrap", a->options.bootstrap, "block-bootstrap replicates (0: none)")
      ->capture_default_str();
  cmd->add_option("--bootstrap-block-s", a->options.bootstrap_block_s, "bootstrap block length (s)")
      ->capture_default_str();
  cmd->add_option("--starts", a->options.starts,
                  "global search starts (0: the manifest's fit.multistart, default 16)")
      ->capture_default_str();
  cmd->add_option("--solve-starts", a->options.solve_starts,
                  "starts with the lowest pre-fit cost that get a local solve")->capture_default_str();
  cmd->add_option("--start-iterations", a->options.start_iterations,
                  "local iterations of each solved start")->capture_default_str();
  cmd->add_option("--derivatives", a->derivatives,
                  "Jacobian: exact forward sensitivities or central finite differences")
      ->check(CLI::IsMember({"sensitivities", "fd"}))
      ->capture_default_str();
  cmd->add_flag("--no-profiles", a->no_profiles,
                "skip the profile likelihoods (verdicts then come from the covariance)");
  cmd->add_option("--profile-points", a->options.profile_points, "profile points per side, at most")
      ->capture_default_str();
  cmd->add_flag("--no-cross-validation", a->no_cv, "skip leave-one-out cross-validation");
  cmd->add_flag("--white-noise", a->white_noise,
                "assume white residuals: do not widen the intervals by the residuals' AR(1) factor");
  cmd->add_flag("--coarse-to-fine", a->options.coarse_to_fine,
                "global search at voxels merged by 2, then refinement, profiles and intervals at the sample's own");
  cmd->add_flag("--no-discretization-check", a->no_discretization,
                "skip the refit on the sample with voxels merged by 2 (each estimate's discretization error)");
  cmd->add_flag("--no-depth-check", a->no_depth,
                "skip the refit with a depth offset free for the recordings whose depth nothing corrects");
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("calibrate", setup);

}  // namespace
