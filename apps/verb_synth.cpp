// burrbench synth: a recording with known ground truth (model driven through a protocol).
#include <fmt/format.h>

#include <chrono>
#include <fstream>
#include <memory>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/output_files.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/synth.hpp"
#include "output_paths.hpp"
#include "step_option.hpp"
#include "verb_registry.hpp"

namespace {

namespace fs = std::filesystem;
using namespace burrbench;

struct Args {
  std::string sample, protocol, params, out, truth;
  bool overwrite = false;
  double noise_N = 0, lag_ms = 0, step_us = 0;
  std::vector<double> bias_N{0, 0, 0};
  double torque_noise_Nmm = 0, spindle_noise_Nmm = 0, spindle_idle_Nmm = 0, spindle_viscous = 0, spindle_lag_ms = 0;
  std::vector<double> torque_bias_Nmm{0, 0, 0};
  std::uint64_t seed = 1;
};

void refuse_overwriting_inputs(const Args& a) {
  apps::refuse_output_over_inputs(a.out, "--out", {a.sample, a.protocol, a.params});
  apps::refuse_output_over_inputs(a.truth, "--truth", {a.sample, a.protocol, a.params, a.out});
  apps::refuse_existing(a.out, "--out", a.overwrite);
  apps::refuse_existing(a.truth, "--truth", a.overwrite);
}

void run(const Args& a) {
  if (a.bias_N.size() != 3) throw InputError("command line", "--bias-N", "three numbers x,y,z (N)");
  if (a.torque_bias_Nmm.size() != 3)
    throw InputError("command line", "--torque-bias-Nmm", "three numbers x,y,z (N·mm)");
  for (auto [v, name] : {std::pair{a.torque_noise_Nmm, "--torque-noise-Nmm"}, {a.spindle_noise_Nmm, "--spindle-noise-Nmm"}})
    if (!(v >= 0) || !std::isfinite(v)) throw InputError("command line", name, "a finite σ ≥ 0 (N·mm)", fmt::format("{}", v));
  apps::check_step_us(a.step_us);
  refuse_overwriting_inputs(a);
  // Each input hashed as it is read (the recording's provenance), checked before writing.
  std::vector<InputFile> read;
  const auto sample = read_hashed(a.sample, read, data_schema::read_sample);
  const auto protocol = read_hashed(a.protocol, read, model::read_protocol);
  const auto params = read_hashed(a.params, read, data_schema::read_params);
  model::SynthOptions o;
  o.noise_N = a.noise_N;
  o.bias_N = {a.bias_N[0], a.bias_N[1], a.bias_N[2]};
  o.lag_ms = a.lag_ms;
  o.torque_noise_Nmm = a.torque_noise_Nmm;
  o.torque_bias_Nmm = {a.torque_bias_Nmm[0], a.torque_bias_Nmm[1], a.torque_bias_Nmm[2]};
  o.spindle_noise_Nmm = a.spindle_noise_Nmm;
  o.spindle_idle_Nmm = a.spindle_idle_Nmm;
  o.spindle_viscous_Nmm_per_krpm = a.spindle_viscous;
  o.spindle_lag_ms = a.spindle_lag_ms;
  o.seed = a.seed;
  o.replay.step_s = a.step_us * 1e-6;
  const Provenance prov = make_provenance_hashed(read);
  TerminalProgress progress("synth");
  const auto t0 = std::chrono::steady_clock::now();
  auto res = apps::with_step_option(
      a.step_us, [&] { return model::synthesize(sample, protocol, params, o, prov, &progress); });
  res.recording.meta.sample_id = fs::path(a.sample).stem().string();
  const auto truth = model::truth_json(res, sample, protocol, params, o, prov);
  check_unchanged(prov.inputs, "synth");
  data_schema::OutputFiles outputs;  // the recording and its truth appear together or not at all
  outputs.write(a.out, [&](const fs::path& p) { data_schema::write_recording(p, res.recording); });
  outputs.write(a.truth, [&](const fs::path& p) { data_schema::write_file_atomic(p, truth.dump(2) + "\n"); });
  outputs.commit(a.overwrite);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::string removed;
  for (const auto& [name, v] : truth["removed_mm3_by_class"].items())
    removed += fmt::format(" {}={:.6g}", name, v.get<double>());
  progress.finish(fmt::format("{} samples ({:.3f} s), {} buried, removed mm³:{}, wall {:.2f} s",
                              res.path.t_s.size(), res.path.duration_s, res.buried_samples, removed,
                              wall));
  fmt::print("wrote {} and {}\n", a.out, a.truth);
}

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("synth",
                                  "Write a recording with known ground truth: the model "
                                  "driven through a protocol on a sample");
  auto a = std::make_shared<Args>();
  cmd->add_option("--sample", a->sample, "sample volume (.h5)")->required();
  cmd->add_option("--protocol", a->protocol, "protocol (.toml, format burrbench.protocol)")
      ->required();
  cmd->add_option("--params", a->params, "true parameter set (.toml)")->required();
  cmd->add_option("--out", a->out, "recording to write (.h5)")->required();
  cmd->add_flag("--overwrite", a->overwrite, "replace an existing --out (or --truth) file (refused otherwise)");
  cmd->add_option("--truth", a->truth, "ground truth to write (.json)")->required();
  cmd->add_option("--noise-N", a->noise_N, "σ of Gaussian force noise per component (N)")
      ->capture_default_str();
  cmd->add_option("--bias-N", a->bias_N, "force bias x,y,z (N, sensor frame)")
      ->delimiter(',')
      ->expected(3);
  cmd->add_option("--lag-ms", a->lag_ms, "recorded force at t = true force at t − lag (ms)")
      ->capture_default_str();
  cmd->add_option("--torque-noise-Nmm", a->torque_noise_Nmm, "σ of Gaussian moment noise per component (N·mm)")
      ->capture_default_str();
  cmd->add_option("--torque-bias-Nmm", a->torque_bias_Nmm, "moment bias x,y,z (N·mm, sensor frame)")
      ->delimiter(',')->expected(3);
  cmd->add_option("--spindle-noise-Nmm", a->spindle_noise_Nmm, "σ of Gaussian noise on the spindle torque (N·mm)")
      ->capture_default_str();
  cmd->add_option("--spindle-idle-Nmm", a->spindle_idle_Nmm, "the drive's idle torque, added to the spindle torque (N·mm)")
      ->capture_default_str();
  cmd->add_option("--spindle-viscous-Nmm-per-krpm", a->spindle_viscous,
                  "viscous drag: + this × |rpm|/1000 on the spindle torque (N·mm)")->capture_default_str();
  cmd->add_option("--spindle-lag-ms", a->spindle_lag_ms,
                  "the spindle torque logged this much later than the force (ms; its own stream)")->capture_default_str();
  cmd->add_option("--seed", a->seed, "noise seed")->capture_default_str();
  cmd->add_option("--step-us", a->step_us, "replay step (µs; 0 = half the sample period; at most the sample period)")
      ->capture_default_str();
  cmd->callback([a] { run(*a); });
}
BURRBENCH_VERB("synth", setup);

}  // namespace
