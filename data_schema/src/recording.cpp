// Recording: validator, HDF5 writer and reader. Layout (docs/formats.md):
//   /@format, /@format_version, /provenance, /meta (attributes + datasets),
//   /streams/<name>/{t_ns, t_send_ns, t_recv_ns, raw_registers, device_counter, stale,
//   channels/<channel>@unit}, /events/{t_ns, kind, stream, detail}.
#include "burrbench/data_schema/recording.hpp"

#include <algorithm>
#include <cmath>
#include <set>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "format_common.hpp"
#include "hdf5/h5.hpp"
#include "hdf5/h5_common.hpp"

namespace burrbench::data_schema {

namespace {

// Largest per-dataset element count we read; all streams together are further bounded
// by the 4 GiB recording budget, checked from the headers in read_recording.
constexpr std::uint64_t kMaxElements = 1ull << 31;
constexpr std::uint64_t kMaxRecordingBytes = 4ull << 30;
constexpr std::uint64_t kMaxEvents = 1ull << 24;
constexpr std::uint64_t kMaxTextBytes = 16ull << 20;

bool valid_name(const std::string& n) {
  return !n.empty() && n != "." && n != ".." && n.find('/') == std::string::npos;
}

void validate_stream(const Stream& s, const std::string& file) {
  const std::string base = "/streams/" + s.name;
  if (!valid_name(s.name)) throw InputError(file, "/streams/" + s.name, "a stream name without '/'");
  const std::size_t n = s.samples();
  auto same_len = [&](std::size_t len, const char* what, bool may_be_empty) {
    if (len == n || (may_be_empty && len == 0)) return;
    throw InputError(file, base + "/" + what,
                     fmt::format("{} values (one per t_ns sample){}", n, may_be_empty ? " or none" : ""),
                     std::to_string(len));
  };
  same_len(s.t_send_ns.size(), "t_send_ns", true);
  same_len(s.t_recv_ns.size(), "t_recv_ns", true);
  same_len(s.device_counter.size(), "device_counter", true);
  same_len(s.stale.size(), "stale", true);
  if (s.raw_registers.size() != n * s.registers_per_sample &&
      !(s.raw_registers.empty() && s.registers_per_sample == 0))
    throw InputError(file, base + "/raw_registers",
                     fmt::format("{}×{} registers", n, s.registers_per_sample),
                     std::to_string(s.raw_registers.size()) + " values");
  for (std::size_t i = 1; i < n; ++i)
    if (s.t_ns[i] < s.t_ns[i - 1])
      throw InputError(file, fmt::format("{}/t_ns[{}]", base, i), "non-decreasing timestamps",
                       fmt::format("{} after {}", s.t_ns[i], s.t_ns[i - 1]));
  if (!s.t_send_ns.empty() && !s.t_recv_ns.empty())
    for (std::size_t i = 0; i < n; ++i)
      if (s.t_send_ns[i] > s.t_recv_ns[i])
        throw InputError(file, fmt::format("{}/t_recv_ns[{}]", base, i), "t_recv_ns >= t_send_ns",
                         fmt::format("{} < {}", s.t_recv_ns[i], s.t_send_ns[i]));
  for (std::size_t i = 0; i < s.stale.size(); ++i)
    if (s.stale[i] > 1)
      throw InputError(file, fmt::format("{}/stale[{}]", base, i), "0 or 1", std::to_string(s.stale[i]));
  std::set<std::string> names;
  for (const auto& c : s.channels) {
    const std::string cb = base + "/channels/" + c.name;
    if (!valid_name(c.name)) throw InputError(file, cb, "a channel name without '/'");
    if (!names.insert(c.name).second) throw InputError(file, cb, "unique channel names", "duplicate");
    if (c.width == 0) throw InputError(file, cb, "width >= 1", "0");
    if (c.unit.empty()) throw InputError(file, cb + "/@unit", "a unit", "empty");
    if (c.values.size() != n * c.width)
      throw InputError(file, cb, fmt::format("{}×{} values", n, c.width), std::to_string(c.values.size()));
    for (const auto& k : kCanonicalChannels)
      if (c.name == k.name && (c.width != k.width || c.unit != k.unit))
        throw InputError(file, cb, fmt::format("width {} and unit \"{}\"", k.width, k.unit),
                         fmt::format("width {} and unit \"{}\"", c.width, c.unit));
    // NaN marks "no fresh value" and is allowed only on rows flagged stale; Inf never;
    // positions must always be finite (the replay follows them).
    const bool position = c.name == kPosition;
    for (std::size_t i = 0; i < c.values.size(); ++i) {
      const double v = c.values[i];
      if (std::isfinite(v)) continue;
      const std::size_t row = i / c.width;
      const bool stale = !s.stale.empty() && s.stale[row] == 1;
      if (std::isnan(v) && stale && !position) continue;
      throw InputError(file, fmt::format("{}[{}][{}]", cb, row, i % c.width),
                       position ? "a finite position"
                                : "a finite value (NaN only on rows flagged stale)",
                       fmt::format("{}", v));
    }
  }
}

}  // namespace

const Channel* Stream::channel(const std::string& n) const {
  for (const auto& c : channels)
    if (c.name == n) return &c;
  return nullptr;
}

const Stream* Recording::stream(const std::string& n) const {
  for (const auto& s : streams)
    if (s.name == n) return &s;
  return nullptr;
}

const Stream* Recording::stream_with(const std::string& ch) const {
  for (const auto& s : streams)
    if (s.channel(ch)) return &s;
  return nullptr;
}

void validate(const Recording& rec, const std::string& file) {
  const auto& m = rec.meta;
  if (!std::isfinite(m.burr_radius_mm) || m.burr_radius_mm < 0)
    throw InputError(file, "/meta/@burr_radius_mm", "a finite radius >= 0 (0 = unknown)",
                     fmt::format("{}", m.burr_radius_mm));
  const double len = std::sqrt(glm::dot(m.burr_axis_rig, m.burr_axis_rig));
  if (!std::isfinite(len) || (len != 0 && std::abs(len - 1.0) > 1e-6))
    throw InputError(file, "/meta/@burr_axis_rig", "a unit vector, or [0, 0, 0] (not stated)",
                     fmt::format("length {}", len));
  if (m.spin_sign < -1 || m.spin_sign > 1)
    throw InputError(file, "/meta/@spin_sign", "+1, -1, or 0 (not stated)", std::to_string(m.spin_sign));
  if (!m.sensor_calibration.empty() && m.sensor_calibration.size() != 36)
    throw InputError(file, "/meta/sensor_calibration", "36 values (6×6) or none",
                     std::to_string(m.sensor_calibration.size()));
  for (double v : m.sensor_calibration)
    if (!std::isfinite(v)) throw InputError(file, "/meta/sensor_calibration", "finite values", "NaN/Inf");
  if (!m.bias.empty() && m.bias.size() != 6)
    throw InputError(file, "/meta/bias", "6 values (Fx,Fy,Fz N, Tx,Ty,Tz N·mm) or none",
                     std::to_string(m.bias.size()));
  for (double v : m.bias)
    if (!std::isfinite(v)) throw InputError(file, "/meta/bias", "finite values", "NaN/Inf");
  std::set<std::string> names;
  for (const auto& s : rec.streams) {
    if (!names.insert(s.name).second)
      throw InputError(file, "/streams/" + s.name, "unique stream names", "duplicate");
    validate_stream(s, file);
  }
  for (std::size_t i = 0; i < rec.events.size(); ++i) {
    const auto& e = rec.events[i];
    if (e.kind.empty()) throw InputError(file, fmt::format("/events/kind[{}]", i), "a non-empty kind");
    if (!e.stream.empty() && !names.count(e.stream))
      throw InputError(file, fmt::format("/events/stream[{}]", i), "\"\" or the name of a stream",
                       "\"" + e.stream + "\"");
  }
}

void write_recording(const std::filesystem::path& path, const Recording& rec) {
  validate(rec, path.string());
  h5::Writer w(path);
  h5::write_header(w, kRecordingFormat, kRecordingVersionMajor, kRecordingVersionMinor, rec.provenance);
  const auto& m = rec.meta;
  w.group("/meta");
  w.attr("/meta", "sample_id", m.sample_id);
  w.attr("/meta", "rig_id", m.rig_id);
  w.attr("/meta", "operator", m.operator_name);
  w.attr("/meta", "burr_radius_mm", m.burr_radius_mm);
  w.attr("/meta", "burr_axis_rig", std::vector<double>{m.burr_axis_rig.x, m.burr_axis_rig.y, m.burr_axis_rig.z});
  w.attr("/meta", "spin_sign", std::int64_t{m.spin_sign});
  w.attr("/meta", "sensor_model", m.sensor_model);
  w.attr("/meta", "sensor_serial", m.sensor_serial);
  w.attr("/meta", "sensor_calibration_date", m.sensor_calibration_date);
  w.attr("/meta", "bias_t_ns", m.bias_t_ns);
  w.attr("/meta", "session_wall_ns", m.session_wall_ns);
  w.attr("/meta", "session_monotonic_ns", m.session_monotonic_ns);
  w.attr("/meta", "notes", m.notes);
  if (!m.sensor_calibration.empty()) w.dataset("/meta/sensor_calibration", {6, 6}, m.sensor_calibration.data());
  if (!m.bias.empty()) w.dataset("/meta/bias", {6}, m.bias.data());
  w.string("/meta/register_map_toml", m.register_map_toml);

  w.group("/streams");
  for (const auto& s : rec.streams) {
    const std::string b = "/streams/" + s.name;
    const hsize_t n = s.samples();
    w.group(b);
    w.dataset(b + "/t_ns", {n}, s.t_ns.data(), true);
    if (!s.t_send_ns.empty()) w.dataset(b + "/t_send_ns", {n}, s.t_send_ns.data(), true);
    if (!s.t_recv_ns.empty()) w.dataset(b + "/t_recv_ns", {n}, s.t_recv_ns.data(), true);
    if (s.registers_per_sample > 0)
      w.dataset(b + "/raw_registers", {n, hsize_t(s.registers_per_sample)}, s.raw_registers.data(), true);
    if (!s.device_counter.empty()) w.dataset(b + "/device_counter", {n}, s.device_counter.data(), true);
    if (!s.stale.empty()) w.dataset(b + "/stale", {n}, s.stale.data(), true);
    w.group(b + "/channels");
    for (const auto& c : s.channels) {
      const std::string cp = b + "/channels/" + c.name;
      // Width 1 is stored 1-D ([n]) so h5py/MATLAB users get a plain vector.
      if (c.width == 1)
        w.dataset(cp, {n}, c.values.data(), true);
      else
        w.dataset(cp, {n, hsize_t(c.width)}, c.values.data(), true);
      w.attr(cp, "unit", c.unit);
    }
  }
  w.group("/events");
  std::vector<std::int64_t> et;
  std::vector<std::string> kind, stream, detail;
  for (const auto& e : rec.events) {
    et.push_back(e.t_ns);
    kind.push_back(e.kind);
    stream.push_back(e.stream);
    detail.push_back(e.detail);
  }
  w.dataset("/events/t_ns", {hsize_t(et.size())}, et.data());
  w.strings("/events/kind", kind);
  w.strings("/events/stream", stream);
  w.strings("/events/detail", detail);
  w.commit();
}

namespace {

std::vector<std::int64_t> read_i64(const h5::Reader& r, const std::string& p) {
  std::vector<hsize_t> shape;
  auto v = r.read<std::int64_t>(p, h5::Elem::kInt64, &shape, kMaxElements);
  if (shape.size() != 1) throw InputError(r.file(), p, "a 1-D int64 dataset", fmt::format("rank {}", shape.size()));
  return v;
}

Stream read_stream(const h5::Reader& r, const std::string& name) {
  Stream s;
  s.name = name;
  const std::string b = "/streams/" + name;
  r.expect_only(b, {"t_ns", "t_send_ns", "t_recv_ns", "raw_registers", "device_counter", "stale", "channels"});
  s.t_ns = read_i64(r, b + "/t_ns");
  const std::size_t n = s.t_ns.size();
  auto opt_i64 = [&](const char* what, std::vector<std::int64_t>& out) {
    const std::string p = b + "/" + what;
    if (!r.exists(p)) return;
    out = read_i64(r, p);
    if (out.size() != n)
      throw InputError(r.file(), p, fmt::format("int64 dataset of length {}", n), std::to_string(out.size()));
  };
  opt_i64("t_send_ns", s.t_send_ns);
  opt_i64("t_recv_ns", s.t_recv_ns);
  opt_i64("device_counter", s.device_counter);
  if (r.exists(b + "/stale")) {
    std::vector<hsize_t> shape;
    s.stale = r.read<std::uint8_t>(b + "/stale", h5::Elem::kUInt8, &shape, kMaxElements);
    if (shape.size() != 1 || s.stale.size() != n)
      throw InputError(r.file(), b + "/stale", fmt::format("uint8 dataset of length {}", n),
                       std::to_string(s.stale.size()));
  }
  if (r.exists(b + "/raw_registers")) {
    std::vector<hsize_t> shape;
    s.raw_registers = r.read<std::uint16_t>(b + "/raw_registers", h5::Elem::kUInt16, &shape, kMaxElements);
    if (shape.size() != 2 || shape[0] != n || shape[1] == 0)
      throw InputError(r.file(), b + "/raw_registers", fmt::format("uint16 dataset of shape [{}×k], k >= 1", n),
                       fmt::format("rank {}", shape.size()));
    s.registers_per_sample = shape[1];
  }
  if (r.exists(b + "/channels")) {
    for (const auto& cn : r.members(b + "/channels")) {
      const std::string cp = b + "/channels/" + cn;
      Channel c;
      c.name = cn;
      std::vector<hsize_t> shape;
      c.values = r.read<double>(cp, h5::Elem::kFloat64, &shape, kMaxElements);
      if (shape.empty() || shape.size() > 2 || shape[0] != n || (shape.size() == 2 && shape[1] == 0))
        throw InputError(r.file(), cp, fmt::format("float64 dataset of shape [{}] or [{}×k]", n, n),
                         shape.empty() ? "scalar" : fmt::format("rank {}, {} rows", shape.size(), shape[0]));
      c.width = shape.size() == 2 ? shape[1] : 1;
      c.unit = r.attr_string(cp, "unit");
      s.channels.push_back(std::move(c));
    }
  }
  return s;
}

}  // namespace

namespace {
Recording read_recording_from(const h5::Reader& r);
}  // namespace

Recording read_recording(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  return read_recording_from(h5::Reader(path));
}

Recording read_recording_image(std::string_view image, const std::string& name) {
  const ReadingFile reading(name);
  return read_recording_from(h5::Reader(image, name));
}

namespace {
Recording read_recording_from(const h5::Reader& r) {
  const std::string file = r.file();
  const std::string version = h5::check_header(r, kRecordingFormat, kRecordingVersionMajor);
  r.expect_only("/", {"provenance", "meta", "streams", "events"});
  Recording rec;
  rec.provenance = h5::read_provenance(r);

  r.expect_only("/meta", {"sensor_calibration", "bias", "register_map_toml"});
  auto& m = rec.meta;
  m.sample_id = r.attr_string("/meta", "sample_id");
  m.rig_id = r.attr_string("/meta", "rig_id");
  m.operator_name = r.attr_string("/meta", "operator");
  m.burr_radius_mm = r.attr_double("/meta", "burr_radius_mm");
  const auto axis = r.attr_doubles("/meta", "burr_axis_rig", 3);
  m.burr_axis_rig = {axis[0], axis[1], axis[2]};
  const std::int64_t spin = r.attr_int64("/meta", "spin_sign");
  if (spin < -1 || spin > 1) throw InputError(file, "/meta/@spin_sign", "+1, -1, or 0 (not stated)", std::to_string(spin));
  m.spin_sign = int(spin);
  if (version == "1.0") {
    m.burr_axis_rig = glm::dvec3(0);  // 1.0 wrote [0, 0, 1] and +1 by default: not stated
    m.spin_sign = 0;
  }
  m.sensor_model = r.attr_string("/meta", "sensor_model");
  m.sensor_serial = r.attr_string("/meta", "sensor_serial");
  m.sensor_calibration_date = r.attr_string("/meta", "sensor_calibration_date");
  m.bias_t_ns = r.attr_int64("/meta", "bias_t_ns");
  m.session_wall_ns = r.attr_int64("/meta", "session_wall_ns");
  m.session_monotonic_ns = r.attr_int64("/meta", "session_monotonic_ns");
  m.notes = r.attr_string("/meta", "notes");
  if (r.exists("/meta/sensor_calibration")) {
    std::vector<hsize_t> shape;
    m.sensor_calibration = r.read<double>("/meta/sensor_calibration", h5::Elem::kFloat64, &shape, 36);
    if (shape != std::vector<hsize_t>{6, 6})
      throw InputError(file, "/meta/sensor_calibration", "a 6×6 float64 dataset");
  }
  if (r.exists("/meta/bias")) {
    std::vector<hsize_t> shape;
    m.bias = r.read<double>("/meta/bias", h5::Elem::kFloat64, &shape, 6);
    if (shape != std::vector<hsize_t>{6}) throw InputError(file, "/meta/bias", "a float64 dataset of length 6");
  }
  m.register_map_toml = r.read_string("/meta/register_map_toml", kMaxTextBytes);

  // Budget from the dataset headers before reading: every stream's sample count times
  // the bytes a sample may take (4 int64 timestamps/counters + stale + channels + registers).
  std::uint64_t total_bytes = 0;
  for (const auto& name : r.members("/streams")) {
    const std::string b = "/streams/" + name;
    const auto shape = r.shape(b + "/t_ns", h5::Elem::kInt64);
    if (shape.size() != 1) throw InputError(file, b + "/t_ns", "a 1-D int64 dataset", fmt::format("rank {}", shape.size()));
    std::uint64_t per_sample = 4 * 8 + 1;
    if (r.exists(b + "/raw_registers")) {
      const auto rs = r.shape(b + "/raw_registers", h5::Elem::kUInt16);
      if (rs.size() == 2) per_sample += 2 * std::min<std::uint64_t>(rs[1], kMaxElements);
    }
    if (r.exists(b + "/channels"))
      for (const auto& c : r.members(b + "/channels")) {
        const auto cs = r.shape(b + "/channels/" + c, h5::Elem::kFloat64);
        per_sample += 8 * (cs.size() == 2 ? std::min<std::uint64_t>(cs[1], kMaxElements) : 1);
      }
    const std::uint64_t n = std::min<std::uint64_t>(shape[0], kMaxElements);
    // per_sample can reach ~2^33: compare by division so the product cannot wrap.
    if (per_sample > kMaxRecordingBytes || n > (kMaxRecordingBytes - total_bytes) / per_sample)
      total_bytes = kMaxRecordingBytes + 1;
    else
      total_bytes += n * per_sample;
    if (total_bytes > kMaxRecordingBytes)
      throw InputError(file, b, "a recording within the 4 GiB memory budget",
                       fmt::format("{} samples of {} bytes", shape[0], per_sample));
    rec.streams.push_back(read_stream(r, name));
  }

  r.expect_only("/events", {"t_ns", "kind", "stream", "detail"});
  std::vector<hsize_t> shape;
  const auto et = r.read<std::int64_t>("/events/t_ns", h5::Elem::kInt64, &shape, kMaxEvents);
  if (shape.size() != 1) throw InputError(file, "/events/t_ns", "a 1-D int64 dataset");
  const auto kind = r.read_strings("/events/kind", kMaxEvents);
  const auto stream = r.read_strings("/events/stream", kMaxEvents);
  const auto detail = r.read_strings("/events/detail", kMaxEvents);
  for (const auto* v : {&kind, &stream, &detail})
    if (v->size() != et.size())
      throw InputError(file, "/events", fmt::format("t_ns, kind, stream, detail of equal length {}", et.size()),
                       std::to_string(v->size()));
  for (std::size_t i = 0; i < et.size(); ++i) rec.events.push_back({et[i], kind[i], stream[i], detail[i]});

  validate(rec, file);
  return rec;
}
}  // namespace

}  // namespace burrbench::data_schema
