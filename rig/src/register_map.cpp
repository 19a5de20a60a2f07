#include "burrbench/rig/register_map.hpp"

#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/toml_input.hpp"

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
  return "?";
}
const char* to_string(WordOrder o) {
  switch (o) {
    case WordOrder::ABCD: return "ABCD";
    case WordOrder::CDAB: return "CDAB";
    case WordOrder::BADC: return "BADC";
    case WordOrder::DCBA: return "DCBA";
  }
  return "?";
}

namespace {

constexpr int kMaxReadRegisters = 125;  // Modbus limit for one read request

// Reads one table with a known key set; every error names file and dotted field.
class Reader {
 public:
  Reader(const toml::table& t, std::string path, const std::string& file)
      : t_(t), path_(std::move(path)), file_(file) {}

  std::string field(std::string_view key) const {
    return path_.empty() ? std::string(key) : fmt::format("{}.{}", path_, key);
  }
  [[noreturn]] void fail(std::string_view key, const std::string& expected,
                         const std::string& got = {}) const {
    throw InputError(file_, field(key), expected, got);
  }
  void allow(std::initializer_list<std::string_view> keys) const {
    const std::set<std::string_view> ok(keys);
    for (const auto& [k, v] : t_) {
      if (!ok.count(k.str())) fail(k.str(), "a known key (see docs/rig.md)", "unknown key");
    }
  }
  bool has(std::string_view key) const { return t_.contains(key); }
  const toml::node* node(std::string_view key) const { return t_.get(key); }

  std::string str(std::string_view key, std::optional<std::string> def = {}) const {
    const auto* n = t_.get(key);
    if (!n) {
      if (def) return *def;
      fail(key, "a string", "missing");
    }
    if (auto s = n->value<std::string>(); s && n->is_string()) return *s;
    fail(key, "a string", std::string(toml::impl::node_type_friendly_names[static_cast<int>(n->type())]));
  }
  double num(std::string_view key, std::optional<double> def = {}) const {
    const auto* n = t_.get(key);
    if (!n) {
      if (def) return *def;
      fail(key, "a number", "missing");
    }
    if (n->is_integer()) return static_cast<double>(*n->value<std::int64_t>());
    if (n->is_floating_point()) {
      const double v = *n->value<double>();
      if (!std::isfinite(v)) fail(key, "a finite number", fmt::format("{}", v));
      return v;
    }
    fail(key, "a number");
  }
  int integer(std::string_view key, std::int64_t lo, std::int64_t hi,
              std::optional<int> def = {}) const {
    const auto* n = t_.get(key);
    if (!n) {
      if (def) return *def;
      fail(key, fmt::format("an integer in [{}, {}]", lo, hi), "missing");
    }
    if (!n->is_integer()) fail(key, fmt::format("an integer in [{}, {}]", lo, hi));
    const auto v = *n->value<std::int64_t>();
    if (v < lo || v > hi) fail(key, fmt::format("an integer in [{}, {}]", lo, hi), std::to_string(v));
    return static_cast<int>(v);
  }
  const toml::table& table(std::string_view key) const {
    const auto* n = t_.get(key);
    if (!n || !n->is_table()) fail(key, "a table", n ? "another type" : "missing");
    return *n->as_table();
  }
  const toml::array& array(std::string_view key) const {
    const auto* n = t_.get(key);
    if (!n || !n->is_array()) fail(key, "an array", n ? "another type" : "missing");
    return *n->as_array();
  }
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

