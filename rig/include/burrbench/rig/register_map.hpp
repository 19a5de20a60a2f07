#pragma once
// A rig's register map (TOML, docs/rig.md): which devices to poll, how, and how their
// registers decode into named channels. Acquisition is read-only: a map that asks for
// any write is refused.
#include <array>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace burrbench::rig {

enum class ValueType { Int16, UInt16, Int32, UInt32, Float32 };
enum class WordOrder { ABCD, CDAB, BADC, DCBA };
enum class Transport { Tcp, Rtu };
enum class Mode { Latest, Fifo };
// Latest mode with a counter: a device still answering whose counter has not advanced for
// this long has stopped measuring (stalled, or its acquisition stopped). Longer than any
// device's own update period: a sensor updating at 100 Hz polled at 1 kHz repeats itself
// for 10 ms. `acquire` warns while it lasts; the recording gets a `frozen` event.
inline constexpr double kFrozenAfterS = 0.5;

int register_count(ValueType t);  // 1 or 2
const char* to_string(ValueType t);
const char* to_string(WordOrder o);

// One value in registers: where (absolute address, or offset in a FIFO record) and how.
struct Field {
  int address = 0;
  ValueType type = ValueType::UInt16;
  WordOrder order = WordOrder::ABCD;
};

struct ChannelSpec {
  std::string name;                // canonical (force_N, torque_Nmm, position_mm, spindle_rpm) or own
  std::string unit;
  ValueType type = ValueType::Int16;
  WordOrder order = WordOrder::ABCD;
  std::vector<int> registers;      // one start address per column
  // value = raw * scale + offset, per column (one entry: the same for every column), so
  // each axis of a sensor can carry its own gain and zero.
  std::vector<double> scale{1.0}, offset{0.0};
  std::optional<double> min, max;    // decoded values outside → sample flagged invalid
  std::optional<int> negate_if_register;  // register (≠ 0 → value negated), e.g. spindle direction
};

struct FifoSpec {
  Field counter;               // counter of the newest record
  int first_register = 0;      // oldest record's first register
  int depth = 0;               // records exposed
  int record_registers = 0;    // registers per record
  double device_rate_hz = 0;   // the device's own sample rate
  // Each record's own counter (offset in the record), when the device stores one: records
  // are then taken by their counters, not by their slots, which a FIFO read in several
  // blocks needs (the window may move between two requests of one poll).
  std::optional<Field> record_counter;
};

// A device's status word: a sample whose status has any of invalid_mask's bits set is
// flagged invalid (e.g. a sensor's saturation or overload bit).
struct StatusSpec {
  Field field;                  // latest mode: inside the block; fifo mode: offset in a record
  std::uint32_t invalid_mask = 0;
};

struct CalibrationSpec {
  std::string input;               // a 6-column raw channel (e.g. strain gauges)
  std::array<double, 36> matrix{};  // row-major; rows 0-2 → force_N, 3-5 → torque_Nmm
};

// One read request of a poll: a function code and a register range.
struct BlockSpec {
  int function = 3;   // 3 = holding, 4 = input registers
  int start = 0, count = 0;
};

struct DeviceSpec {
  std::string name;                // stream name in the recording
  Transport transport = Transport::Tcp;
  std::string host;                // TCP
  int port = 502;
  std::string serial;              // RTU: device path; devices on one path share a bus thread
  int baud = 19200;
  char parity = 'N';
  int data_bits = 8, stop_bits = 1;
  int slave = 1;
  double rate_hz = 100;            // polls per second
  double timeout_ms = 100;         // reply timeout
  double late_reply_ms = 300;      // RTU: latest a reply may still come (after the request)
  // TCP: a lost connection is retried at once; while the device refuses, again after
  // reconnect_backoff_ms, doubling up to reconnect_max_ms.
  double reconnect_backoff_ms = 20, reconnect_max_ms = 1000;
  Mode mode = Mode::Latest;
  // The blocks read per poll, one request each, in this order, one time base (the first
  // request's send, the last reply). Their registers are laid end to end in one buffer:
  // block k's register a sits at start + Σ_{j<k} count_j + (a − blocks[k].start), so a
  // map's addresses are stored translated to that buffer (identical with one block).
  std::vector<BlockSpec> blocks;
  int start = 0, count = 0;        // blocks[0].start; Σ counts (registers per poll)
  std::vector<ChannelSpec> channels;
  std::optional<Field> counter;    // latest mode: device sample counter
  std::optional<FifoSpec> fifo;    // fifo mode
  std::optional<CalibrationSpec> calibration;
  std::optional<StatusSpec> status;
  // Registers stored per sample: the block (latest) or one FIFO record.
  int sample_registers() const { return mode == Mode::Fifo ? fifo->record_registers : count; }
};

struct RigMap {
  std::string file;                // for messages
  std::string rig_id, sensor_model, sensor_serial, sensor_calibration_date;
  std::vector<DeviceSpec> devices;
  std::string source_toml;         // verbatim text
};

// An RS-485 bus's wire budget: one request at a time, so the devices' polls must fit.
struct BusBudget {
  std::string serial;
  int baud = 0;
  std::vector<std::string> devices;
  std::vector<double> poll_wire_ms;  // per device: request + reply frames and their silences
  double load = 0;                   // Σ rate_hz × poll wire time (1 = the bus never idle)
};
inline constexpr double kMaxBusLoad = 0.9;  // headroom for the devices' own turnaround
// Wire time of one poll of d on its bus: request (8 bytes) and reply (5 + 2·count bytes)
// at 1 start + data + parity + stop bits per byte, plus the 3.5-character silence after
// each frame (fixed 1.75 ms above 19200 baud, Modbus over serial line §2.5.1.1).
double rtu_poll_wire_s(const DeviceSpec& d);
// The request and reply frames alone (no silences): the fastest a reply can come.
double rtu_frames_wire_s(const DeviceSpec& d);                       // all blocks
double rtu_frames_wire_s(const BlockSpec& b, const DeviceSpec& d);  // one request
std::vector<BusBudget> rtu_bus_budgets(const std::vector<DeviceSpec>& devices);

// Throws InputError (file, field, expected, got) on any defect, unknown key or write request.
// An RTU bus whose polls would not fit its baud rate (load > kMaxBusLoad) is a defect.
RigMap parse_rig_map(std::string_view toml_text, const std::string& file_for_messages);
RigMap load_rig_map(const std::filesystem::path& path);

}  // namespace burrbench::rig
