// Ground-truth synthesis (docs/replay.md "synth"). The synthetic recording is replayed
// through exactly the path `burrbench replay` takes (align_recording → trajectory →
// replay), so replaying it with the true parameters reproduces the noiseless force bit
// for bit.
#include "burrbench/model/synth.hpp"

#include <fmt/format.h>

#include <cmath>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "burrbench/data_schema/version.hpp"

namespace burrbench::model {

double GaussianSource::operator()() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = double(gen_() >> 11) * 0x1.0p-53;  // [0, 1)
  const double u2 = double(gen_() >> 11) * 0x1.0p-53;
  const double r = std::sqrt(-2.0 * std::log(1.0 - u1));  // 1 − u1 ∈ (0, 1]: no log(0)
  spare_ = r * std::sin(2 * M_PI * u2);
  has_spare_ = true;
  return r * std::cos(2 * M_PI * u2);
}

void describe_for_manifest(const Protocol& p, const SynthOptions& o,
                           data_schema::ExperimentManifest& m, data_schema::RecordingRef& ref) {
  const RigidTransform reg = o.rig_to_vol.value_or(RigidTransform{});
  m.burr.radius_mm = p.burr_radius_mm;
  m.burr.shaft_axis_rig = glm::transpose(reg.R) * p.burr_axis_vol;
  m.burr.spin_sign = p.spin_sign;
  m.burr.tool_offset_mm = glm::dvec3(0);
  m.sensor.rotation_sensor_to_rig = glm::dmat3(1.0);
  m.sensor.measures = data_schema::SensorMeasures::kForceOnSample;
  ref.lag_ms = o.lag_ms;
  ref.registration = {};
  ref.registration.rotation = reg.R;
  ref.registration.translation_mm = reg.t;
  ref.segments.clear();
}

