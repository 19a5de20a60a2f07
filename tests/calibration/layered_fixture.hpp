#pragma once
// The held-out case of issue 10, synthesized: a compact layer (0.5 mm, χ = 1) over
// trabecular bone (χ = 0.6) and ONE recording that plunges through the compact layer into
// the trabecular bone, then sweeps and polishes in compact bone only. Segments give the
// plunge and the sweep role "calibrate" and the polish role "validate". The truth has real
// bone's cutting energy (compact α = 1500 N/mm²), above the old default bound.
#include <filesystem>
#include <string>

#include "reference_fixture.hpp"

namespace burrbench::calibration::testing {

struct LayeredSpec {
  double noise_N = 0.02, lag_ms = 4.0;
  std::uint64_t seed = 1;
  bool fit_section = true;  // false: no [fit] at all (every default)
  int multistart = 16;
  double alpha1 = 1500, c1_1 = 16, mu1 = 0.4;  // compact
  double alpha2 = 600, c1_2 = 8, mu2 = 0.3;    // trabecular
};

inline data_schema::SampleVolume layered_sample() {
  data_schema::SampleVolume v;
  v.voxel_mm = 0.1;
  v.dims = {80, 60, 20};  // 8 × 6 × 2 mm, top at z = 2
  v.origin_mm = glm::dvec3(0.05);
  v.labels.assign(v.voxel_count(), 2);
  v.fraction.assign(v.voxel_count(), 0.6f);
  for (std::size_t z = 0; z < v.dims[2]; ++z)
    for (std::size_t y = 0; y < v.dims[1]; ++y)
      for (std::size_t x = 0; x < v.dims[0]; ++x)
        if (v.centre_mm(x, y, z).z > 1.5) {
          v.labels[v.index(x, y, z)] = 1;
          v.fraction[v.index(x, y, z)] = 1.f;
        }
  v.classes = {{1, "compact"}, {2, "trabecular"}};
  v.segmentation_json = "{}";
  return v;
}

// Segment times (s from the first sample), from the protocol's moves at R = 1 mm: plunge
// 1.6 (0.1 mm approach + 1.5 mm: through the 0.5 mm compact layer, 1 mm into trabecular
// bone) + dwell 0.2 + retract 0.8 = 2.6; free move 0.5; sweep 0.35 + 1.5 + 0.175
// (3.1..5.125); free move 0.6; polish 0.35 + 1.2 + 0.175 (5.725..7.45).
inline std::filesystem::path make_layered_experiment(const std::filesystem::path& dir,
                                                     const LayeredSpec& s,
                                                     const std::string& burrbench) {
  namespace fs = std::filesystem;
  fs::create_directories(dir);
  data_schema::write_sample(dir / "sample.h5", layered_sample());
  data_schema::ParameterSet truth;
  truth.classes[1] = {"compact", s.alpha1, s.c1_1, s.mu1};
  truth.classes[2] = {"trabecular", s.alpha2, s.c1_2, s.mu2};
  data_schema::write_params(dir / "truth.toml", truth);
  write_text(dir / "session.protocol.toml", protocol_head("session", 1.0, 1.5, 1.8, 2.0) + R"(
[[moves]]
type = "plunge"
depth_mm = 1.5
feed_mm_s = 1.0
[[moves]]
type = "dwell"
duration_s = 0.2
[[moves]]
type = "retract"
speed_mm_s = 2.0
[[moves]]
type = "sweep"
direction = [1.0, 0.0, 0.0]
length_mm = 2.0
speed_mm_s = 4.0
[[moves]]
type = "sweep"
depth_mm = 0.25
feed_mm_s = 1.0
direction = [1.0, 0.0, 0.0]
length_mm = 3.0
speed_mm_s = 2.0
[[moves]]
type = "retract"
speed_mm_s = 2.0
[[moves]]
type = "sweep"
direction = [0.0, 1.0, 0.0]
length_mm = 2.4
speed_mm_s = 4.0
[[moves]]
type = "polish"
depth_mm = 0.25
feed_mm_s = 1.0
direction = [-1.0, 0.0, 0.0]
length_mm = 3.0
strokes = 2
speed_mm_s = 10.0
[[moves]]
type = "retract"
speed_mm_s = 2.0
)");
  synth_recording(dir, "session", burrbench, s.noise_N, glm::dvec3(0.05, -0.03, 0.08), s.lag_ms,
                  s.seed);
  const std::string fit = !s.fit_section ? "" : fmt::format(R"(
[fit]
seed = {}
multistart = {}
  [fit.classes.compact]
  alpha = {{ initial = 300.0, lower = 1.0, upper = 1.0e5 }}
  c1    = {{ initial = 10.0, lower = 0.01, upper = 1.0e4 }}
  mu    = {{ initial = 0.3, lower = 0.01, upper = 3.0 }}
  [fit.classes.trabecular]
  alpha = {{ initial = 300.0, lower = 1.0, upper = 1.0e5 }}
  c1    = {{ initial = 10.0, lower = 0.01, upper = 1.0e4 }}
  mu    = {{ initial = 0.3, lower = 0.01, upper = 3.0 }}
)", s.seed, s.multistart);
  const fs::path manifest = dir / "experiment.toml";
  write_text(manifest, R"(format = "burrbench.experiment"
format_version = "1.0"
name = "held-out-polish"
description = "synthetic: compact over trabecular; one recording, plunge + sweep calibrate, polish validates"

[[samples]]
id = "S1"
path = "sample.h5"

[burr]
radius_mm = 1.0
shaft_axis_rig = [0.8, 0.0, 0.6]
spin_sign = 1
tool_offset_mm = [0.0, 0.0, 0.0]

[sensor]
rotation_sensor_to_rig = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
measures = "force_on_sample"

[[recordings]]
id = "session"
path = "session.h5"
sample = "S1"
role = "calibrate"
  [recordings.registration]
  rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
  translation_mm = [0.0, 0.0, 0.0]
  [[recordings.segments]]
  label = "plunge"
  start_s = 0.0
  end_s = 2.6
  [[recordings.segments]]
  label = "sweep"
  start_s = 3.1
  end_s = 5.125
  [[recordings.segments]]
  label = "polish"
  start_s = 5.725
  end_s = 7.45
  role = "validate"
)" + fit);
  return manifest;
}

}  // namespace burrbench::calibration::testing
