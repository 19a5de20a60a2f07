#pragma once
// Builds a synthetic calibration experiment with known truth in a folder, using the real
// `burrbench synth` command: a block of bone with compact (label 1, χ = 1) for x < 4 mm
// and trabecular-like bone (label 2, χ = 0.6) for x ≥ 4 mm, flat top; three protocols
// (plunge, sweep across the class boundary, polishing strokes across it); noise, bias and
// a position→force lag on every recording. Shared by tests/calibration and bench/.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <fmt/format.h>

#include "../burrbench_cli.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::calibration::testing {

struct ReferenceSpec {
  double voxel_mm = 0.1;
  double radius_mm = 1.0;   // R/l = 10
  double time_scale = 1.0;     // > 1: slower moves, more strokes (longer recordings)
  double noise_N = 0.02;
  double lag_ms = 4.0;
  std::uint64_t seed = 1;
  bool trabecular = true;      // false: every move stays over compact bone
  bool erosion = true;         // false: the truth has α = ∞ (no erosion)
  bool depth_offset = false;   // fit a depth offset per recording
  // Also synthesise the sensor's moments and the spindle's load (noise 0.05 N·mm and
  // 0.005 N·mm, a moment bias, the drive's idle and viscous torque) and write
  // experiment_wrench.toml fitting them beside experiment.toml (issue 13).
  bool wrench = false;
  int multistart = 4;  // global search: manifest start + 3 Latin-hypercube points
  // truth
  double alpha1 = 150, c1_1 = 16, mu1 = 0.4;
  double alpha2 = 60, c1_2 = 6, mu2 = 0.3;
};

using burrbench::testing::burrbench_cli;

inline void write_text(const std::filesystem::path& p, const std::string& s) {
  std::ofstream f(p);
  f << s;
  if (!f) throw std::runtime_error("cannot write " + p.string());
}

inline data_schema::SampleVolume reference_sample(const ReferenceSpec& s) {
  data_schema::SampleVolume v;
  const double ex = 8, ey = 4 + 2 * s.radius_mm, ez = 2;
  v.voxel_mm = s.voxel_mm;
  v.dims = {std::size_t(std::lround(ex / s.voxel_mm)), std::size_t(std::lround(ey / s.voxel_mm)),
            std::size_t(std::lround(ez / s.voxel_mm))};
  v.origin_mm = glm::dvec3(0.5 * s.voxel_mm);
  v.labels.assign(v.voxel_count(), 2);
  v.fraction.assign(v.voxel_count(), 0.6f);
  for (std::size_t z = 0; z < v.dims[2]; ++z)
    for (std::size_t y = 0; y < v.dims[1]; ++y)
      for (std::size_t x = 0; x < v.dims[0]; ++x)
        if (v.centre_mm(x, y, z).x < 4.0) {
          v.labels[v.index(x, y, z)] = 1;
          v.fraction[v.index(x, y, z)] = 1.f;
        }
  v.segmentation_json = "{}";
  return v;
}

// The head of a protocol file (1 kHz, 40 000 rpm, burr axis tilted in x–z) with its start
// point above (x0, y0, top) and a vertical approach.
inline std::string protocol_head(const std::string& name, double R, double x0, double y0, double top) {
  return fmt::format(R"(format = "burrbench.protocol"
format_version = "1.0"
name = "{}"
sample_rate_hz = 1000.0
spindle_rpm = 40000.0
[burr]
radius_mm = {}
axis = [0.8, 0.0, 0.6]
spin_sign = 1
[start]
point_mm = [{}, {}, {}]
approach = [0.0, 0.0, -1.0]
)", name, R, x0, y0, top + R + 0.1);
}

// `burrbench synth` of one protocol in `dir` (sample.h5, truth.toml) into NAME.h5.
inline void synth_recording(const std::filesystem::path& dir, const std::string& name,
                            const std::string& burrbench, double noise_N, glm::dvec3 bias_N,
                            double lag_ms, std::uint64_t seed, const std::string& extra = "") {
  const std::string cmd = fmt::format(
      "'{}' synth --sample '{}' --protocol '{}' --params '{}' --out '{}' --truth '{}' "
      "--noise-N {} --bias-N {},{},{} --lag-ms {} --seed {} {} > /dev/null 2>&1",
      burrbench, (dir / "sample.h5").string(), (dir / (name + ".protocol.toml")).string(),
      (dir / "truth.toml").string(), (dir / (name + ".h5")).string(),
      (dir / (name + ".truth.json")).string(), noise_N, bias_N.x, bias_N.y, bias_N.z, lag_ms, seed, extra);
  if (std::system(cmd.c_str()) != 0) throw std::runtime_error("synth failed: " + cmd);
}

