#include "burrbench/rig/register_map.hpp"

#include <cctype>
#include <algorithm>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace burrbench::rig {

int register_count(ValueType t) {
  return (t == ValueType::Int16 || t == ValueType::UInt16) ? 1 : 2;
}
const char* to_string(ValueType t) {
  switch (t) {
    case ValueType::Int16: return "int16";
    case ValueType::UInt16: return "uint16";
    case ValueType::Int32: return "int32";
    case ValueType::UInt32: return "uint32";
    case ValueType::Float32: return "float32";
  }
  BURRBENCH_UNREACHABLE();
}
const char* to_string(WordOrder o) {
  switch (o) {
    case WordOrder::ABCD: return "ABCD";
    case WordOrder::CDAB: return "CDAB";
    case WordOrder::BADC: return "BADC";
    case WordOrder::DCBA: return "DCBA";
  }
  BURRBENCH_UNREACHABLE();
}

namespace {

using data_schema::TomlView;

constexpr int kMaxReadRegisters = 125;  // Modbus limit for one read request

// Safety: refuse any key or value that mentions writing, anywhere in the document.
void refuse_writes(const toml::node& n, const std::string& path, const std::string& file) {
  const auto mentions_write = [](std::string s) {
    for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s.find("write") != std::string::npos;
  };
  const std::string expected = "no write request (acquisition is read-only; a rig moves a spinning burr)";
  if (const auto* t = n.as_table()) {
    for (const auto& [k, v] : *t) {
      const std::string sub = path.empty() ? std::string(k.str()) : path + "." + std::string(k.str());
      if (mentions_write(std::string(k.str()))) throw InputError(file, sub, expected, "a write key");
      refuse_writes(v, sub, file);
    }
  } else if (const auto* a = n.as_array()) {
    for (std::size_t i = 0; i < a->size(); ++i)
      refuse_writes(*a->get(i), fmt::format("{}[{}]", path, i), file);
  } else if (const auto* s = n.as_string()) {
    if (mentions_write(s->get())) throw InputError(file, path, expected, "\"" + s->get() + "\"");
  }
}

ValueType parse_type(const TomlView& r, std::string_view key, std::optional<std::string> def = {}) {
  const auto s = def ? r.str_or(key, *def) : r.str(key);
  if (s == "int16") return ValueType::Int16;
  if (s == "uint16") return ValueType::UInt16;
  if (s == "int32") return ValueType::Int32;
  if (s == "uint32") return ValueType::UInt32;
  if (s == "float32") return ValueType::Float32;
  r.fail(key, "int16, uint16, int32, uint32 or float32", "\"" + s + "\"");
}

WordOrder parse_order(const TomlView& r, std::string_view key) {
  const auto s = r.str_or(key, "ABCD");
  if (s == "ABCD") return WordOrder::ABCD;
  if (s == "CDAB") return WordOrder::CDAB;
  if (s == "BADC") return WordOrder::BADC;
  if (s == "DCBA") return WordOrder::DCBA;
  r.fail(key, "ABCD, CDAB, BADC or DCBA", "\"" + s + "\"");
}

Field parse_field(const TomlView& r, bool integer_only) {
  r.allow({"register", "type", "word_order"});
  Field f;
  f.address = static_cast<int>(r.integer("register", 0, 65535));
  f.type = parse_type(r, "type", std::string("uint32"));
  if (integer_only && f.type == ValueType::Float32) r.fail("type", "an integer type for a counter", "float32");
  f.order = parse_order(r, "word_order");
  return f;
}

ChannelSpec parse_channel(const TomlView& r) {
  r.allow({"name", "unit", "type", "word_order", "registers", "scale", "offset", "min", "max",
           "negate_if_register"});
  ChannelSpec c;
  c.name = r.str("name");
  if (c.name.empty()) r.fail("name", "a non-empty name", "\"\"");
  c.unit = r.str("unit");
  if (c.unit.empty()) r.fail("unit", "a unit (\"N\", \"N*mm\", \"mm\", \"rpm\", \"1\" for none, ...)", "\"\"");
  c.type = parse_type(r, "type");
  c.order = parse_order(r, "word_order");
  for (const auto a : r.integers("registers", 0, 65535, 64)) c.registers.push_back(static_cast<int>(a));
  // A number for every column, or an array with one per column (per-axis gain and zero).
  const auto per_column = [&](std::string_view key, double def) {
    const auto* n = r.node(key);
    if (n && n->is_array()) return r.numbers(key, c.registers.size());
    return std::vector<double>{r.num_or(key, def)};
  };
  c.scale = per_column("scale", 1.0);
  for (std::size_t k = 0; k < c.scale.size(); ++k)
    if (c.scale[k] == 0.0) r.fail(c.scale.size() > 1 ? fmt::format("scale[{}]", k) : "scale", "a non-zero number", "0");
  c.offset = per_column("offset", 0.0);
  if (r.has("min")) c.min = r.num("min");
  if (r.has("max")) c.max = r.num("max");
  if (c.min && c.max && *c.min > *c.max) r.fail("max", fmt::format("≥ min ({})", *c.min), fmt::format("{}", *c.max));
  if (r.has("negate_if_register")) c.negate_if_register = static_cast<int>(r.integer("negate_if_register", 0, 65535));
  return c;
}

// The registers [addr, addr + n) in the poll's buffer (BlockSpec): each must be read by a
// block, and consecutively (a field or FIFO region may run on into the next block only
// if that block starts where the previous one ends, with the same function).
int place(const TomlView& r, const std::string& what, int addr, int n, const std::vector<BlockSpec>& blocks) {
  const auto at = [&](int a) {
    int v = blocks.front().start;
    for (const auto& b : blocks) {
      if (a >= b.start && a < b.start + b.count) return v + (a - b.start);
      v += b.count;
    }
    return -1;
  };
  const int v0 = at(addr);
  std::string ranges;
  for (const auto& b : blocks) ranges += fmt::format("{}[{}, {})", ranges.empty() ? "" : " ", b.start, b.start + b.count);
  for (int i = 0; i < n; ++i)
    if (v0 < 0 || at(addr + i) != v0 + i)
      r.fail(what,
             blocks.size() == 1 ? fmt::format("registers inside {}", ranges)
                                : fmt::format("registers read consecutively by the device's blocks {}", ranges),
             fmt::format("[{}, {})", addr, addr + n));
  return v0;
}

void check_inside(const TomlView& r, const std::string& what, int addr, int n, int lo, int count) {
  if (addr < lo || addr + n > lo + count)
    r.fail(what, fmt::format("registers inside [{}, {})", lo, lo + count),
           fmt::format("[{}, {})", addr, addr + n));
}

// A canonical channel (force_N, ...) must decode to the width and unit a recording
// holds, or the session would be recorded in full and then refused when written.
void check_canonical(const TomlView& r, const ChannelSpec& c) {
  for (const auto& k : data_schema::kCanonicalChannels) {
    if (c.name != k.name) continue;
    if (c.registers.size() != k.width)
      r.fail("registers", fmt::format("{} start address(es) for {} (width {})", k.width, k.name, k.width),
             std::to_string(c.registers.size()));
    if (c.unit != k.unit)
      r.fail("unit", fmt::format("\"{}\" for {} (scale converts the device's unit)", k.unit, k.name),
             "\"" + c.unit + "\"");
  }
}

// No register is read into two channels, or twice into one: overlapping fields decode
// the same bits as two values, which is always a typo in the map.
void check_disjoint(const TomlView& r, const ChannelSpec& c, std::map<int, std::string>& owner) {
  const int n = register_count(c.type);
  for (std::size_t k = 0; k < c.registers.size(); ++k)
    for (int a = c.registers[k]; a < c.registers[k] + n; ++a) {
      const auto [it, fresh] = owner.emplace(a, fmt::format("{}.registers[{}]", c.name, k));
      if (!fresh)
        r.fail(fmt::format("registers[{}]", k), "registers no other channel field reads",
               fmt::format("register {} read by {} too", a, it->second));
    }
}

// parse_device's steps, in the order the checks are made (the first defect is the one
// reported): the name, the line (TCP host or RS-485 serial settings, unit), the timing
// (poll rate, timeouts, late replies, reconnects), the requests of one poll (blocks), the
// mode and its counter, the FIFO, the channels, the status word, the calibration.
void parse_name(const TomlView& r, DeviceSpec& d) {
  d.name = r.str("name");
  if (d.name.empty() || d.name.find_first_of("/. ") != std::string::npos)
    r.fail("name", "a non-empty name without '/', '.' or spaces", "\"" + d.name + "\"");
}

void parse_line(const TomlView& r, DeviceSpec& d) {
  const auto transport = r.str("transport");
  if (transport == "tcp") {
    d.transport = Transport::Tcp;
    d.host = r.str("host");
    d.port = static_cast<int>(r.integer_or("port", 1, 65535, 502));
    d.slave = static_cast<int>(r.integer_or("slave", 0, 255, 1));
    for (auto k : {"serial", "baud", "parity", "data_bits", "stop_bits"})
      if (r.has(k)) r.fail(k, "no serial settings on a tcp device", "present");
  } else if (transport == "rtu") {
    d.transport = Transport::Rtu;
    d.serial = r.str("serial");
    d.baud = static_cast<int>(r.integer_or("baud", 300, 4000000, 19200));
    const auto parity = r.str_or("parity", "N");
    if (parity != "N" && parity != "E" && parity != "O") r.fail("parity", "N, E or O", "\"" + parity + "\"");
    d.parity = parity[0];
    d.data_bits = static_cast<int>(r.integer_or("data_bits", 7, 8, 8));
    d.stop_bits = static_cast<int>(r.integer_or("stop_bits", 1, 2, 1));
    d.slave = static_cast<int>(r.integer("slave", 1, 247));
    for (auto k : {"host", "port"})
      if (r.has(k)) r.fail(k, "no network settings on an rtu device", "present");
  } else {
    r.fail("transport", "\"tcp\" or \"rtu\"", "\"" + transport + "\"");
  }
}

void parse_timing(const TomlView& r, DeviceSpec& d) {
  d.rate_hz = r.num("rate_hz");
  if (!(d.rate_hz >= 0.001 && d.rate_hz <= 100000)) r.fail("rate_hz", "a rate in [0.001, 100000] Hz", fmt::format("{}", d.rate_hz));
  d.timeout_ms = r.num_or("timeout_ms", 100.0);
  if (!(d.timeout_ms >= 1 && d.timeout_ms <= 10000)) r.fail("timeout_ms", "a timeout in [1, 10000] ms", fmt::format("{}", d.timeout_ms));
  // RTU has no transaction id: a reply that comes after we gave up would pass for the
  // answer to the next request, so after a timeout the bus is left quiet until then.
  d.late_reply_ms = r.num_or("late_reply_ms", 3 * d.timeout_ms);
  if (d.transport != Transport::Rtu && r.has("late_reply_ms")) r.fail("late_reply_ms", "no late_reply_ms on a tcp device", "present");
  if (!(d.late_reply_ms >= d.timeout_ms && d.late_reply_ms <= 60000))
    r.fail("late_reply_ms", fmt::format("a time in [timeout_ms = {}, 60000] ms", d.timeout_ms), fmt::format("{}", d.late_reply_ms));
  d.reconnect_backoff_ms = r.num_or("reconnect_backoff_ms", 20.0);
  d.reconnect_max_ms = r.num_or("reconnect_max_ms", std::max(1000.0, d.reconnect_backoff_ms));
  for (const char* k : {"reconnect_backoff_ms", "reconnect_max_ms"})
    if (d.transport != Transport::Tcp && r.has(k)) r.fail(k, "no reconnect settings on an rtu device (a bus is not reconnected)", "present");
  if (!(d.reconnect_backoff_ms >= 1 && d.reconnect_backoff_ms <= 60000))
    r.fail("reconnect_backoff_ms", "a wait in [1, 60000] ms", fmt::format("{}", d.reconnect_backoff_ms));
  if (!(d.reconnect_max_ms >= d.reconnect_backoff_ms && d.reconnect_max_ms <= 600000))
    r.fail("reconnect_max_ms", fmt::format("a wait in [reconnect_backoff_ms = {}, 600000] ms", d.reconnect_backoff_ms),
           fmt::format("{}", d.reconnect_max_ms));
}

void parse_blocks(const TomlView& r, DeviceSpec& d) {
  const auto parse_block = [](const TomlView& b) {
    BlockSpec k;
    const auto function = b.str_or("function", "holding");
    if (function == "holding") k.function = 3;
    else if (function == "input") k.function = 4;
    else b.fail("function", "\"holding\" or \"input\" (reads only)", "\"" + function + "\"");
    k.start = static_cast<int>(b.integer("start", 0, 65535));
    k.count = static_cast<int>(b.integer("count", 1, kMaxReadRegisters));
    if (k.start + k.count > 65536) b.fail("count", "a block ending at or before address 65535");
    return k;
  };
  if (r.has("blocks")) {
    // Several requests per poll (e.g. input and holding registers of one unit, or a FIFO
    // deeper than one request's 125 registers).
    for (const char* k : {"function", "start", "count"})
      if (r.has(k)) r.fail(k, "function, start and count inside blocks when blocks is given", "present");
    const auto bs = r.tables("blocks");
    if (bs.empty() || bs.size() > 32) r.fail("blocks", "1 to 32 blocks", std::to_string(bs.size()));
    for (const auto& b : bs) {
      b.allow({"function", "start", "count"});
      const BlockSpec k = parse_block(b);
      for (const auto& o : d.blocks)
        if (k.start < o.start + o.count && o.start < k.start + k.count)
          b.fail("start", "a block whose registers no other block of the device reads",
                 fmt::format("[{}, {}) overlapping [{}, {})", k.start, k.start + k.count, o.start, o.start + o.count));
      d.blocks.push_back(k);
    }
  } else {
    d.blocks.push_back(parse_block(r));
  }
  d.start = d.blocks.front().start;
  for (const auto& b : d.blocks) d.count += b.count;
}

void parse_mode_and_counter(const TomlView& r, DeviceSpec& d) {
  const auto mode = r.str_or("mode", "latest");
  if (mode == "latest") d.mode = Mode::Latest;
  else if (mode == "fifo") d.mode = Mode::Fifo;
  else r.fail("mode", "\"latest\" or \"fifo\"", "\"" + mode + "\"");

  if (r.has("counter")) {
    const TomlView cr = r.table("counter");
    d.counter = parse_field(cr, true);
    d.counter->address = place(cr, "register", d.counter->address, register_count(d.counter->type), d.blocks);
  }
}

void parse_fifo(const TomlView& r, DeviceSpec& d) {
  if (!r.has("fifo")) r.fail("fifo", "a fifo table for mode = \"fifo\"", "missing");
  if (d.counter) r.fail("counter", "no separate counter in fifo mode (fifo.counter is used)", "present");
  const TomlView fr = r.table("fifo");
  fr.allow({"counter", "first_register", "depth", "record_registers", "device_rate_hz", "record_counter"});
  FifoSpec f;
  const TomlView fcr = fr.table("counter");
  f.counter = parse_field(fcr, true);
  f.counter.address = place(fcr, "register", f.counter.address, register_count(f.counter.type), d.blocks);
  f.first_register = static_cast<int>(fr.integer("first_register", 0, 65535));
  f.depth = static_cast<int>(fr.integer("depth", 1, 32 * kMaxReadRegisters));
  f.record_registers = static_cast<int>(fr.integer("record_registers", 1, kMaxReadRegisters));
  f.device_rate_hz = fr.num("device_rate_hz");
  if (!(f.device_rate_hz > 0 && f.device_rate_hz <= 100000))
    fr.fail("device_rate_hz", "a rate in (0, 100000] Hz", fmt::format("{}", f.device_rate_hz));
  f.first_register = place(fr, "first_register", f.first_register, f.depth * f.record_registers, d.blocks);
  if (fr.has("record_counter")) {
    const TomlView rcr = fr.table("record_counter");
    f.record_counter = parse_field(rcr, true);
    check_inside(rcr, "register", f.record_counter->address, register_count(f.record_counter->type), 0,
                 f.record_registers);
    // One request returns one consistent image; a record split between two requests
    // could join two samples under one counter.
    int block_end = d.start;
    std::vector<int> ends;  // buffer offsets where a block ends
    for (const auto& b : d.blocks) ends.push_back(block_end += b.count);
    for (int slot = 0; slot < f.depth; ++slot) {
      const int lo = f.first_register + slot * f.record_registers, hi = lo + f.record_registers;
      for (const int e : ends)
        if (lo < e && e < hi)
          fr.fail("record_registers", "records that each lie inside one block (a record split between two requests "
                  "may join two samples)", fmt::format("record {} split at a block's end", slot));
    }
  } else if (d.blocks.size() > 1) {
    // Without record counters a window that moves between two requests of one poll
    // would shift the later blocks' records: taken twice, or as the wrong sample.
    fr.fail("record_counter", "each record's own counter when a FIFO device is read in several blocks", "missing");
  }
  // Polling must outpace the FIFO or records are lost by design.
  if (d.rate_hz * f.depth < f.device_rate_hz * 1.5)
    r.fail("rate_hz", fmt::format("≥ 1.5 × device_rate_hz / depth = {} Hz so the FIFO never overruns",
                                  1.5 * f.device_rate_hz / f.depth), fmt::format("{}", d.rate_hz));
  d.fifo = f;
}

// Where a field's registers lie: latest mode, addresses placed in the poll's buffer; FIFO
// mode, offsets inside one record.
int locate(const DeviceSpec& d, const TomlView& t, const std::string& what, int addr, int n) {
  if (d.mode != Mode::Fifo) return place(t, what, addr, n, d.blocks);
  check_inside(t, what, addr, n, 0, d.fifo->record_registers);
  return addr;
}

// Returns the channels' names.
std::set<std::string> parse_channels(const TomlView& r, DeviceSpec& d) {
  const auto chans = r.tables("channels");
  if (chans.empty()) r.fail("channels", "at least one channel", "none");
  std::set<std::string> names;
  std::map<int, std::string> owner;  // register → the channel that reads it
  for (const auto& cr : chans) {
    auto c = parse_channel(cr);
    if (!names.insert(c.name).second) cr.fail("name", "a name unique within the device", "\"" + c.name + "\"");
    check_canonical(cr, c);
    check_disjoint(cr, c, owner);  // on the map's own addresses
    for (std::size_t k = 0; k < c.registers.size(); ++k)
      c.registers[k] = locate(d, cr, fmt::format("registers[{}]", k), c.registers[k], register_count(c.type));
    if (c.negate_if_register) c.negate_if_register = locate(d, cr, "negate_if_register", *c.negate_if_register, 1);
    d.channels.push_back(std::move(c));
  }
  return names;
}

void parse_status(const TomlView& r, DeviceSpec& d) {
  if (r.has("status")) {
    const TomlView sr = r.table("status");
    sr.allow({"register", "type", "word_order", "invalid_mask"});
    StatusSpec st;
    st.field.address = static_cast<int>(sr.integer("register", 0, 65535));
    st.field.type = parse_type(sr, "type", std::string("uint16"));
    if (st.field.type == ValueType::Float32) sr.fail("type", "an integer type for a status word", "float32");
    st.field.order = parse_order(sr, "word_order");
    const auto bits = register_count(st.field.type) * 16;
    st.invalid_mask = static_cast<std::uint32_t>(
        sr.integer("invalid_mask", 1, bits == 16 ? 0xFFFF : 0xFFFFFFFFLL));
    st.field.address = locate(d, sr, "register", st.field.address, register_count(st.field.type));
    d.status = st;
  }
}

void parse_calibration(const TomlView& r, DeviceSpec& d, const std::set<std::string>& names) {
  if (r.has("calibration")) {
    const TomlView cr = r.table("calibration");
    cr.allow({"input", "matrix"});
    CalibrationSpec cal;
    cal.input = cr.str("input");
    const ChannelSpec* in = nullptr;
    for (const auto& c : d.channels)
      if (c.name == cal.input) in = &c;
    if (!in || in->registers.size() != 6) cr.fail("input", "the name of a 6-column channel of this device", "\"" + cal.input + "\"");
    for (const char* out : {"force_N", "torque_Nmm"})
      if (names.count(out)) cr.fail("input", fmt::format("no channel named {} beside a calibration (it is computed)", out), "present");
    const auto rows = cr.number_rows("matrix", 6, 6);
    std::copy(rows.begin(), rows.end(), cal.matrix.begin());
    d.calibration = cal;
  }
}

DeviceSpec parse_device(const TomlView& r) {
  r.allow({"name", "transport", "host", "port", "serial", "baud", "parity", "data_bits", "stop_bits",
           "slave", "rate_hz", "timeout_ms", "late_reply_ms", "reconnect_backoff_ms", "reconnect_max_ms", "mode", "function", "start", "count", "blocks", "counter", "fifo",
           "calibration", "channels", "status"});
  DeviceSpec d;
  parse_name(r, d);
  parse_line(r, d);
  parse_timing(r, d);
  parse_blocks(r, d);
  parse_mode_and_counter(r, d);
  if (d.mode == Mode::Fifo) parse_fifo(r, d);
  else if (r.has("fifo")) r.fail("fifo", "no fifo table unless mode = \"fifo\"", "present");
  const std::set<std::string> names = parse_channels(r, d);
  parse_status(r, d);
  parse_calibration(r, d, names);
  return d;
}

}  // namespace

