#pragma once
// A drilling session: one stream per device, events and metadata. Stored as HDF5
// (format "burrbench.recording"); docs/formats.md lists every field with unit and frame.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema {

inline constexpr const char* kRecordingFormat = "burrbench.recording";
inline constexpr int kRecordingVersionMajor = 1;
// 1.1: burr_axis_rig = [0, 0, 0] and spin_sign = 0 mean "not stated" (1.0 writers always
// wrote [0, 0, 1] and +1, whether the rig knew them or not: read as not stated).
inline constexpr int kRecordingVersionMinor = 1;

// Canonical channel names (decoded, in MODEL.md units).
inline constexpr const char* kForce = "force_N";        // n×3, sensor frame, force on sample
inline constexpr const char* kTorque = "torque_Nmm";    // n×3, sensor frame
inline constexpr const char* kPosition = "position_mm"; // n×3, rig frame, burr centre
inline constexpr const char* kSpindle = "spindle_rpm";  // n×1
// The spindle drive's load (MODEL.md "Moments"): the torque the cutting takes from the
// spindle, positive when it brakes the spin (N·mm), or the drive's power (W), which the
// replay converts through the speed: τ = 1000·P/|ω|.
inline constexpr const char* kSpindleTorque = "spindle_torque_Nmm";  // n×1
inline constexpr const char* kSpindlePower = "spindle_power_W";      // n×1

// The width and unit a canonical channel must have (a recording with another is refused,
// and so is a register map that would produce one).
struct CanonicalChannel {
  const char* name;
  std::size_t width;
  const char* unit;
};
inline constexpr CanonicalChannel kCanonicalChannels[] = {
    {kForce, 3, "N"},        {kTorque, 3, "N*mm"},         {kPosition, 3, "mm"},
    {kSpindle, 1, "rpm"},    {kSpindleTorque, 1, "N*mm"},  {kSpindlePower, 1, "W"}};

struct Channel {
  std::string name;            // canonical name or a device-specific one
  std::string unit;            // "N", "N*mm", "mm", "rpm", ...
  std::size_t width = 1;       // columns per sample (3 for vectors)
  std::vector<double> values;  // row-major, samples × width
  std::size_t samples() const { return width ? values.size() / width : 0; }
};

// One device's samples. All per-sample vectors have the same length n (counter and
// raw_registers may be empty when the device has none).
struct Stream {
  std::string name;                  // "ft_sensor", "stage", "spindle", ...
  std::vector<std::int64_t> t_ns;    // host monotonic timestamp = (send+recv)/2
  std::vector<std::int64_t> t_send_ns, t_recv_ns;  // request send / reply receive
  std::size_t registers_per_sample = 0;
  std::vector<std::uint16_t> raw_registers;        // n × registers_per_sample
  std::vector<std::int64_t> device_counter;        // device's own sample counter
  std::vector<std::uint8_t> stale;                 // 1 = value repeated, not fresh
  std::vector<Channel> channels;
  std::size_t samples() const { return t_ns.size(); }
  const Channel* channel(const std::string& name) const;
};

struct Event {
  std::int64_t t_ns = 0;  // host monotonic
  std::string kind;       // start, stop, tare, fault, reconnect, gap, duplicate, ...
  std::string stream;     // device stream, "" for the session
  std::string detail;
};

struct RecordingMeta {
  std::string sample_id, rig_id, operator_name;
  double burr_radius_mm = 0;
  // What the rig logged of its burr; 0 / zero vector = not stated. A stated value must
  // agree with the manifest's [burr] (model/experiment.cpp) unless the manifest waives it.
  glm::dvec3 burr_axis_rig{0, 0, 0};  // shaft direction, unit vector, rig frame
  int spin_sign = 0;                   // +1: ω along burr_axis_rig, -1: against
  bool axis_stated() const { return burr_axis_rig != glm::dvec3(0); }
  std::string sensor_model, sensor_serial;
  std::vector<double> sensor_calibration;  // 36 values (6×6 row-major) or empty
  std::string sensor_calibration_date;
  std::vector<double> bias;                // 6 values: Fx,Fy,Fz N, Tx,Ty,Tz N·mm; or empty
  std::int64_t bias_t_ns = 0;              // when the bias was taken (host monotonic)
  std::string register_map_toml;           // the map used, verbatim
  std::int64_t session_wall_ns = 0;        // wall clock (Unix ns) ...
  std::int64_t session_monotonic_ns = 0;   // ... paired with this monotonic instant
  std::string notes;
};

struct Recording {
  RecordingMeta meta;
  std::vector<Stream> streams;
  std::vector<Event> events;
  Provenance provenance;
  const Stream* stream(const std::string& name) const;
  // The stream holding a canonical channel, or nullptr.
  const Stream* stream_with(const std::string& channel) const;
};

// Throws InputError naming file and field on any defect (lengths, NaN/Inf, version...).
// Non-finite values: positions never; other channels may hold NaN (never ±Inf) only on
// rows flagged stale = 1 — consumers must skip stale rows. Timestamps non-decreasing.
// Memory budget: all streams together ≤ 4 GiB, checked from the file headers.
void validate(const Recording& rec, const std::string& file_for_messages);
void write_recording(const std::filesystem::path& path, const Recording& rec);
Recording read_recording(const std::filesystem::path& path);  // validates
// The same from an HDF5 file image in memory; `name` stands for the file in messages.
Recording read_recording_image(std::string_view image, const std::string& name);

}  // namespace burrbench::data_schema
