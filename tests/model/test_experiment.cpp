// Experiment layer: stream alignment at different instants, lag, tool offset,
// registration, segments, ω and the sensor-force mapping — on in-memory recordings.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <glm/gtc/matrix_transform.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/experiment.hpp"

using burrbench::InputError;
using namespace burrbench::model;
namespace ds = burrbench::data_schema;

namespace {

glm::dmat3 rotation(double angle, glm::dvec3 axis) {
  return glm::dmat3(glm::rotate(glm::dmat4(1.0), angle, glm::normalize(axis)));
}

// Stage moves linearly: x(t) = (1 + 2t, −3t, 0.5 + t) mm; spindle ramps rpm(t) = 1000 + 500 t.
glm::dvec3 stage_at(double t) { return {1 + 2 * t, -3 * t, 0.5 + t}; }
double rpm_at(double t) { return 1000 + 500 * t; }

ds::Stream make_stream(const char* name, std::int64_t t0_ns, std::int64_t period_ns,
                       std::size_t n) {
  ds::Stream s;
  s.name = name;
  for (std::size_t k = 0; k < n; ++k) s.t_ns.push_back(t0_ns + std::int64_t(k) * period_ns);
  s.t_send_ns = s.t_recv_ns = s.t_ns;
  s.stale.assign(n, 0);
  return s;
}

// Force at 1 kHz from t = 10 s; stage at 800 Hz starting 0.3 ms earlier; spindle at 250 Hz.
ds::Recording recording() {
  ds::Recording rec;
  const std::int64_t t0 = 10'000'000'000;
  auto ft = make_stream("ft_sensor", t0, 1'000'000, 200);
  ds::Channel f{ds::kForce, "N", 3, {}};
  for (std::size_t k = 0; k < 200; ++k) f.values.insert(f.values.end(), {double(k), 2.0 * k, -1.0});
  ft.channels.push_back(f);
  auto st = make_stream("stage", t0 - 300'000, 1'250'000, 170);
  ds::Channel p{ds::kPosition, "mm", 3, {}};
  for (auto t : st.t_ns) {
    const glm::dvec3 x = stage_at(double(t - t0) * 1e-9);
    p.values.insert(p.values.end(), {x.x, x.y, x.z});
  }
  st.channels.push_back(p);
  auto sp = make_stream("spindle", t0 - 2'000'000, 4'000'000, 60);
  ds::Channel r{ds::kSpindle, "rpm", 1, {}};
  for (auto t : sp.t_ns) r.values.push_back(rpm_at(double(t - t0) * 1e-9));
  sp.channels.push_back(r);
  rec.streams = {ft, st, sp};
  return rec;
}

ds::ExperimentManifest manifest() {
  ds::ExperimentManifest m;
  m.file = "exp.toml";
  m.burr.radius_mm = 1.0;
  m.burr.shaft_axis_rig = {0, 0, 1};
  m.burr.spin_sign = -1;
  m.burr.tool_offset_mm = {0.1, 0.2, 0.3};
  m.sensor.rotation_sensor_to_rig = rotation(0.7, {1, 0, 0});
  ds::RecordingRef r;
  r.id = "rec";
  r.sample = "S";
  r.registration.rotation = rotation(0.5, {0, 0, 1});
  r.registration.translation_mm = {10, 20, 30};
  m.recordings.push_back(r);
  return m;
}

}  // namespace

TEST(Experiment, AlignsStreamsAtForceTimestampsWithRegistrationAndToolOffset) {
  const auto m = manifest();
  const auto a = align_recording(m, m.recordings[0], recording(), "rec.h5");
  ASSERT_EQ(a.t_s.size(), 200u);
  EXPECT_EQ(a.t_s[0], 0.0);
  EXPECT_NEAR(a.t_s[199], 0.199, 1e-15);
  EXPECT_EQ(a.force_sensor_N[7], glm::dvec3(7, 14, -1));
  const Trajectory tr = a.trajectory(0.0);
  const glm::dmat3 R = m.recordings[0].registration.rotation;
  for (std::size_t k = 0; k < 200; k += 13) {
    const double t = a.t_s[k];
    // linear motion: interpolation between the 800 Hz samples is exact
    const glm::dvec3 want = R * (stage_at(t) + m.burr.tool_offset_mm) + glm::dvec3(10, 20, 30);
    EXPECT_NEAR(glm::length(tr.centre_vol_mm[k] - want), 0, 1e-12) << k;
    const glm::dvec3 w = 2 * M_PI * rpm_at(t) / 60 * -1.0 * (R * glm::dvec3(0, 0, 1));
    EXPECT_NEAR(glm::length(tr.omega_vol_rad_s[k] - w), 0, 1e-9) << k;
  }
}

TEST(Experiment, LagShiftsPositionsAndClampsAtTheEnds) {
  const auto m = manifest();
  const auto a = align_recording(m, m.recordings[0], recording(), "rec.h5");
  const glm::dmat3 R = m.recordings[0].registration.rotation;
  const double lag = 0.0123;  // the force at t answers the position at t − 12.3 ms
  const Trajectory tr = a.trajectory(lag);
  for (std::size_t k = 20; k < 200; k += 17) {
    const glm::dvec3 want =
        R * (stage_at(a.t_s[k] - lag) + m.burr.tool_offset_mm) + glm::dvec3(10, 20, 30);
    EXPECT_NEAR(glm::length(tr.centre_vol_mm[k] - want), 0, 1e-12) << k;
  }
  // Before the first stage sample (t = −0.3 ms): clamped to it.
  const glm::dvec3 first = R * (stage_at(-0.0003) + m.burr.tool_offset_mm) + glm::dvec3(10, 20, 30);
  EXPECT_NEAR(glm::length(tr.centre_vol_mm[0] - first), 0, 1e-12);
  // Negative lag: after the last stage sample, clamped to it.
  const Trajectory late = a.trajectory(-0.5);
  const double t_last = (169 * 1.25e6 - 0.3e6) * 1e-9;
  EXPECT_NEAR(
      glm::length(late.centre_vol_mm[199] -
                  (R * (stage_at(t_last) + m.burr.tool_offset_mm) + glm::dvec3(10, 20, 30))),
      0, 1e-12);
  // The manifest's lag is the default.
  auto m2 = manifest();
  m2.recordings[0].lag_ms = 12.3;
  const auto a2 = align_recording(m2, m2.recordings[0], recording(), "rec.h5");
  EXPECT_DOUBLE_EQ(a2.lag_s, 0.0123);
  EXPECT_EQ(a2.trajectory().centre_vol_mm[100], a.trajectory(0.0123).centre_vol_mm[100]);
}

TEST(Experiment, DepthOffsetMovesAlongMinusShaftAxis) {
  const auto m = manifest();
  const auto a = align_recording(m, m.recordings[0], recording(), "rec.h5");
  const auto t0 = a.trajectory(0, 0), t1 = a.trajectory(0, 0.05);
  const glm::dvec3 axis = m.recordings[0].registration.rotation * glm::dvec3(0, 0, 1);
  EXPECT_NEAR(glm::length(t1.centre_vol_mm[50] - (t0.centre_vol_mm[50] - 0.05 * axis)), 0, 1e-12);
}

TEST(Experiment, SensorForceMapping) {
  auto m = manifest();
  const auto a = align_recording(m, m.recordings[0], recording(), "rec.h5");
  const glm::dvec3 f_burr{0.3, -1.2, 2.5};
  const glm::dmat3 Rs = m.sensor.rotation_sensor_to_rig, Rr = m.recordings[0].registration.rotation;
  // force on sample = −F_on_burr, seen in the sensor frame: v_rig = Rs·v_sensor.
  const glm::dvec3 want = -(glm::transpose(Rs) * (glm::transpose(Rr) * f_burr));
  EXPECT_NEAR(glm::length(a.sensor_force_from_burr_force(f_burr) - want), 0, 1e-12);
  // rotating the mapped force back gives −F in the volume frame
  EXPECT_NEAR(glm::length(Rr * (Rs * a.sensor_force_from_burr_force(f_burr)) + f_burr), 0, 1e-12);
  m.sensor.measures = ds::SensorMeasures::kForceOnBurr;
  const auto b = align_recording(m, m.recordings[0], recording(), "rec.h5");
  EXPECT_NEAR(glm::length(b.sensor_force_from_burr_force(f_burr) + want), 0, 1e-12);
}

// The sensor's moment (MODEL.md "Moments"): the closed form, the moment transfer law when the
// sensor origin moves, a rotated sensor, and a rigid motion of the whole scene (volume and
// rig together) that must leave every reading unchanged; T·F is frame- and origin-free.
TEST(Experiment, SensorWrenchIsCovariantUnderMovingTheSceneAndTheSensor) {
  auto m = manifest();
  m.sensor.origin_rig_mm = {3, -4, 12};
  const auto a = align_recording(m, m.recordings[0], recording(), "rec.h5");
  const glm::dvec3 F{0.3, -1.2, 2.5}, T{0.05, 0.02, -0.11}, p{11, 22, 29};
  const glm::dmat3 Q = m.sensor.rotation_sensor_to_rig, R = m.recordings[0].registration.rotation;
  const glm::dvec3 o_vol = R * m.sensor.origin_rig_mm + glm::dvec3(10, 20, 30);
  const glm::dvec3 want = -(glm::transpose(Q) * (glm::transpose(R) * (glm::cross(p - o_vol, F) + T)));
  const glm::dvec3 M = a.sensor_torque_from_burr_wrench(F, T, p);
  EXPECT_NEAR(glm::length(M - want), 0, 1e-12);
  // T·F survives every frame and origin: M·F_sensor = T·F (both flip sign with s).
  EXPECT_NEAR(glm::dot(M, a.sensor_force_from_burr_force(F)), glm::dot(T, F), 1e-12);
  // Moving the origin by d (rig frame) changes the moment by −(d × F_sensor) in sensor axes.
  auto m2 = m;
  const glm::dvec3 d{0.5, 1.5, -2};
  m2.sensor.origin_rig_mm += d;
  const auto b = align_recording(m2, m2.recordings[0], recording(), "rec.h5");
  const glm::dvec3 d_sensor = glm::transpose(Q) * d;
  EXPECT_NEAR(glm::length(b.sensor_torque_from_burr_wrench(F, T, p) -
                          (M - glm::cross(d_sensor, a.sensor_force_from_burr_force(F)))), 0, 1e-12);
  // Rotating the sensor by S about its origin: both readings turn by Sᵀ.
  auto m3 = m;
  const glm::dmat3 S = rotation(1.1, {1, 2, 3});
  m3.sensor.rotation_sensor_to_rig = Q * S;
  const auto c = align_recording(m3, m3.recordings[0], recording(), "rec.h5");
  EXPECT_NEAR(glm::length(c.sensor_torque_from_burr_wrench(F, T, p) - glm::transpose(S) * M), 0, 1e-12);
  EXPECT_NEAR(glm::length(c.sensor_force_from_burr_force(F) - glm::transpose(S) * a.sensor_force_from_burr_force(F)),
              0, 1e-12);
  // The whole scene moved rigidly in the volume frame (G, g): the burr's wrench and the
  // registration move with it, the sensor (on the rig) reads the same.
  auto m4 = m;
  const glm::dmat3 G = rotation(-0.8, {2, -1, 0.5});
  const glm::dvec3 g{-7, 3, 1.5};
  m4.recordings[0].registration.rotation = G * R;
  m4.recordings[0].registration.translation_mm = G * glm::dvec3(10, 20, 30) + g;
  const auto e = align_recording(m4, m4.recordings[0], recording(), "rec.h5");
  EXPECT_NEAR(glm::length(e.sensor_torque_from_burr_wrench(G * F, G * T, G * p + g) - M), 0, 1e-11);
  EXPECT_NEAR(glm::length(e.sensor_force_from_burr_force(G * F) - a.sensor_force_from_burr_force(F)), 0, 1e-12);
}

TEST(Experiment, SpindleTorqueIsTheCouplesBrakingComponent) {
  const glm::dvec3 w{0, 0, -300};  // spinning about −z
  EXPECT_DOUBLE_EQ(spindle_torque_Nmm({0.1, -0.2, 0.4}, w), 0.4);   // −T·ω̂ = −(0.4·(−1))
  EXPECT_DOUBLE_EQ(spindle_torque_Nmm({0.1, -0.2, -0.4}, w), -0.4);
  EXPECT_EQ(spindle_torque_Nmm({1, 2, 3}, glm::dvec3(0)), 0.0);  // standing spindle: no load
}

TEST(Experiment, MomentAndSpindleLoadChannelsAreAligned) {
  const auto m = manifest();
  auto rec = recording();
  ds::Channel tq{ds::kTorque, "N*mm", 3, {}};
  for (std::size_t k = 0; k < 200; ++k) tq.values.insert(tq.values.end(), {0.5 * double(k), 1.0, -2.0});
  rec.streams[0].channels.push_back(tq);
  // The drive's power at 250 Hz on the spindle stream: P = 0.02 W·(1 + t).
  ds::Channel pw{ds::kSpindlePower, "W", 1, {}};
  for (auto t : rec.streams[2].t_ns) pw.values.push_back(0.02 * (1 + double(t - 10'000'000'000) * 1e-9));
  rec.streams[2].channels.push_back(pw);
  const auto a = align_recording(m, m.recordings[0], rec, "rec.h5");
  ASSERT_EQ(a.torque_sensor_Nmm.size(), 200u);
  EXPECT_EQ(a.torque_sensor_Nmm[9], glm::dvec3(4.5, 1, -2));
  ASSERT_FALSE(a.spindle_torque_Nmm.t_s.empty());
  for (double t : {0.01, 0.1, 0.15}) {
    // τ = 1000·P/|ω| (N·mm from W and rad/s); P and rpm are both linear, so compare at
    // the spindle's own sample instants, where neither is interpolated.
    const double ts = 0.004 * std::round((t + 0.002) / 0.004) - 0.002;
    const double w = 2 * M_PI * rpm_at(ts) / 60;
    EXPECT_NEAR(a.spindle_torque_Nmm.at(ts), 1000 * 0.02 * (1 + ts) / w, 1e-9) << ts;
  }
  // A torque and a power channel at once: which one is right? Refused.
  ds::Channel st{ds::kSpindleTorque, "N*mm", 1, std::vector<double>(rec.streams[2].samples(), 0.1)};
  rec.streams[2].channels.push_back(st);
  EXPECT_THROW(align_recording(m, m.recordings[0], rec, "rec.h5"), InputError);
}

TEST(Experiment, SegmentsStaleSamplesAndFiducials) {
  auto m = manifest();
  m.recordings[0].segments = {{0.0, 0.1, true, "a"}, {0.05, 0.06, false, "skip"}};
  auto m_fid = m;
  const glm::dmat3 R = rotation(-0.4, {1, 1, 1});
  const glm::dvec3 t{1, 2, 3};
  m_fid.recordings[0].registration = {};
  for (glm::dvec3 p :
       {glm::dvec3(0, 0, 0), glm::dvec3(10, 0, 0), glm::dvec3(0, 10, 0), glm::dvec3(0, 0, 10)}) {
    m_fid.recordings[0].registration.fiducials_rig_mm.push_back(p);
    m_fid.recordings[0].registration.fiducials_vol_mm.push_back(R * p + t);
  }
  auto rec = recording();
  rec.streams[0].stale[3] = 1;  // a repeated value: dropped
  const auto a = align_recording(m_fid, m_fid.recordings[0], rec, "rec.h5");
  EXPECT_EQ(a.t_s.size(), 199u);
  EXPECT_EQ(a.dropped_force_samples, 1u);
  EXPECT_EQ(a.force_sensor_N[3], glm::dvec3(4, 8, -1));
  std::size_t used = 0;
  for (std::size_t k = 0; k < a.t_s.size(); ++k) {
    const long ms = std::lround(a.t_s[k] * 1e3);  // samples every 1 ms; bounds inclusive
    const bool want = ms <= 100 && !(ms >= 50 && ms <= 60);
    EXPECT_EQ(bool(a.use[k]), want) << a.t_s[k];
    used += a.use[k];
  }
  EXPECT_EQ(used, 101u - 1u - 11u);  // 0..100 ms minus the stale one minus 50..60 ms
  ASSERT_TRUE(a.fiducial_fit.has_value());
  EXPECT_LT(a.fiducial_fit->rms_mm, 1e-10);
  EXPECT_NEAR(glm::length(a.rig_to_vol.t - t), 0, 1e-10);
}

// The fixture's stage without samples first … first + count − 1 (a stretch it missed).
ds::Recording recording_without_stage_samples(std::size_t first, std::size_t count) {
  auto rec = recording();
  auto& st = rec.streams[1];
  const auto cut = [&](auto& v, std::size_t width) {
    v.erase(v.begin() + std::ptrdiff_t(first * width), v.begin() + std::ptrdiff_t((first + count) * width));
  };
  cut(st.t_ns, 1);
  cut(st.t_send_ns, 1);
  cut(st.t_recv_ns, 1);
  cut(st.stale, 1);
  cut(st.channels[0].values, 3);
  return rec;
}

TEST(Experiment, ForceSamplesInAGapOfTheStagePositionsAreLeftOutOfUse) {
  const auto m = manifest();
  // Stage samples every 1.25 ms from −0.3 ms: without 40…44 the interval 39 → 45 lasts
  // 7.5 ms, longer than 5 × 1.25 ms. The force samples inside it, counted here by brute
  // force, have no measured position.
  const auto rec = recording_without_stage_samples(40, 5);
  const double from = (39 * 1.25 - 0.3) * 1e-3, to = (45 * 1.25 - 0.3) * 1e-3;
  const auto a = align_recording(m, m.recordings[0], rec, "rec.h5");
  EXPECT_NEAR(a.position_period_s, 1.25e-3, 1e-15);
  ASSERT_EQ(a.position_gaps.size(), 1u);
  std::size_t inside = 0;
  for (std::size_t k = 0; k < a.t_s.size(); ++k) {
    const bool in_gap = a.t_s[k] > from && a.t_s[k] < to;
    inside += in_gap;
    EXPECT_EQ(a.use[k], in_gap ? 0 : 1) << a.t_s[k];
    EXPECT_EQ(a.use_calibrate[k], in_gap ? 0 : 1) << a.t_s[k];
  }
  EXPECT_EQ(inside, 7u);  // 49 … 55 ms
  EXPECT_EQ(a.unmeasured_position_samples(), inside);
  EXPECT_DOUBLE_EQ(a.position_gaps[0].from_s, 0.049);
  EXPECT_DOUBLE_EQ(a.position_gaps[0].to_s, 0.055);
  EXPECT_NEAR(a.position_gaps[0].gap_s, 7.5e-3, 1e-12);
  // Still replayed: along the straight line across the gap (exact for this linear motion).
  const glm::dmat3 R = m.recordings[0].registration.rotation;
  const glm::dvec3 want = R * (stage_at(0.052) + m.burr.tool_offset_mm) + glm::dvec3(10, 20, 30);
  EXPECT_NEAR(glm::length(a.trajectory().centre_vol_mm[52] - want), 0, 1e-12);
  const std::string text = a.position_gap_text();
  EXPECT_NE(text.find("Recording rec: the stage measured no position for 7 force samples, in 1 gap(s)"),
            std::string::npos) << text;
  EXPECT_NE(text.find("t = 0.049 … 0.055 s (0.0075 s without a position sample)"), std::string::npos) << text;

  // Three samples missing (an interval of 5 ms) is no gap: every sample stays in use.
  const auto b = align_recording(m, m.recordings[0], recording_without_stage_samples(40, 3), "rec.h5");
  EXPECT_TRUE(b.position_gaps.empty());
  EXPECT_EQ(std::count(b.use.begin(), b.use.end(), 1), 200);
  EXPECT_EQ(b.position_gap_text(), "");
}

TEST(Experiment, ForceSamplesFarBeyondTheStagesEndsAtTheLagAreLeftOutOfUse) {
  // Lag 12.3 ms: the force at t answers the position at t − 12.3 ms, before the first
  // stage sample (−0.3 ms) by more than 6.25 ms for t < 5.75 ms: samples 0 … 5.
  auto m = manifest();
  m.recordings[0].lag_ms = 12.3;
  const auto a = align_recording(m, m.recordings[0], recording(), "rec.h5");
  ASSERT_EQ(a.position_gaps.size(), 1u);
  EXPECT_EQ(a.unmeasured_position_samples(), 6u);
  for (std::size_t k = 0; k < 10; ++k) EXPECT_EQ(a.use[k], k < 6 ? 0 : 1) << k;
  // Lag −20 ms: past the last stage sample (210.95 ms) by more than 6.25 ms for t > 197.2 ms.
  m.recordings[0].lag_ms = -20;
  const auto b = align_recording(m, m.recordings[0], recording(), "rec.h5");
  ASSERT_EQ(b.position_gaps.size(), 1u);
  EXPECT_EQ(b.unmeasured_position_samples(), 2u);
  EXPECT_EQ(b.use[197], 1);
  EXPECT_EQ(b.use[198], 0);
  EXPECT_EQ(b.use[199], 0);
  // At the manifest's default lag (0) nothing is beyond either end.
  EXPECT_TRUE(align_recording(manifest(), manifest().recordings[0], recording(), "rec.h5").position_gaps.empty());
}

TEST(Experiment, TheTrajectoryFollowsTheStageAcrossAGapInTheForceStream) {
  // Force samples 50 … 99 missing (a sensor that dropped out), and the stage 0.3 mm off the
  // line from 49 ms to 100 ms at one of its samples inside (t = 60.95 ms, sample 49): the
  // trajectory passes where the full recording's did at the missing times, not along the line.
  const auto m = manifest();
  auto full = recording();
  full.streams[1].channels[0].values[3 * 49 + 1] += 0.3;
  auto cut = full;
  auto& ft = cut.streams[0];
  ft.t_ns.erase(ft.t_ns.begin() + 50, ft.t_ns.begin() + 100);
  ft.t_send_ns = ft.t_recv_ns = ft.t_ns;
  ft.stale.resize(ft.t_ns.size());
  auto& f = ft.channels[0].values;
  f.erase(f.begin() + 150, f.begin() + 300);
  const auto a = align_recording(m, m.recordings[0], full, "rec.h5");
  const auto b = align_recording(m, m.recordings[0], cut, "rec.h5");
  EXPECT_TRUE(a.via_times.empty());
  EXPECT_TRUE(b.position_gaps.empty());  // its positions are all measured
  ASSERT_EQ(b.via_times.size(), 50u);
  ASSERT_EQ(b.silences().size(), 1u);  // the report's quality event
  EXPECT_DOUBLE_EQ(b.silences()[0].from_s, b.t_s[49]);
  EXPECT_DOUBLE_EQ(b.silences()[0].to_s, b.t_s[50]);
  EXPECT_TRUE(a.silences().empty());
  for (std::size_t j = 0; j < 50; ++j) {
    EXPECT_EQ(b.via_times[j].after, 49u);
    EXPECT_NEAR(b.via_times[j].t_s, a.t_s[50 + j], 1e-12);
  }
  for (const double lag_s : {0.0, 0.0023}) {
    const auto ta = a.trajectory(lag_s, 0.1), tb = b.trajectory(lag_s, 0.1);
    ASSERT_EQ(tb.vias.size(), 50u);
    const auto da = a.dcentre_dlag_ms(lag_s), db = b.dcentre_dlag_ms(lag_s);
    ASSERT_EQ(db.size(), 150u + 50u);  // the samples', then the vias'
    double off_line_mm = 0;
    for (std::size_t j = 0; j < 50; ++j) {
      const auto& v = tb.vias[j];
      EXPECT_NEAR(glm::length(v.centre_vol_mm - ta.centre_vol_mm[50 + j]), 0, 1e-12) << j;
      EXPECT_NEAR(glm::length(v.omega_vol_rad_s - ta.omega_vol_rad_s[50 + j]), 0, 1e-9) << j;
      EXPECT_NEAR(glm::length(db[150 + j] - da[50 + j]), 0, 1e-12) << j;
      const double f = (v.t_s - tb.t_s[49]) / (tb.t_s[50] - tb.t_s[49]);
      off_line_mm = std::max(off_line_mm, glm::length(v.centre_vol_mm - glm::mix(tb.centre_vol_mm[49], tb.centre_vol_mm[50], f)));
    }
    EXPECT_GT(off_line_mm, 0.15) << "the vias follow the stage off the line";
  }
}

TEST(Experiment, TheTrajectoryFollowsTheStageBeforeALateFirstForceSample) {
  // The sensor's first 30 samples missing (it started at 30 ms): the stage's path from its
  // own first sample (−0.3 ms) is followed at the force's interval (30.3 ms in 30 steps).
  const auto m = manifest();
  auto rec = recording();
  auto& ft = rec.streams[0];
  ft.t_ns.erase(ft.t_ns.begin(), ft.t_ns.begin() + 30);
  ft.t_send_ns = ft.t_recv_ns = ft.t_ns;
  ft.stale.resize(ft.t_ns.size());
  ft.channels[0].values.erase(ft.channels[0].values.begin(), ft.channels[0].values.begin() + 90);
  const auto a = align_recording(m, m.recordings[0], rec, "rec.h5");
  ASSERT_EQ(a.via_times.size(), 30u);  // 30.3 ms at 1 ms, rounded
  const double t0 = a.t_s[0];
  for (std::size_t j = 0; j < 30; ++j) {
    EXPECT_EQ(a.via_times[j].after, Trajectory::Via::kBeforeFirst);
    EXPECT_NEAR(a.via_times[j].t_s, t0 - 0.0303 * double(30 - j) / 30, 1e-12) << j;
  }
  ASSERT_EQ(a.silences().size(), 1u);
  EXPECT_NEAR(a.silences()[0].from_s, t0 - 0.0303, 1e-12);
  EXPECT_EQ(a.silences()[0].to_s, t0);
  const auto tr = a.trajectory(0.0, 0.0);
  EXPECT_NEAR(glm::length(tr.vias.front().centre_vol_mm - a.centre_vol_mm(stage_at(-0.0003))), 0, 1e-12);
  EXPECT_NEAR(glm::length(tr.vias.back().centre_vol_mm - a.centre_vol_mm(stage_at(0.030 - 0.0303 / 30))), 0, 1e-12);
  // A sensor that starts with the stage has none.
  EXPECT_TRUE(align_recording(m, m.recordings[0], recording(), "rec.h5").via_times.empty());
}

TEST(Experiment, MissingChannelsAreInputErrors) {
  const auto m = manifest();
  auto rec = recording();
  rec.streams.erase(rec.streams.begin() + 2);  // no spindle
  try {
    align_recording(m, m.recordings[0], rec, "rec.h5");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(
                  "rec.h5: streams: expected a stream with the channel spindle_rpm"),
              std::string::npos)
        << e.what();
  }
  auto rec2 = recording();
  rec2.streams[1].channels[0].width = 2;
  EXPECT_THROW(align_recording(m, m.recordings[0], rec2, "rec.h5"), InputError);
  auto m2 = manifest();
  m2.recordings[0].registration.fiducials_rig_mm = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
  m2.recordings[0].registration.fiducials_vol_mm = {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}};
  EXPECT_THROW(align_recording(m2, m2.recordings[0], recording(), "rec.h5"), InputError);
}
