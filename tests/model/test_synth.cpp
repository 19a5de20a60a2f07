// Ground-truth synthesis: reproducible noise, noise statistics, bias and lag in the
// output, and the round trip synth → files → experiment → replay reproducing the
// noiseless force.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <glm/gtc/matrix_transform.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/synth.hpp"

using namespace burrbench::model;
namespace ds = burrbench::data_schema;
namespace fs = std::filesystem;

namespace {

// 5×5×3 mm block of 0.1 mm voxels: compact (label 1) for z < 2 mm, trabecular-like
// label 2 with χ = 0.6 for z < 1 mm; empty above.
ds::SampleVolume sample() {
  ds::SampleVolume s;
  s.dims = {50, 50, 30};
  s.voxel_mm = 0.1;
  s.origin_mm = glm::dvec3(0.05);
  s.labels.assign(s.voxel_count(), 0);
  s.fraction.assign(s.voxel_count(), 0.f);
  for (std::size_t z = 0; z < 20; ++z)
    for (std::size_t y = 0; y < 50; ++y)
      for (std::size_t x = 0; x < 50; ++x) {
        const auto i = s.index(x, y, z);
        s.labels[i] = z < 10 ? 2 : 1;
        s.fraction[i] = z < 10 ? 0.6f : 1.f;
      }
  return s;
}

// Plunge 0.4 mm into the top, sweep 1.5 mm sideways, retract: ~2 s at 1 kHz.
Protocol protocol() {
  return parse_protocol(R"(
format = "burrbench.protocol"
format_version = "1.0"
name = "test"
sample_rate_hz = 1000
spindle_rpm = 40000
[burr]
radius_mm = 0.5
axis = [0.8, 0.0, 0.6]
spin_sign = 1
[start]
point_mm = [1.5, 2.5, 2.8]
approach = [0, 0, -1]
[[moves]]
type = "plunge"
depth_mm = 0.15
feed_mm_s = 1.0
[[moves]]
type = "sweep"
direction = [1, 0.3, 0]
length_mm = 1.5
speed_mm_s = 2.0
spindle_rpm = 60000
[[moves]]
type = "retract"
speed_mm_s = 2.0
)",
                        "test.toml");
}

ds::ParameterSet params() {
  ds::ParameterSet p;
  p.classes[1] = {"compact", 80.0, 16.0, 0.4};
  p.classes[2] = {"trabecular", 40.0, 6.0, 0.3};
  return p;
}

const std::vector<double>& forces(const SynthResult& r) {
  return r.recording.stream_with(ds::kForce)->channel(ds::kForce)->values;
}

}  // namespace

TEST(Synth, ProducesContactAndErosion) {
  const auto r = synthesize(sample(), protocol(), params(), {});
  double fmax = 0;
  for (const auto& f : r.force_true_sensor_N) fmax = std::max(fmax, glm::length(f));
  EXPECT_GT(fmax, 0.1);            // the burr does touch the bone
  EXPECT_GT(r.removed_mm3[1], 0);  // and erodes compact bone
  EXPECT_EQ(r.recording.streams.size(), 3u);
  ds::validate(r.recording, "synth");  // a valid recording
  // stage reports the protocol path (rig = volume frame)
  const auto& pos = r.recording.stream_with(ds::kPosition)->channel(ds::kPosition)->values;
  EXPECT_EQ(pos[3 * 500 + 2], r.path.centre_vol_mm[500].z);
  // sensor measures force on the sample: −F_on_burr
  EXPECT_EQ(r.force_true_sensor_N[700], -r.force_burr_vol_N[700]);
}

TEST(Synth, SameSeedSameBytesOtherSeedOtherNoise) {
  SynthOptions o;
  o.noise_N = 0.05;
  o.seed = 42;
  const auto a = synthesize(sample(), protocol(), params(), o);
  const auto b = synthesize(sample(), protocol(), params(), o);
  o.seed = 43;
  const auto c = synthesize(sample(), protocol(), params(), o);
  ASSERT_EQ(forces(a).size(), forces(b).size());
  EXPECT_EQ(std::memcmp(forces(a).data(), forces(b).data(), forces(a).size() * sizeof(double)), 0);
  std::size_t same = 0;
  for (std::size_t i = 0; i < forces(a).size(); ++i) same += forces(a)[i] == forces(c)[i];
  EXPECT_EQ(same, 0u);
  // the truth itself does not depend on the seed
  EXPECT_EQ(a.force_true_sensor_N, c.force_true_sensor_N);
}

TEST(Synth, NoiseStatisticsAndBias) {
  SynthOptions o;
  o.noise_N = 0.5;
  o.bias_N = {0.3, -0.2, 1.5};
  o.seed = 7;
  const auto r = synthesize(sample(), protocol(), params(), o);
  const auto& f = forces(r);
  const std::size_t n = r.force_true_sensor_N.size();
  ASSERT_GT(n, 1000u);
  double pooled = 0;
  for (int i = 0; i < 3; ++i) {
    double s = 0, ss = 0;
    for (std::size_t k = 0; k < n; ++k) {
      const double e = f[3 * k + std::size_t(i)] - r.force_true_sensor_N[k][i];
      s += e;
      ss += e * e;
    }
    const double mean = s / double(n), var = ss / double(n) - mean * mean;
    pooled += var / 3;
    EXPECT_NEAR(mean, o.bias_N[i], 4 * 0.5 / std::sqrt(double(n))) << i;  // 4 standard errors
    EXPECT_NEAR(std::sqrt(var), 0.5, 0.06 * 0.5) << i;                    // within 6 % per axis
  }
  EXPECT_NEAR(std::sqrt(pooled), 0.5, 0.03 * 0.5);  // within 3 % over all 3n draws
}