namespace {
double rtu_byte_s(const DeviceSpec& d) {
  return (1 + d.data_bits + (d.parity == 'N' ? 0 : 1) + d.stop_bits) / static_cast<double>(d.baud);
}
}  // namespace

double rtu_frames_wire_s(const BlockSpec& b, const DeviceSpec& d) { return (8 + 5 + 2 * b.count) * rtu_byte_s(d); }

double rtu_frames_wire_s(const DeviceSpec& d) {
  double s = 0;
  for (const auto& b : d.blocks) s += rtu_frames_wire_s(b, d);
  return s;
}

double rtu_poll_wire_s(const DeviceSpec& d) {
  const double silence_s = d.baud > 19200 ? 1.75e-3 : 3.5 * rtu_byte_s(d);
  return rtu_frames_wire_s(d) + 2 * silence_s * static_cast<double>(d.blocks.size());
}

std::vector<BusBudget> rtu_bus_budgets(const std::vector<DeviceSpec>& devices) {
  std::vector<BusBudget> buses;
  for (const auto& d : devices) {
    if (d.transport != Transport::Rtu) continue;
    auto it = std::find_if(buses.begin(), buses.end(), [&](const BusBudget& b) { return b.serial == d.serial; });
    if (it == buses.end()) it = buses.insert(buses.end(), BusBudget{d.serial, d.baud, {}, {}, 0});
    const double t = rtu_poll_wire_s(d);
    it->devices.push_back(d.name);
    it->poll_wire_ms.push_back(t * 1e3);
    it->load += d.rate_hz * t;
  }
  return buses;
}

