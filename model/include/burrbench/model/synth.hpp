#pragma once
// Ground-truth synthesis: drive the model through a protocol on a sample with known
// constants and write what an ideal rig would have recorded, plus sensor noise, bias and
// a position→force lag. docs/replay.md ("synth") documents every choice.
//
// Frames: the sensor frame equals the rig frame; the rig frame equals the volume frame
// unless `rig_to_vol` is given (then stage positions are R⁻¹(x_vol − t)). The sensor
// measures the force on the SAMPLE (= −force on the burr). No tool offset.
#include <array>
#include <cstdint>
#include <glm/glm.hpp>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/protocol.hpp"
#include "burrbench/model/registration.hpp"

namespace burrbench::model {

// Reproducible N(0,1) draws: std::mt19937_64 → 53-bit uniforms u = (x >> 11)·2⁻⁵³ →
// Box–Muller pairs z₀ = √(−2 ln(1−u₁))·cos(2πu₂), z₁ = …·sin(2πu₂), used in that order.
// (std::normal_distribution is implementation-defined; this is not.)
class GaussianSource {
 public:
  explicit GaussianSource(std::uint64_t seed) : gen_(seed) {}
  double operator()();

 private:
  std::mt19937_64 gen_;
  double spare_ = 0;
  bool has_spare_ = false;
};

struct SynthOptions {
  double noise_N = 0;    // σ of white Gaussian noise per force component
  glm::dvec3 bias_N{0};  // added to every force sample (sensor frame)
  double lag_ms = 0;     // recorded force at t = true force at t − lag
  // The moment channel (sensor = rig frame, about the rig origin, on the sample) and the
  // spindle's load torque (MODEL.md "Moments"), with their own noise and offsets, drawn
  // from a second generator so that the force's noise is the same for any of these.
  double torque_noise_Nmm = 0;     // σ per moment component
  glm::dvec3 torque_bias_Nmm{0};   // added to every moment sample
  double spindle_noise_Nmm = 0;    // σ of the spindle torque
  double spindle_idle_Nmm = 0;     // the drive's idle torque (bearings), added always
  double spindle_viscous_Nmm_per_krpm = 0;  // + this × |rpm|/1000 (viscous drag)
  // The drive's load logged this much later than the force (ms): a device of its own,
  // timestamped late by it. With it, the load gets a stream of its own ("spindle_drive").
  double spindle_lag_ms = 0;
  std::uint64_t seed = 1;
  std::optional<RigidTransform> rig_to_vol;  // absent: rig frame = volume frame
  ReplayOptions replay;                      // internal step (0 → half the sample period)
  std::int64_t t0_ns = 1'000'000'000;        // host timestamp of the first sample
};

struct SynthResult {
  data_schema::Recording recording;
  std::vector<glm::dvec3> force_true_sensor_N;  // noiseless, bias-free sensor reading
  std::vector<glm::dvec3> force_burr_vol_N;     // model force on the burr (volume frame)
  std::vector<glm::dvec3> torque_true_sensor_Nmm;  // noiseless, bias-free moment reading
  std::vector<double> spindle_torque_true_Nmm;     // the cutting's load alone (no idle, no noise)
  std::array<double, kMaxClasses> removed_mm3{};
  std::size_t buried_samples = 0;
  ProtocolPath path;
};

// `provenance` is stored in the recording as given (the CLI passes make_provenance(...)).
SynthResult synthesize(const data_schema::SampleVolume& sample, const Protocol& protocol,
                       const data_schema::ParameterSet& params, const SynthOptions& options,
                       const Provenance& provenance = {}, Progress* progress = nullptr);

// The manifest entries that make `burrbench replay` reproduce a synthetic recording:
// burr (radius, axis, spin), sensor (identity, force on sample), lag and registration.
void describe_for_manifest(const Protocol& protocol, const SynthOptions& options,
                           data_schema::ExperimentManifest& m, data_schema::RecordingRef& ref);

// truth.json (format "burrbench.synth_truth" 1.0): parameters, bias, lag, noise, seed,
// removed volume per class, inputs and provenance.
nlohmann::json truth_json(const SynthResult& r, const data_schema::SampleVolume& sample,
                          const Protocol& protocol, const data_schema::ParameterSet& params,
                          const SynthOptions& options, const Provenance& provenance);

}  // namespace burrbench::model