SynthResult synthesize(const data_schema::SampleVolume& sample, const Protocol& p,
                       const data_schema::ParameterSet& params, const SynthOptions& o,
                       const Provenance& provenance, Progress* progress) {
  const std::string opt = "synth options";
  if (!(o.noise_N >= 0) || !std::isfinite(o.noise_N))
    throw InputError(opt, "noise_N", "a finite σ ≥ 0 (N)");
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(o.bias_N[k])) throw InputError(opt, "bias_N", "finite components (N)");
  for (double v : {o.torque_noise_Nmm, o.spindle_noise_Nmm})
    if (!(v >= 0) || !std::isfinite(v)) throw InputError(opt, "torque/spindle noise", "a finite σ ≥ 0 (N·mm)");
  if (!std::isfinite(glm::length(o.torque_bias_Nmm)) || !std::isfinite(o.spindle_idle_Nmm) ||
      !std::isfinite(o.spindle_viscous_Nmm_per_krpm))
    throw InputError(opt, "torque bias / spindle idle", "finite values (N·mm)");
  if (!std::isfinite(o.lag_ms) || std::abs(o.lag_ms) > 1e4)
    throw InputError(opt, "lag_ms", "a finite lag within ±10 s (ms)");
  if (!std::isfinite(o.spindle_lag_ms) || std::abs(o.spindle_lag_ms) > 1e4)
    throw InputError(opt, "spindle_lag_ms", "a finite lag within ±10 s (ms)");
  const ModelParams mp = ModelParams::from(params);
  const RigidTransform reg = o.rig_to_vol.value_or(RigidTransform{});
  if (o.rig_to_vol) check_rotation(reg.R, opt, "registration.rotation");
  const RigidTransform vol_to_rig = reg.inverse();

  SynthResult out;
  out.path = sample_protocol(p, sample);
  const ProtocolPath& path = out.path;
  const std::size_t n = path.t_s.size();

  data_schema::Recording& rec = out.recording;
  rec.provenance = provenance;
  rec.meta.rig_id = "synthetic";
  rec.meta.operator_name = "burrbench synth";
  rec.meta.burr_radius_mm = p.burr_radius_mm;
  rec.meta.burr_axis_rig = glm::transpose(reg.R) * p.burr_axis_vol;
  rec.meta.spin_sign = p.spin_sign;
  rec.meta.sensor_model = "synthetic (burrbench synth)";
  rec.meta.session_monotonic_ns = o.t0_ns;
  rec.meta.notes =
      fmt::format("protocol \"{}\"; ground truth in the truth file written alongside", p.name);

  std::vector<std::int64_t> t_ns(n);
  for (std::size_t k = 0; k < n; ++k) t_ns[k] = o.t0_ns + std::llround(path.t_s[k] * 1e9);
  auto stream = [&](const char* name, std::vector<data_schema::Channel> channels) {
    data_schema::Stream s;
    s.name = name;
    s.t_ns = s.t_send_ns = s.t_recv_ns = t_ns;  // an ideal device: no transport delay
    s.device_counter.resize(n);
    for (std::size_t k = 0; k < n; ++k) s.device_counter[k] = std::int64_t(k);
    s.stale.assign(n, 0);
    s.channels = std::move(channels);
    return s;
  };
  data_schema::Channel pos{data_schema::kPosition, "mm", 3, {}},
      rpm{data_schema::kSpindle, "rpm", 1, {}},
      load{data_schema::kSpindleTorque, "N*mm", 1, std::vector<double>(n, 0.0)};
  for (std::size_t k = 0; k < n; ++k) {
    const glm::dvec3 x = vol_to_rig.apply(path.centre_vol_mm[k]);
    pos.values.insert(pos.values.end(), {x.x, x.y, x.z});
    rpm.values.push_back(path.spindle_rpm[k]);
  }
  data_schema::Channel force{data_schema::kForce, "N", 3, std::vector<double>(3 * n, 0.0)};
  data_schema::Channel torque{data_schema::kTorque, "N*mm", 3, std::vector<double>(3 * n, 0.0)};
  rec.streams.push_back(stream("ft_sensor", {force, torque}));
  rec.streams.push_back(stream("stage", {pos}));
  if (o.spindle_lag_ms == 0) {
    rec.streams.push_back(stream("spindle", {rpm, load}));
  } else {  // the drive's load stamped spindle_lag_ms late: a device of its own
    rec.streams.push_back(stream("spindle", {rpm}));
    rec.streams.push_back(stream("spindle_drive", {load}));
    for (auto& t : rec.streams.back().t_ns) t += std::llround(o.spindle_lag_ms * 1e6);
    rec.streams.back().t_send_ns = rec.streams.back().t_recv_ns = rec.streams.back().t_ns;
  }
  rec.events.push_back({t_ns.front(), "start", "", "synthetic session"});
  for (std::size_t k = 0; k < n; ++k)
    if (k == 0 || path.move[k] != path.move[k - 1])
      rec.events.push_back(
          {t_ns[k], "move", "",
           fmt::format(
               "{} {}",
               path.move[k] >= 0 ? to_string(p.moves[std::size_t(path.move[k])].kind) : "none",
               path.move[k] >= 0 ? p.moves[std::size_t(path.move[k])].label : "")});
  rec.events.push_back({t_ns.back(), "stop", "", "synthetic session"});

  // The true force, through the same alignment the replay verb uses.
  data_schema::ExperimentManifest m;
  data_schema::RecordingRef ref;
  ref.id = "synth";
  describe_for_manifest(p, o, m, ref);
  m.recordings.push_back(ref);
  const AlignedRecording aligned = align_recording(m, ref, rec, "synthetic recording");
  Volume volume = Volume::from_sample(sample);
  const ReplayResult res =
      replay(volume, p.burr_radius_mm, mp, aligned.trajectory(), o.replay, false, progress);
  out.removed_mm3 = res.removed_mm3;

  GaussianSource gauss(o.seed);
  GaussianSource gauss_wrench(o.seed ^ 0x9E3779B97F4A7C15ull);  // moments and spindle
  auto& f = rec.streams[0].channels[0].values;
  auto& tq = rec.streams[0].channels[1].values;
  auto& sp = o.spindle_lag_ms == 0 ? rec.streams[2].channels[1].values : rec.streams[3].channels[0].values;
  const Trajectory tr = aligned.trajectory();
  out.force_true_sensor_N.resize(n);
  out.force_burr_vol_N.resize(n);
  out.torque_true_sensor_Nmm.resize(n);
  out.spindle_torque_true_Nmm.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ContactResult& c = res.samples[k].contact;
    out.buried_samples += c.buried ? 1 : 0;
    out.force_burr_vol_N[k] = c.force_N;
    const glm::dvec3 truth = aligned.sensor_force_from_burr_force(c.force_N);
    out.force_true_sensor_N[k] = truth;
    for (int i = 0; i < 3; ++i) {
      // Noise is always drawn (even for σ = 0) so a seed gives the same sequence for any σ.
      const double z = gauss();
      f[3 * k + std::size_t(i)] = truth[i] + o.bias_N[i] + o.noise_N * z;
    }
    const glm::dvec3 m = aligned.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, tr.centre_vol_mm[k]);
    out.torque_true_sensor_Nmm[k] = m;
    for (int i = 0; i < 3; ++i)
      tq[3 * k + std::size_t(i)] = m[i] + o.torque_bias_Nmm[i] + o.torque_noise_Nmm * gauss_wrench();
    const double cut = spindle_torque_Nmm(c.moment_Nmm, tr.omega_vol_rad_s[k]);
    out.spindle_torque_true_Nmm[k] = cut;
    sp[k] = cut + o.spindle_idle_Nmm + o.spindle_viscous_Nmm_per_krpm * std::abs(path.spindle_rpm[k]) / 1000 +
            o.spindle_noise_Nmm * gauss_wrench();
  }
  return out;
}