// Writes everything into `dir` and returns the manifest path. `burrbench`: the CLI.
inline std::filesystem::path make_reference_experiment(const std::filesystem::path& dir,
                                                       const ReferenceSpec& s,
                                                       const std::string& burrbench) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  data_schema::write_sample(dir / "sample.h5", reference_sample(s));
  data_schema::ParameterSet truth;
  const double inf = INFINITY;
  truth.classes[1] = {"compact", s.erosion ? s.alpha1 : inf, s.c1_1, s.mu1};
  truth.classes[2] = {"trabecular", s.erosion ? s.alpha2 : inf, s.c1_2, s.mu2};
  data_schema::write_params(dir / "truth.toml", truth);
  const double R = s.radius_mm, top = 2.0, k = s.time_scale;
  const double yc = 2.0 + R;
  auto protocol = [&](const std::string& name, double x0, const std::string& moves) {
    write_text(dir / (name + ".protocol.toml"), protocol_head(name, R, x0, yc, top) + moves);
  };
  // Over compact only (trabecular = false) every lateral move ends 1.5 R short of x = 4.
  const double sweep_x0 = s.trabecular ? 2.0 : 1.0, sweep_len = s.trabecular ? 4.0 : 4.0 - 1.5 * R - 1.0;
  // Polishing strokes over each class separately: erosion is what determines α.
  const double pol_x0 = 1.0, pol_len = 4.0 - 1.5 * R - 1.0;
  // Plunge to a depth, dwell, retract.
  auto plunge_moves = [&](double depth_mm) {
    return fmt::format(R"([[moves]]
type = "plunge"
depth_mm = {}
feed_mm_s = {}
[[moves]]
type = "dwell"
duration_s = {}
[[moves]]
type = "retract"
speed_mm_s = 2.0
)", depth_mm, 1.0 / k, 0.2 * k);
  };
  protocol("plunge", s.trabecular ? 2.0 : 1.5, plunge_moves(0.3 * R));
  if (s.trabecular)  // a second plunge into trabecular bone, as its own recording
    protocol("plunge2", 6.0, plunge_moves(0.4 * R));
  protocol("sweep", sweep_x0, fmt::format(R"([[moves]]
type = "plunge"
depth_mm = {}
feed_mm_s = 1.0
[[moves]]
type = "sweep"
direction = [1.0, 0.0, 0.0]
length_mm = {}
speed_mm_s = {}
[[moves]]
type = "sweep"
spindle_rpm = 60000.0
direction = [0.0, -1.0, 0.0]
length_mm = {}
speed_mm_s = {}
[[moves]]
type = "retract"
speed_mm_s = 2.0
)", 0.25 * R, sweep_len, 2.0 / k, 0.8 * R, 2.0 / k));
  const std::string polish_moves = fmt::format(R"([[moves]]
type = "plunge"
depth_mm = {}
feed_mm_s = 1.0
[[moves]]
type = "polish"
direction = [1.0, 0.0, 0.0]
length_mm = {}
strokes = {}
speed_mm_s = 10.0
[[moves]]
type = "retract"
speed_mm_s = 2.0
)", 0.25 * R, pol_len, int(std::lround(2 * k)));
  protocol("polish", pol_x0, polish_moves);
  if (s.trabecular) protocol("polish2", 4.0 + 1.2 * R, polish_moves);

  std::vector<std::string> names{"plunge", "sweep", "polish"};
  if (s.trabecular) {
    names.insert(names.begin() + 1, "plunge2");
    names.push_back("polish2");
  }
  std::string recs;
  int i = 0;
  for (const auto& n : names) {
    synth_recording(dir, n, burrbench, s.noise_N, glm::dvec3(0.05 + 0.01 * i, -0.03, 0.1 - 0.02 * i),
                    s.lag_ms, s.seed * 100 + std::uint64_t(i),
                    s.wrench ? "--torque-noise-Nmm 0.05 --torque-bias-Nmm 0.5,-0.2,1.0 --spindle-noise-Nmm 0.005 "
                               "--spindle-idle-Nmm 0.3 --spindle-viscous-Nmm-per-krpm 0.01"
                             : "");
    recs += fmt::format(R"(
[[recordings]]
id = "{0}"
path = "{0}.h5"
sample = "S1"
role = "calibrate"
lag_ms = 0.0
  [recordings.registration]
  rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
  translation_mm = [0.0, 0.0, 0.0]
)", n);
    ++i;
  }
  const fs::path manifest = dir / "experiment.toml";
  const std::string text = fmt::format(R"(format = "burrbench.experiment"
format_version = "1.0"
name = "calibration-reference"
description = "synthetic: compact | trabecular side by side; plunge, sweep, polish; known truth"

[[samples]]
id = "S1"
path = "sample.h5"

[burr]
radius_mm = {}
shaft_axis_rig = [0.8, 0.0, 0.6]
spin_sign = 1
tool_offset_mm = [0.0, 0.0, 0.0]

[sensor]
rotation_sensor_to_rig = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
measures = "force_on_sample"
{}
[fit]
loss = "huber"
loss_scale = 3.0
buried = "exclude"
seed = {}
multistart = {}
  [fit.classes.compact]
  alpha = {{ initial = 300.0, lower = 5.0, upper = 1.0e6 }}
  c1    = {{ initial = 10.0, lower = 0.1, upper = 200.0 }}
  mu    = {{ initial = 0.3, lower = 0.01, upper = 2.0 }}
  [fit.classes.trabecular]
  alpha = {{ initial = 300.0, lower = 5.0, upper = 1.0e6 }}
  c1    = {{ initial = 10.0, lower = 0.1, upper = 200.0 }}
  mu    = {{ initial = 0.3, lower = 0.01, upper = 2.0 }}
  [fit.nuisance]
  bias = true
  lag = true
  lag_bounds_ms = [-20.0, 20.0]
  depth_offset = {}
)", R, recs, s.seed, s.multistart, s.depth_offset ? "true" : "false");
  write_text(manifest, text);
  if (s.wrench) {
    std::string w = text;
    w.replace(w.find("[fit]\n"), 6, "[fit]\nchannels = [\"force\", \"torque\", \"spindle\"]\n");
    write_text(dir / "experiment_wrench.toml", w);
  }
  return manifest;
}

}  // namespace burrbench::calibration::testing
