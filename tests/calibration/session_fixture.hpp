#pragma once
// A realistic session (issue 55), synthesized with known truth as a lab would record it:
// - the stage logs in a rig frame turned 37° about z and shifted from the CT volume; the
//   registration comes from four fiducial beads whose rig-side coordinates carry 5 µm of
//   localisation noise (RMS, 3-D);
// - a six-axis sensor 34 mm below the sample's top at the rig's origin, its axes turned
//   60° about z from the rig's (given in the manifest), logging force and moment;
// - the spindle drive logs its load torque (idle + viscous drag + the cutting's load);
// - the speed varies between moves, 20 000 ± 1 500 rpm;
// - plunge, sweep and polishing strokes over compact and trabecular bone, a plunge 0.9 mm
//   into the trabecular side; the force and moment 3 ms late on the stage.
// The calibration is given the defaults: [fit] channels = force, torque, spindle; no
// [fit.classes], no noise levels, fiducials with fiducial_error_mm, the pose fitted.
// Shared by tests/calibration and bench/.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/protocol.hpp"
#include "burrbench/model/registration.hpp"
#include "burrbench/model/synth.hpp"
#include "reference_fixture.hpp"
#include "registration_fixture.hpp"

namespace burrbench::calibration::testing {

struct SessionSpec {
  std::uint64_t seed = 1;              // sensor noise and fiducial noise
  double fiducial_noise_mm = 0.005;    // RMS 3-D per bead
  double noise_N = 0.02, noise_Nmm = 0.05, spindle_noise_Nmm = 0.1;
  double lag_ms = 3.0;               // the force and moment behind the stage
  double spindle_lag_ms = 5.0;       // the drive's load behind the force (8 ms behind the stage)
  double sensor_depth_mm = 34.0;       // the sensor origin below the sample's top
  bool plunge_only = false;            // only the two plunges (the issue's plunge-only variant)
  double time_scale = 0.5;             // < 1: shorter moves, fewer strokes
  glm::dvec3 fiducial_offset_mm{0};    // added to one bead's rig coordinates (a violated prior)
  // truth
  double alpha1 = 150, c1_1 = 16, mu1 = 0.4;
  double alpha2 = 60, c1_2 = 6, mu2 = 0.3;
};

struct SessionCase {
  std::filesystem::path manifest;
  model::RigidTransform vol_from_rig;  // the true registration
  std::vector<glm::dvec3> fiducials_vol, fiducials_rig;
  std::vector<std::string> recordings;
};

inline SessionCase make_session(const std::filesystem::path& dir, const SessionSpec& s) {
  namespace fs = std::filesystem;
  namespace ds = data_schema;
  fs::create_directories(dir);
  ReferenceSpec ref;
  ref.voxel_mm = 0.1;
  ref.radius_mm = 1.0;
  // The reference block (compact for x < 4 mm, trabecular beyond), deep enough in y for
  // every recording to drill fresh bone of its own (rows at y = 2, 5, 8, 11 mm).
  ds::SampleVolume sample = reference_sample(ref);
  {
    ds::SampleVolume wide = sample;
    wide.dims[1] = std::size_t(std::lround(13.0 / ref.voxel_mm));
    wide.labels.assign(wide.voxel_count(), 2);
    wide.fraction.assign(wide.voxel_count(), 0.6f);
    for (std::size_t z = 0; z < wide.dims[2]; ++z)
      for (std::size_t y = 0; y < wide.dims[1]; ++y)
        for (std::size_t x = 0; x < wide.dims[0]; ++x)
          if (wide.centre_mm(x, y, z).x < 4.0) {
            wide.labels[wide.index(x, y, z)] = 1;
            wide.fraction[wide.index(x, y, z)] = 1.f;
          }
    sample = std::move(wide);
  }
  ds::write_sample(dir / "sample.h5", sample);
  ds::ParameterSet truth;
  truth.classes[1] = {"compact", s.alpha1, s.c1_1, s.mu1};
  truth.classes[2] = {"trabecular", s.alpha2, s.c1_2, s.mu2};
  ds::write_params(dir / "truth.toml", truth);

  SessionCase c;
  // Rig frame: turned 37° about z, its origin (= the sensor's) 34 mm below the top (z = 2).
  c.vol_from_rig.R = glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(37.0), glm::dvec3(0, 0, 1)));
  c.vol_from_rig.t = glm::dvec3(4.0, 3.0, 2.0 - s.sensor_depth_mm);
  // The sensor's axes in the rig frame (columns): turned 60° about z (another bolt hole).
  const glm::dmat3 Q = glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(60.0), glm::dvec3(0, 0, 1)));

  const double R = ref.radius_mm, top = 2.0, k = s.time_scale;
  auto head = [&](const std::string& name, double x0, double y0, double rpm) {
    std::string h = protocol_head(name, R, x0, y0, top);
    const std::string from = "spindle_rpm = 40000.0", to = fmt::format("spindle_rpm = {:.1f}", rpm);
    h.replace(h.find(from), from.size(), to);
    return h;
  };
  auto plunge = [&](double depth_mm, double rpm) {
    return fmt::format(R"([[moves]]
type = "plunge"
depth_mm = {}
feed_mm_s = {}
[[moves]]
type = "dwell"
duration_s = {}
spindle_rpm = {}
[[moves]]
type = "retract"
speed_mm_s = 2.0
)", depth_mm, 1.0 / k, 0.2 * k, rpm);
  };
  struct P { std::string name, text; };
  std::vector<P> protocols{
      {"plunge", head("plunge", 2.0, 2.0, 18500) + plunge(0.3 * R, 20000)},
      {"plunge2", head("plunge2", 6.0, 2.0, 21500) + plunge(0.9, 19000)},
  };
  if (!s.plunge_only) {
    protocols.push_back({"sweep", head("sweep", 2.0, 5.0, 20000) + fmt::format(R"([[moves]]
type = "plunge"
depth_mm = {}
feed_mm_s = 1.0
[[moves]]
type = "sweep"
direction = [1.0, 0.0, 0.0]
length_mm = 4.0
speed_mm_s = {}
spindle_rpm = 18500.0
[[moves]]
type = "sweep"
spindle_rpm = 21500.0
direction = [0.0, -1.0, 0.0]
length_mm = {}
speed_mm_s = {}
[[moves]]
type = "retract"
speed_mm_s = 2.0
)", 0.25 * R, 2.0 / k, 0.8 * R, 2.0 / k)});
    const std::string polish = fmt::format(R"([[moves]]
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
)", 0.25 * R, 4.0 - 1.5 * R - 1.0, int(std::lround(2 * k)));
    protocols.push_back({"polish", head("polish", 1.0, 8.0, 20500) + polish});
    protocols.push_back({"polish2", head("polish2", 4.0 + 1.2 * R, 11.0, 19500) + polish});
  }

  std::string recs;
  int i = 0;
  for (const auto& p : protocols) {
    write_text(dir / (p.name + ".protocol.toml"), p.text);
    const model::Protocol proto = model::read_protocol(dir / (p.name + ".protocol.toml"));
    model::SynthOptions o;
    o.noise_N = s.noise_N;
    o.bias_N = glm::dvec3(0.05 + 0.01 * i, -0.03, 0.1 - 0.02 * i);
    o.lag_ms = s.lag_ms;
    o.torque_noise_Nmm = s.noise_Nmm;
    o.torque_bias_Nmm = glm::dvec3(0.5, -0.2, 1.0);
    o.spindle_noise_Nmm = s.spindle_noise_Nmm;
    o.spindle_idle_Nmm = 0.3;
    o.spindle_viscous_Nmm_per_krpm = 0.05;
    o.spindle_lag_ms = s.spindle_lag_ms;
    o.seed = s.seed * 100 + std::uint64_t(i);
    o.rig_to_vol = c.vol_from_rig;
    model::SynthResult res = model::synthesize(sample, proto, truth, o);
    // Readings in the sensor's own axes: v_sensor = Qᵀ v_rig (the noise is isotropic).
    for (auto& ch : res.recording.streams[0].channels)
      for (std::size_t j = 0; j + 2 < ch.values.size(); j += 3) {
        const glm::dvec3 v = glm::transpose(Q) * glm::dvec3(ch.values[j], ch.values[j + 1], ch.values[j + 2]);
        for (int a = 0; a < 3; ++a) ch.values[j + std::size_t(a)] = v[a];
      }
    ds::write_recording(dir / (p.name + ".h5"), res.recording);
    c.recordings.push_back(p.name);
    ++i;
  }
  // Four beads around the sample, known in the volume; the rig side measured with noise.
  c.fiducials_vol = {{-1.0, -1.0, 0.0}, {9.0, -1.0, 0.5}, {4.0, 7.0, 0.0}, {4.0, 2.0, 5.0}};
  model::GaussianSource g(s.seed * 7919 + 17);
  const model::RigidTransform rig_from_vol = c.vol_from_rig.inverse();
  for (std::size_t b = 0; b < c.fiducials_vol.size(); ++b) {
    const double sd = s.fiducial_noise_mm / std::sqrt(3.0);
    glm::dvec3 x = rig_from_vol.apply(c.fiducials_vol[b]) + sd * glm::dvec3(g(), g(), g());
    if (b == 1) x += s.fiducial_offset_mm;
    c.fiducials_rig.push_back(x);
  }
  for (const auto& n : c.recordings)
    recs += fmt::format(R"(
[[recordings]]
id = "{0}"
path = "{0}.h5"
sample = "S1"
role = "calibrate"
  [recordings.registration]
  fiducials_rig_mm = {1}
  fiducials_vol_mm = {2}
  fiducial_error_mm = {3}
)", n, toml_points(c.fiducials_rig), toml_points(c.fiducials_vol), s.fiducial_noise_mm);
  const glm::dvec3 axis = glm::transpose(c.vol_from_rig.R) * glm::dvec3(0.8, 0.0, 0.6);
  c.manifest = dir / "experiment.toml";
  write_text(c.manifest, fmt::format(R"(format = "burrbench.experiment"
format_version = "1.0"
name = "realistic-session"
description = "synthetic, as a lab records it: fiducial registration, a six-axis sensor 34 mm below, spindle load, varying speed"

[[samples]]
id = "S1"
path = "sample.h5"

[burr]
radius_mm = {}
shaft_axis_rig = [{:.15g}, {:.15g}, {:.15g}]
spin_sign = 1
tool_offset_mm = [0.0, 0.0, 0.0]

[sensor]
rotation_sensor_to_rig = {}
origin_rig_mm = [0.0, 0.0, 0.0]
measures = "force_on_sample"
{}
[fit]
channels = ["force", "torque", "spindle"]
seed = {}
)", R, axis.x, axis.y, axis.z, toml_rows(Q), recs, s.seed));
  return c;
}

// The session's manifest with every constant fixed at the truth, beside it: a fit of the
// nuisances alone, whose cost bounds the global optimum's from above.
inline std::filesystem::path with_constants_fixed(const std::filesystem::path& manifest, const SessionSpec& s) {
  std::ifstream in(manifest);
  std::stringstream ss;
  ss << in.rdbuf();
  const auto fixed = [](double v) { return fmt::format("{{ initial = {:.17g}, fixed = true }}", v); };
  const std::string text = ss.str() + fmt::format(R"(  [fit.classes.compact]
  alpha = {}
  c1 = {}
  mu = {}
  [fit.classes.trabecular]
  alpha = {}
  c1 = {}
  mu = {}
)", fixed(s.alpha1), fixed(s.c1_1), fixed(s.mu1), fixed(s.alpha2), fixed(s.c1_2), fixed(s.mu2));
  const std::filesystem::path out = manifest.parent_path() / "experiment_truth_held.toml";
  write_text(out, text);
  return out;
}

}  // namespace burrbench::calibration::testing
