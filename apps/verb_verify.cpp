// burrbench verify: solution verification. Replays every recording at the sample's voxel
// size l and at l/2, 2l, and at half the replay step, and estimates the discretization
// error in force and removed volume (model/verification.hpp, docs/calibration.md).
#include <fmt/format.h>

#include <iostream>
#include <memory>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/model/verification.hpp"
#include "output_paths.hpp"
#include "quadrature_option.hpp"
#include "step_option.hpp"
#include "verb_registry.hpp"

namespace {

using namespace burrbench;

struct Args {
  std::string experiment, params, out;
  double step_us = 0, sigma_N = 0;
  bool overwrite = false;
  int threads = 2;
  bool whole_sample = false;
  std::string quadrature = "lens";
  bool no_erosion = false;
};

void run(const Args& a) {
  apps::check_step_us(a.step_us);
  const model::Quadrature quadrature = apps::quadrature_option(a.quadrature);
  if (!(a.sigma_N >= 0))
    throw InputError("command line", "--sigma-N", "a noise level ≥ 0 N (0 = the manifest's or estimated)");
  const model::Experiment e = model::load_experiment(a.experiment);
  const auto params = data_schema::read_params(a.params);
  const model::ModelParams mp = model::ModelParams::from(params);
  model::check_covers(params, e.samples, a.params);
  if (!a.out.empty()) {
    std::vector<std::string> ins{a.experiment, a.params};
    for (const auto& s : e.manifest.samples) ins.push_back(s.path.string());
    for (const auto& r : e.manifest.recordings) ins.push_back(r.path.string());
    apps::refuse_output_over_inputs(a.out, "--out", ins);
    apps::refuse_existing(a.out, "--out", a.overwrite);
  }
  model::VerifyOptions opt;
  opt.step_s = a.step_us * 1e-6;
  if (a.sigma_N > 0) opt.sigma_N = a.sigma_N;
  opt.threads = a.threads;
  opt.crop = !a.whole_sample;
  opt.quadrature = quadrature;
  opt.erosion = !a.no_erosion;
  TerminalProgress progress("verify");
  const auto study = apps::with_step_option(
      a.step_us, [&] { return model::verify_convergence(e, mp, opt, &progress); });

  std::cout << fmt::format("solution verification ({} quadrature): change against (l, dt); RMS per axis over the used samples\n",
                           model::quadrature_name(study.quadrature));
  for (const auto& r : study.reach) {
    const auto count = [](const std::array<std::size_t, 3>& d) { return double(d[0]) * double(d[1]) * double(d[2]); };
    std::cout << fmt::format("sample {}: replayed {}×{}×{} of its {}×{}×{} voxels ({:.3g} %), those within reach of the burr\n",
                             r.sample_id, r.replayed_dims[0], r.replayed_dims[1], r.replayed_dims[2], r.dims[0], r.dims[1],
                             r.dims[2], 100 * count(r.replayed_dims) / count(r.dims));
  }
  for (const auto& r : study.recordings) {
    std::cout << fmt::format("{} ({} samples)\n", r.id, r.samples);
    std::cout << fmt::format("  {:<5} {:>9} {:>9} {:>12} {:>12} {:>9}", "level", "voxel mm", "step µs", "RMS change N",
                             "max change N", "peak N");
    for (const auto& [id, name] : study.classes) std::cout << fmt::format(" {:>14}", name + " mm³");
    std::cout << fmt::format(" {:>7}\n", "wall s");
    for (const auto& L : r.levels) {
      std::cout << fmt::format("  {:<5} {:>9.4g} {:>9.4g} {:>12.4g} {:>12.4g} {:>9.4g}", L.level, L.voxel_mm,
                               1e6 * L.step_s, L.rms_change_N, L.max_change_N, L.peak_N);
      for (const auto& [id, name] : study.classes) std::cout << fmt::format(" {:>14.5g}", L.removed_mm3[id]);
      std::cout << fmt::format(" {:>7.2f}\n", L.wall_s);
    }
    std::cout << fmt::format("  discretization error in force: {:.3g} N (voxel {:.3g} N, order {}; step {:.3g} N)\n",
                             r.error_N, r.voxel.error,
                             std::isfinite(r.voxel.order) ? fmt::format("{:.2f}", r.voxel.order) : "not observed",
                             r.step_error_N);
  }
  std::cout << fmt::format("sensor noise: {} ({})\n",
                           std::isfinite(study.sigma_N) ? fmt::format("{:.3g} N", study.sigma_N) : "unknown",
                           study.sigma_source);
  std::cout << "verdict: " << study.verdict() << "\n";
  for (const std::string& w : model::alignment_warnings(e)) fmt::print(stderr, "warning: {}\n", w);
  if (!a.out.empty()) {
    data_schema::write_file_atomic(a.out, model::to_json(study).dump(2) + "\n");
    std::cout << "wrote " << a.out << "\n";
  }
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("verify",
                                  "Solution verification: replay at voxel sizes l, l/2, 2l and at half the "
                                  "step; the discretization error in force against the sensor noise");
  auto a = std::make_shared<Args>();
  cmd->add_option("EXPERIMENT,--experiment", a->experiment, "experiment manifest (.toml), as --experiment E.toml or just E.toml")->required();
  cmd->add_option("--params", a->params, "parameter set (.toml)")->required();
  cmd->add_option("--out", a->out, "also write the study as JSON");
  cmd->add_flag("--overwrite", a->overwrite, "replace an existing --out file (refused otherwise)");
  cmd->add_option("--step-us", a->step_us, "base replay step (µs; 0 = half the sample period; at most the sample period)")->capture_default_str();
  cmd->add_option("--sigma-N", a->sigma_N, "sensor noise per axis (N; 0 = the manifest's sensor.sigma_N, else estimated)")
      ->capture_default_str();
  cmd->add_flag("--whole-sample", a->whole_sample,
                "replay every voxel of each sample, not only those within reach of the burr (the same figures to "
                "rounding, at up to 8× the memory of the whole sample for l/2)");
  apps::add_quadrature_option(cmd, a->quadrature);
  cmd->add_flag("--no-erosion", a->no_erosion, "forces only: the contact force's convergence without erosion");
  cmd->add_option("--threads", a->threads, "replays run at once (each recording at each level; at most one at l/2)")
      ->capture_default_str()
      ->check(CLI::Range(1, model::kMaxThreads));
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("verify", setup);

}  // namespace