RigMap parse_rig_map(std::string_view text, const std::string& file) {
  const toml::table root = data_schema::parse_toml_text(text, file);
  refuse_writes(root, "", file);
  const TomlView r(root, file, "", "docs/rig.md");
  r.allow({"format", "format_version", "rig_id", "sensor_model", "sensor_serial",
           "sensor_calibration_date", "devices"});
  data_schema::check_format(file, "format", r.str("format"), "burrbench.rig");
  data_schema::check_version(file, "format_version", r.str("format_version"), 1);
  RigMap m;
  m.file = file;
  m.source_toml = std::string(text);
  m.rig_id = r.str_or("rig_id", "");
  m.sensor_model = r.str_or("sensor_model", "");
  m.sensor_serial = r.str_or("sensor_serial", "");
  m.sensor_calibration_date = r.str_or("sensor_calibration_date", "");
  const auto devs = r.tables("devices");
  if (devs.empty() || devs.size() > 64) r.fail("devices", "1 to 64 devices", std::to_string(devs.size()));
  std::set<std::string> names;
  for (std::size_t i = 0; i < devs.size(); ++i) {
    const std::string& path = devs[i].path();
    auto d = parse_device(devs[i]);
    if (!names.insert(d.name).second) throw InputError(file, path + ".name", "a unique device name", "\"" + d.name + "\"");
    // Devices on one RS-485 bus share its line settings.
    for (const auto& o : m.devices) {
      if (d.transport == Transport::Rtu && o.transport == Transport::Rtu && o.serial == d.serial &&
          (o.baud != d.baud || o.parity != d.parity || o.data_bits != d.data_bits || o.stop_bits != d.stop_bits))
        throw InputError(file, path + ".baud", fmt::format("the line settings of device {} on the same bus {}", o.name, d.serial));
    }
    m.devices.push_back(std::move(d));
  }
  // A bus carries one request at a time: rates it cannot carry would lose polls all
  // session long, so they are refused here, before anything connects.
  for (const auto& b : rtu_bus_budgets(m.devices)) {
    if (b.load <= kMaxBusLoad) continue;
    std::size_t last = 0;
    for (std::size_t i = 0; i < m.devices.size(); ++i)
      if (m.devices[i].name == b.devices.back()) last = i;
    std::string polls;
    for (std::size_t k = 0; k < b.devices.size(); ++k)
      polls += fmt::format("{}{} {:.1f} ms", k ? ", " : "", b.devices[k], b.poll_wire_ms[k]);
    throw InputError(file, devs[last].path() + ".rate_hz",
                     fmt::format("rates the bus {} carries at {} baud (≤ {:.0f} % busy; one poll on the wire: {})",
                                 b.serial, b.baud, kMaxBusLoad * 100, polls),
                     fmt::format("{:.0f} % busy", b.load * 100));
  }
  return m;
}

RigMap load_rig_map(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "(file)", "a readable register map (TOML)", "cannot open");
  in.seekg(0, std::ios::end);
  const auto size = in.tellg();
  if (size < 0 || size > (1 << 20)) throw InputError(path.string(), "(file)", "a register map under 1 MiB");
  in.seekg(0);
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_rig_map(ss.str(), path.string());
}

}  // namespace burrbench::rig