nlohmann::json truth_json(const SynthResult& r, const data_schema::SampleVolume& sample,
                          const Protocol& p, const data_schema::ParameterSet& params,
                          const SynthOptions& o, const Provenance& prov) {
  using nlohmann::json;
  json classes = json::array();
  for (const auto& [label, c] : params.classes)
    classes.push_back({{"label", label},
                       {"name", c.name},
                       {"alpha_N_per_mm2",
                        std::isfinite(c.alpha_N_per_mm2) ? json(c.alpha_N_per_mm2) : json(nullptr)},
                       {"c1_N_per_mm2", c.c1_N_per_mm2},
                       {"mu", c.mu}});
  json removed = json::object();
  double total = 0;
  for (int k = 1; k < kMaxClasses; ++k) {
    if (r.removed_mm3[std::size_t(k)] == 0 && !sample.classes.count(std::uint8_t(k))) continue;
    const auto it = sample.classes.find(std::uint8_t(k));
    removed[it != sample.classes.end() ? it->second : std::to_string(k)] =
        r.removed_mm3[std::size_t(k)];
    total += r.removed_mm3[std::size_t(k)];
  }
  const RigidTransform reg = o.rig_to_vol.value_or(RigidTransform{});
  json rot = json::array();
  for (int row = 0; row < 3; ++row) rot.push_back({reg.R[0][row], reg.R[1][row], reg.R[2][row]});
  return {
      {"format", "burrbench.synth_truth"},
      {"format_version", "1.0"},
      {"params", {{"classes", classes}, {"alpha_null_means", "infinity (no erosion)"}}},
      {"bias_N", {o.bias_N.x, o.bias_N.y, o.bias_N.z}},
      {"lag_ms", o.lag_ms},
      {"noise_N", o.noise_N},
      {"noise_distribution",
       "white Gaussian per component; mt19937_64 53-bit uniforms, Box-Muller "
       "(cos then sin), drawn x,y,z per sample in time order"},
      {"seed", o.seed},
      {"removed_mm3_by_class", removed},
      {"removed_mm3_total", total},
      {"samples", r.path.t_s.size()},
      {"buried_samples", r.buried_samples},
      {"duration_s", r.path.duration_s},
      {"protocol",
       {{"name", p.name},
        {"file", p.file},
        {"sample_rate_hz", p.sample_rate_hz},
        {"burr_radius_mm", p.burr_radius_mm},
        {"spin_sign", p.spin_sign},
        {"burr_axis_vol", {p.burr_axis_vol.x, p.burr_axis_vol.y, p.burr_axis_vol.z}},
        {"surface_vol_mm",
         {r.path.surface_vol_mm.x, r.path.surface_vol_mm.y, r.path.surface_vol_mm.z}}}},
      {"frames",
       {{"sensor", "= rig frame; measures the force on the sample (= -force on burr)"},
        {"registration_rig_to_vol",
         {{"rotation", rot}, {"translation_mm", {reg.t.x, reg.t.y, reg.t.z}}}},
        {"tool_offset_mm", {0.0, 0.0, 0.0}},
        {"torque", "torque_Nmm: moment on the sample about the rig origin, sensor = rig frame, N*mm "
                   "(MODEL.md 'Moments'), + torque_bias_Nmm + noise"},
        {"spindle", "spindle_torque_Nmm: the cutting's load -T.w/|w| + idle + viscous*|rpm|/1000 + noise, N*mm"}}},
      {"torque_noise_Nmm", o.torque_noise_Nmm},
      {"torque_bias_Nmm", {o.torque_bias_Nmm.x, o.torque_bias_Nmm.y, o.torque_bias_Nmm.z}},
      {"spindle_noise_Nmm", o.spindle_noise_Nmm},
      {"spindle_idle_Nmm", o.spindle_idle_Nmm},
      {"spindle_viscous_Nmm_per_krpm", o.spindle_viscous_Nmm_per_krpm},
      {"spindle_lag_ms", o.spindle_lag_ms},
      // the step actually used (replay.hpp): by default half the sample period, never more than it
      {"replay_step_s", replay_step_s(o.replay.step_s, r.path.t_s)},
      {"provenance", data_schema::provenance_json(prov)},
  };
}

}  // namespace burrbench::model
