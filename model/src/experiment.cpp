// Experiment layer: recordings → aligned, registered trajectories (docs/replay.md).
#include "burrbench/model/experiment.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/same_file.hpp"

namespace burrbench::model {

template <class T>
T Series<T>::at(double t) const {
  BURRBENCH_CHECK(!t_s.empty() && t_s.size() == value.size(), "empty or ragged series");
  if (!(t > t_s.front())) return value.front();
  if (t >= t_s.back()) return value.back();
  const auto it = std::upper_bound(t_s.begin(), t_s.end(), t);
  const std::size_t j = std::size_t(it - t_s.begin()) - 1;
  const double u = (t - t_s[j]) / (t_s[j + 1] - t_s[j]);
  return value[j] + u * (value[j + 1] - value[j]);  // u = 0 returns value[j] exactly
}
template <class T>
T Series<T>::slope(double t) const {
  BURRBENCH_CHECK(!t_s.empty() && t_s.size() == value.size(), "empty or ragged series");
  const std::size_t n = t_s.size();
  if (n < 2 || t < t_s.front() || t > t_s.back()) return T(0);
  auto seg = [&](std::size_t j) { return (value[j + 1] - value[j]) / (t_s[j + 1] - t_s[j]); };
  const auto it = std::upper_bound(t_s.begin(), t_s.end(), t);
  const std::size_t j = std::size_t(it - t_s.begin()) - 1;  // t_s[j] <= t
  if (t > t_s[j]) return seg(j);
  // On a sample instant: mean of the slopes on either side (one side at the ends, halved
  // there too, since at() is clamped beyond them).
  const T left = j > 0 ? seg(j - 1) : T(0), right = j + 1 < n ? seg(j) : T(0);
  return 0.5 * (left + right);
}

template struct Series<double>;
template struct Series<glm::dvec3>;

glm::dvec3 AlignedRecording::centre_vol_mm(const glm::dvec3& stage, double depth_offset_mm) const {
  return rig_to_vol.apply(stage + tool_offset_rig_mm) - depth_offset_mm * shaft_axis_vol;
}

glm::dvec3 AlignedRecording::omega_vol_rad_s(double rpm) const {
  return (2 * M_PI * rpm / 60.0 * double(spin_sign)) * shaft_axis_vol;
}

Trajectory AlignedRecording::trajectory(double lag, double depth_offset_mm,
                                        const PoseCorrection* pose) const {
  Trajectory tr;
  tr.t_s = t_s;
  tr.centre_vol_mm.resize(t_s.size());
  tr.omega_vol_rad_s.resize(t_s.size());
  for (std::size_t k = 0; k < t_s.size(); ++k) {
    const double tau = t_s[k] - lag;  // the force at t_k answers the position at t_k − lag
    tr.centre_vol_mm[k] = centre_vol_mm(stage_rig_mm.at(tau), depth_offset_mm);
    tr.omega_vol_rad_s[k] = omega_vol_rad_s(spindle_rpm.at(tau));
    if (pose) {
      tr.centre_vol_mm[k] = pose->apply(tr.centre_vol_mm[k]);
      tr.omega_vol_rad_s[k] = pose->rotate(tr.omega_vol_rad_s[k]);
    }
  }
  for (const auto& v : via_times) {
    const double tau = v.t_s - lag;
    glm::dvec3 c = centre_vol_mm(stage_rig_mm.at(tau), depth_offset_mm);
    glm::dvec3 w = omega_vol_rad_s(spindle_rpm.at(tau));
    if (pose) {
      c = pose->apply(c);
      w = pose->rotate(w);
    }
    tr.vias.push_back({v.after, v.t_s, c, w});
  }
  return tr;
}

std::vector<glm::dvec3> AlignedRecording::dcentre_dlag_ms(double lag) const {
  std::vector<glm::dvec3> d;
  d.reserve(t_s.size() + via_times.size());
  auto at = [&](double t) {  // centre(t − lag): d/dlag = −R·stage'
    d.push_back(-1e-3 * (rig_to_vol.R * stage_rig_mm.slope(t - lag)));
  };
  for (double t : t_s) at(t);
  for (const auto& v : via_times) at(v.t_s);
  return d;
}

std::vector<double> AlignedRecording::spindle_krpm_deviation() const {
  std::vector<double> k;
  k.reserve(t_s.size());
  double mean = 0;
  for (double t : t_s) {
    k.push_back(std::abs(spindle_rpm.at(t)) / 1000);
    mean += k.back() / double(t_s.size());
  }
  for (double& v : k) v -= mean;
  return k;
}

glm::dvec3 AlignedRecording::sensor_force_from_burr_force(const glm::dvec3& f_burr_vol,
                                                          const PoseCorrection* pose) const {
  const glm::dvec3 f_rig = glm::transpose(rig_to_vol.R) * (pose ? pose->unrotate(f_burr_vol) : f_burr_vol);
  return sensor_sign * (glm::transpose(sensor_to_rig) * f_rig);
}

glm::dvec3 AlignedRecording::sensor_torque_from_burr_wrench(const glm::dvec3& f_vol, const glm::dvec3& t_vol,
                                                            const glm::dvec3& p_vol,
                                                            const PoseCorrection* pose) const {
  glm::dvec3 o_vol = rig_to_vol.apply(sensor_origin_rig_mm);
  if (pose) o_vol = pose->apply(o_vol);
  const glm::dvec3 m_vol = glm::cross(p_vol - o_vol, f_vol) + t_vol;
  const glm::dvec3 m_rig = glm::transpose(rig_to_vol.R) * (pose ? pose->unrotate(m_vol) : m_vol);
  return sensor_sign * (glm::transpose(sensor_to_rig) * m_rig);
}

double spindle_torque_Nmm(const glm::dvec3& t_vol, const glm::dvec3& omega) {
  const double w = glm::length(omega);
  return w > 0 ? -glm::dot(t_vol, omega) / w : 0.0;
}

namespace {

const data_schema::Channel& channel(const data_schema::Recording& rec, const char* name,
                                    std::size_t width, const std::string& file) {
  const data_schema::Stream* s = rec.stream_with(name);
  if (!s) throw InputError(file, "streams", fmt::format("a stream with the channel {}", name));
  const data_schema::Channel* c = s->channel(name);
  if (c->width != width || c->samples() != s->samples())
    throw InputError(
        file, fmt::format("streams/{}/{}", s->name, name),
        fmt::format("{} column(s) and one row per sample", width),
        fmt::format("{} column(s), {} rows for {} samples", c->width, c->samples(), s->samples()));
  if (s->samples() == 0) throw InputError(file, "streams/" + s->name, "at least one sample");
  return *c;
}

// Indices of fresh samples with strictly increasing timestamps (a stale sample repeats an
// older value, so its timestamp is not when that value was measured).
std::vector<std::size_t> fresh(const data_schema::Stream& s) {
  std::vector<std::size_t> keep;
  for (std::size_t i = 0; i < s.samples(); ++i) {
    if (!s.stale.empty() && s.stale[i]) continue;
    if (!keep.empty() && s.t_ns[i] <= s.t_ns[keep.back()]) continue;
    keep.push_back(i);
  }
  return keep;
}

double seconds(std::int64_t t_ns, std::int64_t t0_ns) { return double(t_ns - t0_ns) * 1e-9; }

// The median interval between consecutive instants (twice the replay's default step).
double median_interval_s(const std::vector<double>& t) { return 2 * default_step_s(t); }

// The force samples whose position (at t − lag) the stage did not measure, grouped by the
// stage's interval they fall in, and taken out of use (AlignedRecording::position_gaps).
// One position sample gives no interval to judge by: nothing is marked then.
void mark_position_gaps(AlignedRecording& a) {
  const auto& ts = a.stage_rig_mm.t_s;
  if (ts.size() < 2) return;
  a.position_period_s = median_interval_s(ts);
  const double limit_s = kPositionGapFactor * a.position_period_s;
  constexpr std::ptrdiff_t kMeasured = -2;
  std::ptrdiff_t current = kMeasured;  // the stage interval of the gap being grouped
  for (std::size_t k = 0; k < a.t_s.size(); ++k) {
    const double tau = a.t_s[k] - a.lag_s;
    // Which gap holds tau: −1 before the first position sample, n−1 after the last, i for
    // the interval (ts[i], ts[i+1]); kMeasured when the position there is measured.
    std::ptrdiff_t gap = kMeasured;
    double gap_s = 0;
    if (tau < ts.front()) {
      if (ts.front() - tau > limit_s) gap = -1, gap_s = ts.front() - tau;
    } else if (tau > ts.back()) {
      if (tau - ts.back() > limit_s) gap = std::ptrdiff_t(ts.size()) - 1, gap_s = tau - ts.back();
    } else {
      const auto it = std::upper_bound(ts.begin(), ts.end(), tau);
      if (it != ts.end() && it != ts.begin() && tau > *(it - 1)) {
        const std::size_t j = std::size_t(it - ts.begin()) - 1;
        if (ts[j + 1] - ts[j] > limit_s) gap = std::ptrdiff_t(j), gap_s = ts[j + 1] - ts[j];
      }
    }
    if (gap == kMeasured) {
      current = kMeasured;
      continue;
    }
    if (gap != current) a.position_gaps.push_back({a.t_s[k], a.t_s[k], 0, 0});
    current = gap;
    auto& g = a.position_gaps.back();
    g.to_s = a.t_s[k];
    g.gap_s = std::max(g.gap_s, gap_s);
    ++g.force_samples;
    a.use_calibrate[k] = a.use_validate[k] = a.use[k] = 0;
  }
}

// The times at which the trajectory follows the stage where the force stream is silent
// (AlignedRecording::via_times): where the missing force samples would have been, at the
// stream's median interval, inside its long intervals and before its first sample back to
// the stage's first (at the manifest's lag). They do not move with a fitted lag.
void find_via_times(AlignedRecording& a) {
  const auto& t = a.t_s;
  if (t.size() < 3 || a.stage_rig_mm.t_s.empty()) return;
  const double period_s = median_interval_s(t);
  const double lead_s = t[0] - a.lag_s - a.stage_rig_mm.t_s.front();
  if (lead_s > kPositionGapFactor * period_s) {
    const std::size_t m = std::size_t(std::llround(lead_s / period_s));
    for (std::size_t j = m; j >= 1; --j)
      a.via_times.push_back({Trajectory::Via::kBeforeFirst, t[0] - lead_s * double(j) / double(m)});
  }
  for (std::size_t k = 0; k + 1 < t.size(); ++k) {
    const double T = t[k + 1] - t[k];
    if (!(T > kPositionGapFactor * period_s)) continue;
    const std::size_t m = std::size_t(std::llround(T / period_s));
    for (std::size_t j = 1; j < m; ++j) a.via_times.push_back({k, t[k] + T * double(j) / double(m)});
  }
}

}  // namespace

std::vector<AlignedRecording::Silence> AlignedRecording::silences() const {
  std::vector<Silence> out;
  for (std::size_t i = 0; i < via_times.size(); ++i) {
    const ViaTime& v = via_times[i];
    if (i > 0 && via_times[i - 1].after == v.after) continue;  // one stretch per interval
    const bool lead = v.after == Trajectory::Via::kBeforeFirst;
    out.push_back({lead ? v.t_s : t_s[v.after], t_s[lead ? 0 : v.after + 1]});
  }
  return out;
}

std::size_t AlignedRecording::unmeasured_position_samples() const {
  std::size_t n = 0;
  for (const auto& g : position_gaps) n += g.force_samples;
  return n;
}

std::string AlignedRecording::position_gap_text() const {
  if (position_gaps.empty()) return "";
  constexpr std::size_t kListed = 3;
  std::vector<std::string> listed;
  for (std::size_t i = 0; i < position_gaps.size() && i < kListed; ++i) {
    const auto& g = position_gaps[i];
    listed.push_back(fmt::format("t = {:.6g} … {:.6g} s ({:.4g} s without a position sample)", g.from_s, g.to_s,
                                 g.gap_s));
  }
  if (position_gaps.size() > kListed) listed.push_back(fmt::format("{} more", position_gaps.size() - kListed));
  return fmt::format(
      "Recording {}: the stage measured no position for {} force samples, in {} gap(s) longer than {:g} x its "
      "median interval of {:.4g} ms at the manifest's lag: {}. They are replayed along the straight line across "
      "each gap and left out of the fit and the metrics.",
      id, unmeasured_position_samples(), position_gaps.size(), kPositionGapFactor, position_period_s * 1e3,
      fmt::join(listed, "; "));
}

std::vector<std::string> alignment_warnings(const Experiment& e) {
  std::vector<std::string> out;
  for (const auto& r : e.recordings) {
    if (!r.position_gaps.empty()) out.push_back(r.position_gap_text());
    if (std::string w = start_in_bone(e, r).text(r); !w.empty()) out.push_back(std::move(w));
  }
  return out;
}

namespace {

// The force (and the moment, when the sensor's stream carries it): the fresh rows of the
// force stream, whose first sets the recording's t = 0. Returns the rows kept.
std::vector<std::size_t> read_force(AlignedRecording& a, const data_schema::Recording& rec,
                                    const std::string& file) {
  const auto& force = channel(rec, data_schema::kForce, 3, file);
  const data_schema::Stream& f_stream = *rec.stream_with(data_schema::kForce);
  std::vector<std::size_t> f_keep = fresh(f_stream);
  if (f_keep.empty())
    throw InputError(file, "streams/" + f_stream.name, "at least one fresh sample");
  a.dropped_force_samples = f_stream.samples() - f_keep.size();
  a.force_stream = f_stream.name;
  a.t0_ns = f_stream.t_ns[f_keep.front()];
  a.notes = rec.meta.notes;
  for (const auto& e : rec.events) a.events.push_back({seconds(e.t_ns, a.t0_ns), e.kind, e.stream, e.detail});
  for (const auto& st : rec.streams) {
    std::size_t n = 0;
    for (auto v : st.stale) n += v != 0;
    a.stale_rows[st.name] = n;
  }
  for (std::size_t i : f_keep) {
    a.t_s.push_back(seconds(f_stream.t_ns[i], a.t0_ns));
    a.force_sensor_N.emplace_back(force.values[3 * i], force.values[3 * i + 1],
                                  force.values[3 * i + 2]);
  }

  // The moment, when the sensor's stream carries it (six-axis sensors).
  if (const data_schema::Channel* tq = f_stream.channel(data_schema::kTorque)) {
    if (tq->width != 3 || tq->samples() != f_stream.samples())
      throw InputError(file, fmt::format("streams/{}/{}", f_stream.name, data_schema::kTorque),
                       "3 columns and one row per sample",
                       fmt::format("{} column(s), {} rows for {} samples", tq->width, tq->samples(), f_stream.samples()));
    for (std::size_t i : f_keep)
      a.torque_sensor_Nmm.emplace_back(tq->values[3 * i], tq->values[3 * i + 1], tq->values[3 * i + 2]);
  }
  return f_keep;
}

void read_stage_position(AlignedRecording& a, const data_schema::Recording& rec, const std::string& file) {
  const auto& pos = channel(rec, data_schema::kPosition, 3, file);
  const data_schema::Stream& p_stream = *rec.stream_with(data_schema::kPosition);
  for (std::size_t i : fresh(p_stream)) {
    a.stage_rig_mm.t_s.push_back(seconds(p_stream.t_ns[i], a.t0_ns));
    a.stage_rig_mm.value.emplace_back(pos.values[3 * i], pos.values[3 * i + 1],
                                      pos.values[3 * i + 2]);
  }
  if (a.stage_rig_mm.t_s.empty())
    throw InputError(file, "streams/" + p_stream.name, "at least one fresh sample");
}

// The spindle speed: the recording's channel, or the manifest's constant when the rig
// did not log it — never both (which one would be right?).
void read_spindle_speed(AlignedRecording& a, const data_schema::ExperimentManifest& m,
                        const data_schema::RecordingRef& ref, const data_schema::Recording& rec,
                        const std::string& file) {
  if (const data_schema::Stream* s_stream = rec.stream_with(data_schema::kSpindle)) {
    if (ref.spindle_rpm)
      throw InputError(m.file.string(), "recordings." + ref.id + ".spindle_rpm",
                       "no constant speed for a recording that logs spindle_rpm (" + file + ")", "both");
    const auto& rpm = channel(rec, data_schema::kSpindle, 1, file);
    for (std::size_t i : fresh(*s_stream)) {
      a.spindle_rpm.t_s.push_back(seconds(s_stream->t_ns[i], a.t0_ns));
      a.spindle_rpm.value.push_back(rpm.values[i]);
    }
    if (a.spindle_rpm.t_s.empty())
      throw InputError(file, "streams/" + s_stream->name, "at least one fresh sample");
  } else if (ref.spindle_rpm) {
    a.spindle_rpm.t_s = {0.0};
    a.spindle_rpm.value = {*ref.spindle_rpm};
  } else {
    throw InputError(file, "streams", "a stream with the channel spindle_rpm, or spindle_rpm = RPM for recording " +
                                          ref.id + " in the manifest (a constant speed)");
  }
}

// The spindle's load: a torque channel, or a power channel converted through the speed
// at the same instant (τ = 1000·P/|ω|, N·mm from W; none where the spindle stands).
void read_spindle_load(AlignedRecording& a, const data_schema::Recording& rec, const std::string& file) {
  const data_schema::Stream* tq_stream = rec.stream_with(data_schema::kSpindleTorque);
  const data_schema::Stream* pw_stream = rec.stream_with(data_schema::kSpindlePower);
  if (tq_stream && pw_stream)
    throw InputError(file, "streams", "spindle_torque_Nmm or spindle_power_W, not both", "both");
  if (tq_stream || pw_stream) {
    const bool power = !tq_stream;
    const auto& st = *(power ? pw_stream : tq_stream);
    const auto& c = channel(rec, power ? data_schema::kSpindlePower : data_schema::kSpindleTorque, 1, file);
    for (std::size_t i : fresh(st)) {
      const double t = seconds(st.t_ns[i], a.t0_ns);
      double v = c.values[i];
      if (power) {
        const double w = std::abs(a.spindle_rpm.at(t)) * 2 * M_PI / 60;
        if (!(w > 0)) continue;
        v = 1000 * v / w;
      }
      a.spindle_torque_Nmm.t_s.push_back(t);
      a.spindle_torque_Nmm.value.push_back(v);
    }
  }
}

// Segments: a sample is used when some use=true segment holds it and no use=false one does.
// Bounds are inclusive and compared in integer ns (start_s rounded to the ns), so a
// sample exactly on a boundary is never lost to rounding. A segment's role (default: the
// recording's) says whether its samples calibrate or validate.
void mark_segments(AlignedRecording& a, const data_schema::RecordingRef& ref, const data_schema::Stream& f_stream,
                   const std::vector<std::size_t>& f_keep) {
  const bool whole = ref.segments.empty();
  const bool cal = ref.role == data_schema::RecordingRole::kCalibrate;
  a.use_calibrate.assign(a.t_s.size(), whole && cal ? 1 : 0);
  a.use_validate.assign(a.t_s.size(), whole && !cal ? 1 : 0);
  for (bool pass_use : {true, false})
    for (const auto& seg : ref.segments) {
      if (seg.use != pass_use) continue;
      const bool seg_cal = seg.role.value_or(ref.role) == data_schema::RecordingRole::kCalibrate;
      const double lo = std::round(seg.start_s * 1e9), hi = std::round(seg.end_s * 1e9);
      for (std::size_t k = 0; k < a.t_s.size(); ++k) {
        const double rel_ns = double(f_stream.t_ns[f_keep[k]] - a.t0_ns);
        if (!(rel_ns >= lo && rel_ns <= hi)) continue;
        if (!seg.use) {
          a.use_calibrate[k] = a.use_validate[k] = 0;
        } else {
          (seg_cal ? a.use_calibrate : a.use_validate)[k] = 1;
          (seg_cal ? a.use_validate : a.use_calibrate)[k] = 0;
        }
      }
    }
  a.use.resize(a.t_s.size());
  for (std::size_t k = 0; k < a.t_s.size(); ++k) a.use[k] = a.use_calibrate[k] | a.use_validate[k];
}

// The rig-to-volume transform: fitted to the fiducials (and checked against their error),
// or given and checked to be a rotation.
void register_to_volume(AlignedRecording& a, const data_schema::RecordingRef& ref, const std::string& mfile,
                        const std::string& reg_field) {
  if (ref.registration.from_fiducials()) {
    const auto& g = ref.registration;
    a.fiducial_fit = fit_rigid(g.fiducials_rig_mm, g.fiducials_vol_mm, mfile, reg_field);
    auto& rs = a.registration;
    rs.method = "fiducials";
    rs.fiducials = g.fiducials_rig_mm.size();
    rs.fle_given = g.fiducial_error_mm.has_value();
    rs.fle_mm = g.fiducial_error_mm.value_or(kDefaultFiducialErrorMm);
    check_fiducial_fit(*a.fiducial_fit, g.fiducials_rig_mm, g.fiducials_vol_mm,
                       kFiducialLimitFactor * rs.fle_mm, mfile, reg_field + ".fiducials_vol_mm");
    a.rig_to_vol = a.fiducial_fit->transform;
    rs.rms_mm = a.fiducial_fit->rms_mm;
    rs.max_mm = a.fiducial_fit->max_mm;
    for (std::size_t i = 0; i < a.fiducial_fit->residual_mm.size(); ++i)
      if (rs.worst < 0 || a.fiducial_fit->residual_mm[i] > a.fiducial_fit->residual_mm[std::size_t(rs.worst)])
        rs.worst = int(i);
  } else {
    check_rotation(ref.registration.rotation, mfile, reg_field + ".rotation");
    a.rig_to_vol = {ref.registration.rotation, ref.registration.translation_mm};
    a.registration.method = ref.registration.given_as;
  }
}

// The manifest's burr, checked against the one the rig logged, and its sensor, in the
// recording's terms.
void take_burr_and_sensor(AlignedRecording& a, const data_schema::ExperimentManifest& m,
                          const data_schema::RecordingRef& ref, const data_schema::Recording& rec,
                          const std::string& file, std::size_t index) {
  const std::string mfile = m.file.string();
  // The burr the rig logged (radius 0, axis [0, 0, 0], spin 0: not stated) must be the one
  // the model drills with, unless the manifest waives the field.
  const auto waived = [&](const char* f) { return std::find(ref.waive.begin(), ref.waive.end(), f) != ref.waive.end(); };
  const double rec_r = rec.meta.burr_radius_mm;
  if (rec_r > 0 && std::abs(rec_r - m.burr.radius_mm) > 1e-9 * rec_r && !waived("burr_radius_mm"))
    throw InputError(mfile, "burr.radius_mm",
                     fmt::format("the burr radius recorded in {} (/meta/burr_radius_mm = {} mm), or "
                                 "recordings[{}].waive = [\"burr_radius_mm\"] to override it",
                                 file, rec_r, index),
                     fmt::format("{} mm", m.burr.radius_mm));
  const double axis_len = glm::length(m.burr.shaft_axis_rig);
  if (!(axis_len > 0)) throw InputError(mfile, "burr.shaft_axis_rig", "a non-zero vector");
  const glm::dvec3 rec_axis = rec.meta.burr_axis_rig;
  if (rec.meta.axis_stated() && glm::length(rec_axis - m.burr.shaft_axis_rig / axis_len) > 1e-6 &&
      !waived("burr_axis_rig"))
    throw InputError(mfile, "burr.shaft_axis_rig",
                     fmt::format("the shaft axis recorded in {} (/meta/burr_axis_rig = [{}, {}, {}]), or "
                                 "recordings[{}].waive = [\"burr_axis_rig\"] to override it",
                                 file, rec_axis.x, rec_axis.y, rec_axis.z, index),
                     fmt::format("[{}, {}, {}]", m.burr.shaft_axis_rig.x, m.burr.shaft_axis_rig.y,
                                 m.burr.shaft_axis_rig.z));
  if (rec.meta.spin_sign != 0 && rec.meta.spin_sign != m.burr.spin_sign && !waived("spin_sign"))
    throw InputError(mfile, "burr.spin_sign",
                     fmt::format("the spin recorded in {} (/meta/spin_sign = {:+d}), or recordings[{}].waive = "
                                 "[\"spin_sign\"] to override it",
                                 file, rec.meta.spin_sign, index),
                     fmt::format("{:+d}", m.burr.spin_sign));
  if (!(m.burr.radius_mm > 0)) throw InputError(mfile, "burr.radius_mm", "a radius > 0");
  if (m.burr.spin_sign != 1 && m.burr.spin_sign != -1)
    throw InputError(mfile, "burr.spin_sign", "1 or -1");
  a.shaft_axis_vol = glm::normalize(a.rig_to_vol.R * (m.burr.shaft_axis_rig / axis_len));
  a.spin_sign = m.burr.spin_sign;
  a.radius_mm = m.burr.radius_mm;
  a.tool_offset_rig_mm = m.burr.tool_offset_mm;
  a.sensor_to_rig = m.sensor.rotation_sensor_to_rig;
  a.sensor_sign = m.sensor.measures == data_schema::SensorMeasures::kForceOnSample ? -1.0 : 1.0;
  a.sensor_origin_rig_mm = m.sensor.origin_rig_mm;
}

// Predicted TRE along the burr's path (volume frame, as the fiducials).
void path_tre(AlignedRecording& a, const data_schema::RecordingRef& ref) {
  double ss = 0, mx = 0;
  const auto& fv = ref.registration.fiducials_vol_mm;
  for (const auto& p : a.stage_rig_mm.value) {
    const double e = predicted_tre_mm(fv, a.registration.fle_mm, a.centre_vol_mm(p));
    ss += e * e;
    mx = std::max(mx, e);
  }
  a.registration.tre_path_rms_mm = std::sqrt(ss / double(std::max<std::size_t>(1, a.stage_rig_mm.value.size())));
  a.registration.tre_path_max_mm = mx;
}

}  // namespace

AlignedRecording align_recording(const data_schema::ExperimentManifest& m,
                                 const data_schema::RecordingRef& ref,
                                 const data_schema::Recording& rec, const std::string& file) {
  AlignedRecording a;
  a.id = ref.id;
  a.sample_id = ref.sample;
  a.file = ref.path;
  const std::vector<std::size_t> f_keep = read_force(a, rec, file);
  read_stage_position(a, rec, file);
  read_spindle_speed(a, m, ref, rec, file);
  read_spindle_load(a, rec, file);
  mark_segments(a, ref, *rec.stream_with(data_schema::kForce), f_keep);

  const std::string mfile = m.file.string();
  std::size_t index = 0;
  while (index < m.recordings.size() && m.recordings[index].id != ref.id) ++index;
  register_to_volume(a, ref, mfile, fmt::format("recordings[{}].registration", index));
  check_rotation(m.sensor.rotation_sensor_to_rig, mfile, "sensor.rotation_sensor_to_rig");
  take_burr_and_sensor(a, m, ref, rec, file, index);
  if (!std::isfinite(ref.lag_ms))
    throw InputError(mfile, fmt::format("recordings[{}].lag_ms", index), "a finite number");
  a.lag_s = ref.lag_ms * 1e-3;
  mark_position_gaps(a);
  find_via_times(a);
  if (a.fiducial_fit) path_tre(a, ref);
  return a;
}

std::string RegistrationSummary::text() const {
  if (method != "fiducials") return fmt::format("registration {} (given; taken as exact)", method);
  return fmt::format("registration from {} fiducials: RMS {:.4g} mm, largest {:.4g} mm (fiducial {}); "
                     "predicted TRE along the path RMS {:.4g} mm, max {:.4g} mm (FLE {:.4g} mm{})",
                     fiducials, rms_mm, max_mm, worst, tre_path_rms_mm, tre_path_max_mm, fle_mm,
                     fle_given ? "" : ", default: set fiducial_error_mm");
}

Experiment load_experiment(const std::filesystem::path& manifest_path) {
  Experiment e;
  // Each file is hashed as it is read: a change from then on shows at check_unchanged.
  e.manifest = read_hashed(manifest_path, e.inputs, data_schema::read_manifest);
  for (const auto& s : e.manifest.samples) e.samples.emplace(s.id, read_hashed(s.path, e.inputs, data_schema::read_sample));
  for (const auto& r : e.manifest.recordings) {
    const auto rec = read_hashed(r.path, e.inputs, data_schema::read_recording);
    e.recordings.push_back(align_recording(e.manifest, r, rec, r.path.string()));
  }
  return e;
}

const std::string& Experiment::sha256_of(const std::filesystem::path& path) const {
  for (const auto& f : inputs)
    if (f.path == path.string()) return f.sha256;
  BURRBENCH_CHECK(false, "an experiment file that was not read: " + path.string());
  return inputs.front().sha256;  // not reached
}

void check_each_sample_used_once_per_role(const Experiment& e) {
  const auto& recs = e.recordings;
  for (std::size_t b = 0; b < recs.size(); ++b)
    for (std::size_t a = 0; a < b; ++a) {
      const AlignedRecording &ra = recs[a], &rb = recs[b];
      if (ra.file.empty() || rb.file.empty() || ra.t_s.size() != rb.t_s.size() ||
          !data_schema::same_file(ra.file, rb.file))
        continue;
      for (const bool cal : {true, false}) {
        const auto& ua = cal ? ra.use_calibrate : ra.use_validate;
        const auto& ub = cal ? rb.use_calibrate : rb.use_validate;
        std::size_t first = ua.size(), last = 0, n = 0;
        for (std::size_t k = 0; k < ua.size(); ++k)
          if (ua[k] && ub[k]) {
            first = std::min(first, k);
            last = k;
            ++n;
          }
        if (n == 0) continue;
        const char* role = cal ? "calibrate" : "validate";
        throw InputError(e.manifest.file.string(), fmt::format("recordings[{}] (\"{}\")", b, rb.id),
                         fmt::format("each sample of {} used to {} by one listing at most: recordings[{}] (\"{}\") "
                                     "already does (give the listings different roles, or split them with segments)",
                                     rb.file.string(), role, a, ra.id),
                         fmt::format("{} samples used to {} by both, t = {:.6g} … {:.6g} s", n, role,
                                     recs[b].t_s[first], recs[b].t_s[last]));
      }
    }
}

}  // namespace burrbench::model
