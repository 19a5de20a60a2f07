// Register maps: the presets parse to what the hardware serves; defects and any write
// request are refused with the file, the field and what was expected.
#include <fstream>
#include <iterator>
#include <string>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/register_map.hpp"

using namespace burrbench;
using namespace burrbench::rig;

namespace {
const std::string kDevice = R"(
format = "burrbench.rig"
format_version = "1.0"
[[devices]]
name = "ft"
transport = "tcp"
host = "127.0.0.1"
port = 502
slave = 9
rate_hz = 100
start = 180
count = 6
  [[devices.channels]]
  name = "force_N"
  unit = "N"
  type = "int16"
  registers = [180, 181, 182]
  scale = 0.01
)";

std::string message_of(const std::string& text) {
  try {
    parse_rig_map(text, "m.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}
std::string with(const std::string& from, const std::string& to) {
  std::string t = kDevice;
  const auto at = t.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return t.replace(at, from.size(), to);
}
}  // namespace

TEST(RegisterMap, VirtualPresetMatchesContractE) {
  const auto m = load_rig_map(std::string(BURRBENCH_SOURCE_DIR) + "/examples/rigs/virtual.toml");
  ASSERT_EQ(m.devices.size(), 3u);
  const auto& ft = m.devices[0];
  EXPECT_EQ(ft.slave, 9);
  EXPECT_EQ(ft.start, 180);
  EXPECT_EQ(ft.count, 42);
  EXPECT_EQ(ft.counter->address, 220);
  EXPECT_EQ(ft.channels[0].name, "force_N");
  EXPECT_EQ(ft.channels[0].registers, (std::vector<int>{200, 202, 204}));
  EXPECT_EQ(m.devices[1].slave, 1);
  EXPECT_EQ(m.devices[1].channels[0].type, ValueType::Int32);
  EXPECT_EQ(m.devices[1].channels[0].scale, std::vector<double>{0.001});
  EXPECT_EQ(m.devices[2].channels[0].negate_if_register, 1);
  EXPECT_EQ(m.devices[2].count, 5);  // rpm, direction, counter, load
  EXPECT_EQ(m.devices[2].channels[1].name, "spindle_torque_Nmm");
  EXPECT_EQ(m.devices[2].channels[1].registers, (std::vector<int>{4}));
}

// The VFD example (issue 13): speed and the load torque in 0.1 % of nominal, decoded to
// the canonical spindle_rpm and spindle_torque_Nmm (signed int16, scale τ_n/1000).
TEST(RegisterMap, VfdSpindleExampleMapsTheLoadRegister) {
  const auto m = load_rig_map(std::string(BURRBENCH_SOURCE_DIR) + "/examples/rigs/vfd-spindle.toml");
  ASSERT_EQ(m.devices.size(), 1u);
  const auto& d = m.devices[0];
  EXPECT_EQ(d.transport, Transport::Rtu);
  EXPECT_EQ(d.parity, 'E');
  ASSERT_EQ(d.channels.size(), 2u);
  EXPECT_EQ(d.channels[0].name, "spindle_rpm");
  EXPECT_EQ(d.channels[1].name, "spindle_torque_Nmm");
  EXPECT_EQ(d.channels[1].unit, "N*mm");
  EXPECT_EQ(d.channels[1].type, ValueType::Int16);
  EXPECT_EQ(d.channels[1].registers, (std::vector<int>{2106}));
  EXPECT_EQ(d.channels[1].scale, std::vector<double>{0.0796});
  EXPECT_GE(d.channels[1].registers[0], d.start);
  EXPECT_LT(d.channels[1].registers[0], d.start + d.count);
}

TEST(RegisterMap, RobotiqPresetIsRtuSlave9At19200) {
  const auto m = load_rig_map(std::string(BURRBENCH_SOURCE_DIR) + "/examples/rigs/robotiq-ft300-az-spindle.toml");
  const auto& ft = m.devices[0];
  EXPECT_EQ(ft.transport, Transport::Rtu);
  EXPECT_EQ(ft.slave, 9);
  EXPECT_EQ(ft.baud, 19200);
  EXPECT_EQ(ft.parity, 'N');
  EXPECT_EQ(ft.start, 180);
  EXPECT_EQ(ft.count, 6);
  EXPECT_EQ(m.devices[1].serial, m.devices[2].serial);  // one bus, one thread
}

TEST(RegisterMap, RtuBusThatCannotCarryTheRatesIsRefused) {
  // The FT 300 at 19200 8N1: 6 registers are 25 bytes on the wire (13.0 ms) plus two
  // 3.5-character silences (3.6 ms) — 16.6 ms a poll, so 100 Hz would need 167 % of the bus.
  std::ifstream in(std::string(BURRBENCH_SOURCE_DIR) + "/examples/rigs/robotiq-ft300-az-spindle.toml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto m = parse_rig_map(text, "m.toml");
  EXPECT_NEAR(rtu_poll_wire_s(m.devices[0]) * 1e3, (25 * 10 + 7 * 10) / 19.2, 1e-9);
  const auto buses = rtu_bus_budgets(m.devices);
  ASSERT_EQ(buses.size(), 2u);
  EXPECT_NEAR(buses[0].load, 50 * (25 * 10 + 7 * 10) / 19200.0, 1e-12);
  // Above 19200 baud the silence is a fixed 1.75 ms: stage 25 bytes 8E1, spindle 17 bytes.
  EXPECT_NEAR(buses[1].load, 100 * (25 * 11 / 115200.0 + 3.5e-3) + 50 * (17 * 11 / 115200.0 + 3.5e-3), 1e-12);
  const auto at = text.find("rate_hz = 50 ");
  ASSERT_NE(at, std::string::npos);
  const auto msg = message_of(text.replace(at, 13, "rate_hz = 100"));
  EXPECT_NE(msg.find("m.toml: devices[0].rate_hz: expected rates the bus /dev/ttyUSB0 carries at 19200 baud"),
            std::string::npos) << msg;
  EXPECT_NE(msg.find("167 % busy"), std::string::npos) << msg;
}

TEST(RegisterMap, FifoPresetParses) {
  const auto m = load_rig_map(std::string(BURRBENCH_SOURCE_DIR) + "/examples/rigs/virtual-fifo.toml");
  ASSERT_TRUE(m.devices[0].fifo);
  EXPECT_EQ(m.devices[0].fifo->depth, 8);
  EXPECT_EQ(m.devices[0].sample_registers(), 12);
  ASSERT_EQ(m.devices.size(), 3u);  // force and stage through FIFOs, spindle latest
  ASSERT_TRUE(m.devices[1].fifo);
  EXPECT_EQ(m.devices[1].fifo->depth, 16);
  EXPECT_EQ(m.devices[1].sample_registers(), 6);
}

TEST(RegisterMap, PerAxisScaleAndOffsetParse) {
  const auto m = parse_rig_map(with("scale = 0.01", "scale = [0.01, 0.02, 0.03]\noffset = [-1, 0, 1.5]"), "m.toml");
  EXPECT_EQ(m.devices[0].channels[0].scale, (std::vector<double>{0.01, 0.02, 0.03}));
  EXPECT_EQ(m.devices[0].channels[0].offset, (std::vector<double>{-1, 0, 1.5}));
}

TEST(RegisterMap, MinimalMapParses) {
  const auto m = parse_rig_map(kDevice, "m.toml");
  EXPECT_EQ(m.devices[0].channels[0].registers.size(), 3u);
}

TEST(RegisterMap, WriteRequestsAreRefused) {
  for (const auto& bad : {with("start = 180", "start = 180\nwrite_registers = [1]"),
                          with("start = 180", "function = \"write_multiple\"\nstart = 180"),
                          with("format_version = \"1.0\"", "format_version = \"1.0\"\n[write]\nx = 1")}) {
    const auto msg = message_of(bad);
    EXPECT_NE(msg.find("m.toml"), std::string::npos) << msg;
    EXPECT_NE(msg.find("read-only"), std::string::npos) << msg;
  }
}

TEST(RegisterMap, DefectsNameFileFieldAndExpectation) {
  struct Case { std::string text, field; };
  const Case cases[] = {
      {with("type = \"int16\"", "type = \"int24\""), "devices[0].channels[0].type"},
      {with("registers = [180, 181, 182]", "registers = [180, 181, 190]"), "devices[0].channels[0].registers[2]"},
      {with("count = 6", "count = 200"), "devices[0].count"},
      {with("rate_hz = 100", "rate_hz = 0"), "devices[0].rate_hz"},
      {with("rate_hz = 100", "rate_hz = 1e-12"), "devices[0].rate_hz"},  // would overflow the period
      {with("rate_hz = 100", "rate_hz = 100\nlate_reply_ms = 500"), "devices[0].late_reply_ms"},  // RTU only
      {with("rate_hz = 100", "rate_hz = 100\ncolour = 1"), "devices[0].colour"},
      {with("transport = \"tcp\"", "transport = \"udp\""), "devices[0].transport"},
      {with("slave = 9", "slave = 300"), "devices[0].slave"},
      {with("scale = 0.01", "scale = 0"), "devices[0].channels[0].scale"},
      {with("rate_hz = 100", "rate_hz = 100\nreconnect_backoff_ms = 0"), "devices[0].reconnect_backoff_ms"},
      {with("rate_hz = 100", "rate_hz = 100\nreconnect_backoff_ms = 50\nreconnect_max_ms = 10"), "devices[0].reconnect_max_ms"},
      {with("scale = 0.01", "scale = [0.01, 0.01]"), "devices[0].channels[0].scale"},  // one per column
      {with("scale = 0.01", "scale = [0.01, 0, 0.01]"), "devices[0].channels[0].scale[1]"},
      {with("scale = 0.01", "scale = 0.01\noffset = [1, \"a\", 2]"), "devices[0].channels[0].offset"},
      {with("unit = \"N\"", "unit = \"N\"\nword_order = \"ACBD\""), "devices[0].channels[0].word_order"},
      {with("format = \"burrbench.rig\"", "format = \"other\""), "format"},
      {with("scale = 0.01", "scale = 0.01\nscale = 2"), "line"},
      // Canonical channels must decode to what a recording holds (issue 11, fault 2).
      {with("unit = \"N\"", "unit = \"kN\""), "devices[0].channels[0].unit"},
      {with("registers = [180, 181, 182]", "registers = [180, 181]"), "devices[0].channels[0].registers"},
      // No register is read twice (fault 6): within a channel, or by a second channel.
      {with("registers = [180, 181, 182]", "registers = [180, 181, 181]"), "devices[0].channels[0].registers[2]"},
      {kDevice + "  [[devices.channels]]\n  name = \"fz_copy\"\n  unit = \"N\"\n  type = \"int16\"\n"
                 "  registers = [182]\n", "devices[0].channels[1].registers[0]"},
      {with("type = \"int16\"\n  registers = [180, 181, 182]", "type = \"int32\"\n  registers = [180, 181, 183]"),
       "devices[0].channels[0].registers[1]"},
  };
  for (const auto& c : cases) {
    const auto msg = message_of(c.text);
    EXPECT_NE(msg.find("m.toml: " + c.field), std::string::npos) << "want " << c.field << ", got: " << msg;
    EXPECT_NE(msg.find("expected"), std::string::npos) << msg;
  }
}

TEST(RegisterMap, FifoMustOutpaceTheDevice) {
  const std::string fifo = R"(
format = "burrbench.rig"
format_version = "1.0"
[[devices]]
name = "ft"
transport = "tcp"
host = "localhost"
slave = 9
rate_hz = 100
mode = "fifo"
start = 300
count = 98
fifo = { counter = { register = 300 }, first_register = 302, depth = 8, record_registers = 12, device_rate_hz = 1000 }
  [[devices.channels]]
  name = "force_N"
  type = "float32"
  registers = [0, 2, 4]
)";
  const auto msg = message_of(fifo);
  EXPECT_NE(msg.find("devices[0].rate_hz"), std::string::npos) << msg;
}

TEST(RegisterMap, CalibrationNeedsSixColumnInput) {
  std::string t = with("name = \"force_N\"", "name = \"strain\"");
  t += "  [devices.calibration]\n  input = \"strain\"\n  matrix = [[1,0,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,1]]\n";
  const auto msg = message_of(t);  // "strain" has 3 columns
  EXPECT_NE(msg.find("m.toml: devices[0].calibration.input: expected the name of a 6-column channel"), std::string::npos) << msg;
}

TEST(RegisterMap, StatusWordIsParsedAndChecked) {
  const auto m = parse_rig_map(with("count = 6", "count = 6\nstatus = { register = 185, invalid_mask = 0x8003 }"), "m.toml");
  ASSERT_TRUE(m.devices[0].status);
  EXPECT_EQ(m.devices[0].status->field.address, 185);
  EXPECT_EQ(m.devices[0].status->field.type, ValueType::UInt16);
  EXPECT_EQ(m.devices[0].status->invalid_mask, 0x8003u);
  EXPECT_NE(message_of(with("count = 6", "count = 6\nstatus = { register = 190, invalid_mask = 1 }"))
                .find("m.toml: devices[0].status.register: expected registers inside [180, 186)"),
            std::string::npos);
  EXPECT_NE(message_of(with("count = 6", "count = 6\nstatus = { register = 185, invalid_mask = 0x10000 }"))
                .find("m.toml: devices[0].status.invalid_mask"),
            std::string::npos);
  EXPECT_NE(message_of(with("count = 6", "count = 6\nstatus = { register = 185 }")).find("m.toml: devices[0].status.invalid_mask"),
            std::string::npos);
}

TEST(RegisterMap, SeveralBlocksAreLaidEndToEndAndEachCostsAFrameOnTheWire) {
  // Input registers 300..309 and holding registers 100..103 of one unit, in one poll.
  const std::string text = R"(
format = "burrbench.rig"
format_version = "1.0"
[[devices]]
name = "ft"
transport = "rtu"
serial = "/dev/null"
baud = 19200
slave = 9
rate_hz = 10
blocks = [{ function = "input", start = 300, count = 10 }, { function = "holding", start = 100, count = 4 }]
counter = { register = 102, type = "uint32" }
  [[devices.channels]]
  name = "force_N"
  unit = "N"
  type = "int16"
  registers = [300, 301, 309]
)";
  const auto m = parse_rig_map(text, "m.toml");
  const auto& d = m.devices[0];
  ASSERT_EQ(d.blocks.size(), 2u);
  EXPECT_EQ(d.blocks[0].function, 4);
  EXPECT_EQ(d.blocks[1].function, 3);
  EXPECT_EQ(d.start, 300);
  EXPECT_EQ(d.count, 14);
  // In the poll's buffer: block 0 at 300..309, block 1 right after it at 310..313.
  EXPECT_EQ(d.channels[0].registers, (std::vector<int>{300, 301, 309}));
  EXPECT_EQ(d.counter->address, 312);
  // Two requests (8 bytes) and replies (5 + 2·count bytes), each frame with its silence,
  // at 10 bits a byte and 19200 baud.
  EXPECT_NEAR(rtu_poll_wire_s(d) * 1e3, ((8 + 5 + 20) * 10 + (8 + 5 + 8) * 10 + 4 * 3.5 * 10) / 19.2, 1e-9);
  // A field that runs from one block into a register no block reads is refused.
  EXPECT_NE(message_of(std::string(text).replace(text.find("register = 102"), 14, "register = 103")).find(
                "m.toml: devices[0].counter.register: expected registers read consecutively by the device's blocks "
                "[300, 310) [100, 104), got [103, 105)"),
            std::string::npos);
}