 private:
  const toml::table& t_;
  std::string path_;
  const std::string& file_;
};

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

ValueType parse_type(const Reader& r, std::string_view key, std::optional<std::string> def = {}) {
  const auto s = r.str(key, def);
  if (s == "int16") return ValueType::Int16;
  if (s == "uint16") return ValueType::UInt16;
  if (s == "int32") return ValueType::Int32;
  if (s == "uint32") return ValueType::UInt32;
  if (s == "float32") return ValueType::Float32;
  r.fail(key, "int16, uint16, int32, uint32 or float32", "\"" + s + "\"");
}

WordOrder parse_order(const Reader& r, std::string_view key) {
  const auto s = r.str(key, std::string("ABCD"));
  if (s == "ABCD") return WordOrder::ABCD;
  if (s == "CDAB") return WordOrder::CDAB;
  if (s == "BADC") return WordOrder::BADC;
  if (s == "DCBA") return WordOrder::DCBA;
  r.fail(key, "ABCD, CDAB, BADC or DCBA", "\"" + s + "\"");
}

Field parse_field(const Reader& r, bool integer_only) {
  r.allow({"register", "type", "word_order"});
  Field f;
  f.address = r.integer("register", 0, 65535);
  f.type = parse_type(r, "type", std::string("uint32"));
  if (integer_only && f.type == ValueType::Float32) r.fail("type", "an integer type for a counter", "float32");
  f.order = parse_order(r, "word_order");
  return f;
}

ChannelSpec parse_channel(const Reader& r) {
  r.allow({"name", "unit", "type", "word_order", "registers", "scale", "offset", "min", "max",
           "negate_if_register"});
  ChannelSpec c;
  c.name = r.str("name");
  if (c.name.empty()) r.fail("name", "a non-empty name", "\"\"");
  c.unit = r.str("unit");
  if (c.unit.empty()) r.fail("unit", "a unit (\"N\", \"N*mm\", \"mm\", \"rpm\", \"1\" for none, ...)", "\"\"");
  c.type = parse_type(r, "type");
  c.order = parse_order(r, "word_order");
  const auto& regs = r.array("registers");
  if (regs.empty() || regs.size() > 64) r.fail("registers", "1 to 64 register addresses", std::to_string(regs.size()));
  for (std::size_t i = 0; i < regs.size(); ++i) {
    const auto* n = regs.get(i);
    if (!n->is_integer() || *n->value<std::int64_t>() < 0 || *n->value<std::int64_t>() > 65535)
      r.fail(fmt::format("registers[{}]", i), "an integer address in [0, 65535]");
    c.registers.push_back(static_cast<int>(*n->value<std::int64_t>()));
  }
  c.scale = r.num("scale", 1.0);
  if (c.scale == 0.0) r.fail("scale", "a non-zero number", "0");
  c.offset = r.num("offset", 0.0);
  if (r.has("min")) c.min = r.num("min");
  if (r.has("max")) c.max = r.num("max");
  if (c.min && c.max && *c.min > *c.max) r.fail("max", fmt::format("≥ min ({})", *c.min), fmt::format("{}", *c.max));
  if (r.has("negate_if_register")) c.negate_if_register = r.integer("negate_if_register", 0, 65535);
  return c;
}

void check_inside(const Reader& r, const std::string& what, int addr, int n, int lo, int count) {
  if (addr < lo || addr + n > lo + count)
    r.fail(what, fmt::format("registers inside [{}, {})", lo, lo + count),
           fmt::format("[{}, {})", addr, addr + n));
}

DeviceSpec parse_device(const Reader& r) {
  r.allow({"name", "transport", "host", "port", "serial", "baud", "parity", "data_bits", "stop_bits",
           "slave", "rate_hz", "timeout_ms", "late_reply_ms", "mode", "function", "start", "count", "counter", "fifo",
           "calibration", "channels"});
  DeviceSpec d;
  d.name = r.str("name");
  if (d.name.empty() || d.name.find_first_of("/. ") != std::string::npos)
    r.fail("name", "a non-empty name without '/', '.' or spaces", "\"" + d.name + "\"");
  const auto transport = r.str("transport");
  if (transport == "tcp") {
    d.transport = Transport::Tcp;
    d.host = r.str("host");
    d.port = r.integer("port", 1, 65535, 502);
    d.slave = r.integer("slave", 0, 255, 1);
    for (auto k : {"serial", "baud", "parity", "data_bits", "stop_bits"})
      if (r.has(k)) r.fail(k, "no serial settings on a tcp device", "present");
  } else if (transport == "rtu") {
    d.transport = Transport::Rtu;
    d.serial = r.str("serial");
    d.baud = r.integer("baud", 300, 4000000, 19200);
    const auto parity = r.str("parity", std::string("N"));
    if (parity != "N" && parity != "E" && parity != "O") r.fail("parity", "N, E or O", "\"" + parity + "\"");
    d.parity = parity[0];
    d.data_bits = r.integer("data_bits", 7, 8, 8);
    d.stop_bits = r.integer("stop_bits", 1, 2, 1);
    d.slave = r.integer("slave", 1, 247);
    for (auto k : {"host", "port"})
      if (r.has(k)) r.fail(k, "no network settings on an rtu device", "present");
  } else {
    r.fail("transport", "\"tcp\" or \"rtu\"", "\"" + transport + "\"");
  }
  d.rate_hz = r.num("rate_hz");
  if (!(d.rate_hz > 0 && d.rate_hz <= 100000)) r.fail("rate_hz", "a rate in (0, 100000] Hz", fmt::format("{}", d.rate_hz));
  d.timeout_ms = r.num("timeout_ms", 100.0);
  if (!(d.timeout_ms >= 1 && d.timeout_ms <= 10000)) r.fail("timeout_ms", "a timeout in [1, 10000] ms", fmt::format("{}", d.timeout_ms));
  // RTU has no transaction id: a reply that comes after we gave up would pass for the
  // answer to the next request, so after a timeout the bus is left quiet until then.
  d.late_reply_ms = r.num("late_reply_ms", 3 * d.timeout_ms);
  if (d.transport != Transport::Rtu && r.has("late_reply_ms")) r.fail("late_reply_ms", "no late_reply_ms on a tcp device", "present");
  if (!(d.late_reply_ms >= d.timeout_ms && d.late_reply_ms <= 60000))
    r.fail("late_reply_ms", fmt::format("a time in [timeout_ms = {}, 60000] ms", d.timeout_ms), fmt::format("{}", d.late_reply_ms));
  const auto function = r.str("function", std::string("holding"));
  if (function == "holding") d.function = 3;
  else if (function == "input") d.function = 4;
  else r.fail("function", "\"holding\" or \"input\" (reads only)", "\"" + function + "\"");
  d.start = r.integer("start", 0, 65535);
  d.count = r.integer("count", 1, kMaxReadRegisters);
  if (d.start + d.count > 65536) r.fail("count", "a block ending at or before address 65535");
  const auto mode = r.str("mode", std::string("latest"));
  if (mode == "latest") d.mode = Mode::Latest;
  else if (mode == "fifo") d.mode = Mode::Fifo;
  else r.fail("mode", "\"latest\" or \"fifo\"", "\"" + mode + "\"");

  if (r.has("counter")) {
    Reader cr(r.table("counter"), r.field("counter"), r.file());
    d.counter = parse_field(cr, true);
    check_inside(cr, "register", d.counter->address, register_count(d.counter->type), d.start, d.count);
  }
  if (d.mode == Mode::Fifo) {
    if (!r.has("fifo")) r.fail("fifo", "a fifo table for mode = \"fifo\"", "missing");
    if (d.counter) r.fail("counter", "no separate counter in fifo mode (fifo.counter is used)", "present");
    Reader fr(r.table("fifo"), r.field("fifo"), r.file());
    fr.allow({"counter", "first_register", "depth", "record_registers", "device_rate_hz"});
    FifoSpec f;
    Reader fcr(fr.table("counter"), fr.field("counter"), r.file());
    f.counter = parse_field(fcr, true);
    check_inside(fcr, "register", f.counter.address, register_count(f.counter.type), d.start, d.count);
    f.first_register = fr.integer("first_register", 0, 65535);
    f.depth = fr.integer("depth", 1, kMaxReadRegisters);
    f.record_registers = fr.integer("record_registers", 1, kMaxReadRegisters);
    f.device_rate_hz = fr.num("device_rate_hz");
    if (!(f.device_rate_hz > 0 && f.device_rate_hz <= 100000))
      fr.fail("device_rate_hz", "a rate in (0, 100000] Hz", fmt::format("{}", f.device_rate_hz));
    check_inside(fr, "first_register", f.first_register, f.depth * f.record_registers, d.start, d.count);
    // Polling must outpace the FIFO or records are lost by design.
    if (d.rate_hz * f.depth < f.device_rate_hz * 1.5)
      r.fail("rate_hz", fmt::format("≥ 1.5 × device_rate_hz / depth = {} Hz so the FIFO never overruns",
                                    1.5 * f.device_rate_hz / f.depth), fmt::format("{}", d.rate_hz));
    d.fifo = f;
  } else if (r.has("fifo")) {
    r.fail("fifo", "no fifo table unless mode = \"fifo\"", "present");
  }

  const auto& chans = r.array("channels");
  if (chans.empty()) r.fail("channels", "at least one channel", "none");
  std::set<std::string> names;
  const int base = d.mode == Mode::Fifo ? 0 : d.start;
  const int span = d.mode == Mode::Fifo ? d.fifo->record_registers : d.count;
  for (std::size_t i = 0; i < chans.size(); ++i) {
    const auto* t = chans.get(i)->as_table();
    const std::string path = fmt::format("{}[{}]", r.field("channels"), i);
    if (!t) throw InputError(r.file(), path, "a table");
    Reader cr(*t, path, r.file());
    auto c = parse_channel(cr);
    if (!names.insert(c.name).second) cr.fail("name", "a name unique within the device", "\"" + c.name + "\"");
    for (std::size_t k = 0; k < c.registers.size(); ++k)
      check_inside(cr, fmt::format("registers[{}]", k), c.registers[k], register_count(c.type), base, span);
    if (c.negate_if_register) check_inside(cr, "negate_if_register", *c.negate_if_register, 1, base, span);
    d.channels.push_back(std::move(c));
  }
  if (r.has("calibration")) {
    Reader cr(r.table("calibration"), r.field("calibration"), r.file());
    cr.allow({"input", "matrix"});
    CalibrationSpec cal;
    cal.input = cr.str("input");
    const ChannelSpec* in = nullptr;
    for (const auto& c : d.channels)
      if (c.name == cal.input) in = &c;
    if (!in || in->registers.size() != 6) cr.fail("input", "the name of a 6-column channel of this device", "\"" + cal.input + "\"");
    for (const char* out : {"force_N", "torque_Nmm"})
      if (names.count(out)) cr.fail("input", fmt::format("no channel named {} beside a calibration (it is computed)", out), "present");
    const auto& rows = cr.array("matrix");
    if (rows.size() != 6) cr.fail("matrix", "6 rows of 6 numbers", fmt::format("{} rows", rows.size()));
    for (std::size_t i = 0; i < 6; ++i) {
      const auto* row = rows.get(i)->as_array();
      if (!row || row->size() != 6) cr.fail(fmt::format("matrix[{}]", i), "6 numbers");
      for (std::size_t j = 0; j < 6; ++j) {
        const auto* v = row->get(j);
        if (!v->is_number()) cr.fail(fmt::format("matrix[{}][{}]", i, j), "a number");
        const double x = v->is_integer() ? static_cast<double>(*v->value<std::int64_t>()) : *v->value<double>();
        if (!std::isfinite(x)) cr.fail(fmt::format("matrix[{}][{}]", i, j), "a finite number");
        cal.matrix[i * 6 + j] = x;
      }
    }
    d.calibration = cal;
  }
  return d;
}

}  // namespace