TEST(Synth, LagDelaysTheForce) {
  SynthOptions o0, o5;
  o5.lag_ms = 5.0;  // five samples at 1 kHz
  o5.bias_N = {0.01, 0.02, 0.03};
  const auto a = synthesize(sample(), protocol(), params(), o0);
  const auto b = synthesize(sample(), protocol(), params(), o5);
  const auto& fa = forces(a);
  const auto& fb = forces(b);
  const std::size_t n = a.force_true_sensor_N.size();
  double worst = 0, scale = 0;
  for (std::size_t k = 5; k < n; ++k)
    for (std::size_t i = 0; i < 3; ++i) {
      worst = std::max(worst, std::abs((fb[3 * k + i] - o5.bias_N[int(i)]) - fa[3 * (k - 5) + i]));
      scale = std::max(scale, std::abs(fa[3 * k + i]));
    }
  EXPECT_GT(scale, 0.1);
  EXPECT_LT(worst, 1e-9 * scale);
  // and the stage still reports the undelayed path
  EXPECT_EQ(a.recording.stream_with(ds::kPosition)->channel(ds::kPosition)->values,
            b.recording.stream_with(ds::kPosition)->channel(ds::kPosition)->values);
}

TEST(Synth, ReplayOfTheFilesReproducesTheNoiselessForce) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("burrbench_synth_{}", ::getpid());
  fs::create_directories(dir);
  SynthOptions o;
  o.lag_ms = 3.7;
  RigidTransform reg;
  reg.R = glm::dmat3(glm::rotate(glm::dmat4(1.0), 0.6, glm::normalize(glm::dvec3(1, 2, 3))));
  reg.t = {5, -2, 1};
  o.rig_to_vol = reg;
  const auto s = sample();
  const auto p = protocol();
  const auto r = synthesize(s, p, params(), o);
  ds::write_sample(dir / "s.h5", s);
  ds::write_recording(dir / "r.h5", r.recording);
  ds::ExperimentManifest m;
  m.name = "roundtrip";
  m.samples.push_back({"S", dir / "s.h5"});
  ds::RecordingRef ref;
  ref.id = "r";
  ref.path = dir / "r.h5";
  ref.sample = "S";
  describe_for_manifest(p, o, m, ref);
  m.recordings.push_back(ref);
  ds::write_manifest(dir / "e.toml", m);

  const Experiment e = load_experiment(dir / "e.toml");
  ASSERT_EQ(e.recordings.size(), 1u);
  Volume v = Volume::from_sample(e.samples.at("S"));
  const auto pred = predict(e.recordings[0], v, ModelParams::from(params()));
  ASSERT_EQ(pred.t_s.size(), r.force_true_sensor_N.size());
  double worst = 0, scale = 0;
  for (std::size_t k = 0; k < pred.t_s.size(); ++k) {
    worst = std::max(worst, glm::length(pred.force_sensor_pred_N[k] - r.force_true_sensor_N[k]));
    worst = std::max(worst, glm::length(pred.force_sensor_meas_N[k] - r.force_true_sensor_N[k]));
    scale = std::max(scale, glm::length(r.force_true_sensor_N[k]));
  }
  EXPECT_GT(scale, 0.1);
  EXPECT_LE(worst, 1e-9 * scale);
  EXPECT_NEAR(pred.removed_mm3[1], r.removed_mm3[1], 1e-9 * r.removed_mm3[1]);
  // Independently of the replay: the stage positions written in the rig frame, read back
  // through the manifest's registration with no lag, are the protocol's burr path in the
  // volume frame, and ω is along the protocol's axis with its spin sign. (A frame mistake
  // shared by synth and replay would cancel in the force comparison above.)
  const auto zero_lag = e.recordings[0].trajectory(0.0);
  const auto omega = r.path.omega_vol_rad_s(p);
  ASSERT_EQ(zero_lag.centre_vol_mm.size(), r.path.centre_vol_mm.size());
  for (std::size_t k = 0; k < zero_lag.centre_vol_mm.size(); k += 97) {
    EXPECT_LE(glm::length(zero_lag.centre_vol_mm[k] - r.path.centre_vol_mm[k]), 1e-9) << k;
    EXPECT_LE(glm::length(zero_lag.omega_vol_rad_s[k] - omega[k]), 1e-9 * (1 + glm::length(omega[k]))) << k;
  }
  // The lag matters: replayed without it, the prediction misses the truth.
  auto no_lag = e.recordings[0];
  no_lag.lag_s = 0;
  Volume v2 = Volume::from_sample(e.samples.at("S"));
  const auto off = predict(no_lag, v2, ModelParams::from(params()));
  double off_worst = 0;
  for (std::size_t k = 0; k < off.t_s.size(); ++k)
    off_worst = std::max(off_worst, glm::length(off.force_sensor_pred_N[k] - r.force_true_sensor_N[k]));
  EXPECT_GT(off_worst, 1e-3 * scale);
  fs::remove_all(dir);
}

TEST(Synth, RejectsBadOptions) {
  SynthOptions o;
  o.noise_N = -1;
  EXPECT_THROW(synthesize(sample(), protocol(), params(), o), burrbench::InputError);
  o = {};
  o.lag_ms = NAN;
  EXPECT_THROW(synthesize(sample(), protocol(), params(), o), burrbench::InputError);
}
