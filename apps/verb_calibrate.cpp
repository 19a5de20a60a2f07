// burrbench calibrate: fit α, C1, μ per bone class (and the recordings' nuisances) to the
// recorded forces of an experiment; writes DIR/fit.json and DIR/params.toml.
#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "burrbench/calibration/calibrate.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;
using namespace burrbench;

struct Args {
  std::string experiment, out;
  calibration::CalibrateOptions options;
  bool no_cv = false;
};

void run(const Args& a) {
  if (a.options.threads < 1 || a.options.threads > 64)
    throw InputError("command line", "--threads", "1..64");
  if (a.options.bootstrap < 0 || a.options.bootstrap > 10000)
    throw InputError("command line", "--bootstrap", "0..10000 replicates");
  if (a.options.max_iterations < 1 || a.options.max_iterations > 1000)
    throw InputError("command line", "--max-iterations", "1..1000");
  if (!(a.options.bootstrap_block_s > 0))
    throw InputError("command line", "--bootstrap-block-s", "a block length > 0 s");
  std::error_code ec;
  if (fs::exists(a.out) && !fs::is_directory(a.out))
    throw InputError(a.out, "--out", "a directory (or a path to create one)", "an existing file");
  fs::create_directories(a.out, ec);
  if (ec) throw InputError(a.out, "--out", "a directory that can be created", ec.message());
  TerminalProgress progress("calibrate");
  calibration::CalibrateOptions o = a.options;
  o.cross_validate = !a.no_cv;
  o.progress = &progress;
  const auto res = calibration::calibrate(a.experiment, o);
  const fs::path fit = fs::path(a.out) / "fit.json", params = fs::path(a.out) / "params.toml";
  data_schema::write_fit(fit, res.fit);
  data_schema::write_params(params, res.params);
  progress.finish(fmt::format("{} iterations, {} replays, {:.1f} s", res.fit.solver.iterations,
                              res.fit.solver.replays, res.fit.solver.wall_s));
  std::cout << res.summary << fmt::format("wrote {} and {}\n", fit.string(), params.string());
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("calibrate", "Fit alpha, C1 and mu per bone class to an "
                                               "experiment's recorded forces, with intervals");
  auto a = std::make_shared<Args>();
  cmd->add_option("--experiment", a->experiment, "experiment manifest (.toml)")->required();
  cmd->add_option("--out", a->out, "output directory (fit.json, params.toml)")->required();
  cmd->add_option("--threads", a->options.threads, "replay threads")->capture_default_str();
  cmd->add_option("--max-iterations", a->options.max_iterations, "Ceres iterations")->capture_default_str();
  cmd->add_option("--bootstrap", a->options.bootstrap, "block-bootstrap replicates (0: none)")
      ->capture_default_str();
  cmd->add_option("--bootstrap-block-s", a->options.bootstrap_block_s, "bootstrap block length (s)")
      ->capture_default_str();
  cmd->add_flag("--no-cross-validation", a->no_cv, "skip leave-one-out cross-validation");
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("calibrate", setup);

}  // namespace