RigMap parse_rig_map(std::string_view text, const std::string& file) {
  const toml::table root = data_schema::parse_toml_text(text, file);
  refuse_writes(root, "", file);
  Reader r(root, "", file);
  r.allow({"format", "format_version", "rig_id", "sensor_model", "sensor_serial",
           "sensor_calibration_date", "devices"});
  if (r.str("format") != "burrbench.rig") r.fail("format", "\"burrbench.rig\"", "\"" + r.str("format") + "\"");
  const auto version = r.str("format_version");
  if (version.rfind("1.", 0) != 0) r.fail("format_version", "1.x", "\"" + version + "\"");
  RigMap m;
  m.file = file;
  m.source_toml = std::string(text);
  m.rig_id = r.str("rig_id", std::string());
  m.sensor_model = r.str("sensor_model", std::string());
  m.sensor_serial = r.str("sensor_serial", std::string());
  m.sensor_calibration_date = r.str("sensor_calibration_date", std::string());
  const auto& devs = r.array("devices");
  if (devs.empty() || devs.size() > 64) r.fail("devices", "1 to 64 devices", std::to_string(devs.size()));
  std::set<std::string> names;
  for (std::size_t i = 0; i < devs.size(); ++i) {
    const auto* t = devs.get(i)->as_table();
    const std::string path = fmt::format("devices[{}]", i);
    if (!t) throw InputError(file, path, "a table");
    auto d = parse_device(Reader(*t, path, file));
    if (!names.insert(d.name).second) throw InputError(file, path + ".name", "a unique device name", "\"" + d.name + "\"");
    // Devices on one RS-485 bus share its line settings.
    for (const auto& o : m.devices) {
      if (d.transport == Transport::Rtu && o.transport == Transport::Rtu && o.serial == d.serial &&
          (o.baud != d.baud || o.parity != d.parity || o.data_bits != d.data_bits || o.stop_bits != d.stop_bits))
        throw InputError(file, path + ".baud", fmt::format("the line settings of device {} on the same bus {}", o.name, d.serial));
    }
    m.devices.push_back(std::move(d));
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
