// Decoding of every value type in every word order, against byte patterns built here
// independently of the decoder (registers carry big-endian bytes).
#include <cmath>
#include <cstring>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

#include "burrbench/rig/decode.hpp"

using namespace burrbench::rig;

namespace {
// Four bytes A B C D (A most significant) laid out in two registers per word order.
std::array<std::uint16_t, 2> regs_of(std::uint32_t v, WordOrder o) {
  const std::uint8_t a = v >> 24, b = (v >> 16) & 0xFF, c = (v >> 8) & 0xFF, d = v & 0xFF;
  auto w = [](std::uint8_t hi, std::uint8_t lo) { return static_cast<std::uint16_t>((hi << 8) | lo); };
  switch (o) {
    case WordOrder::ABCD: return {w(a, b), w(c, d)};
    case WordOrder::CDAB: return {w(c, d), w(a, b)};
    case WordOrder::BADC: return {w(b, a), w(d, c)};
    case WordOrder::DCBA: return {w(d, c), w(b, a)};
  }
  return {};
}
std::uint32_t bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}
constexpr WordOrder kOrders[] = {WordOrder::ABCD, WordOrder::CDAB, WordOrder::BADC, WordOrder::DCBA};
}  // namespace

TEST(Decode, Float32In123456EveryWordOrder) {
  for (auto o : kOrders) {
    const auto r = regs_of(bits(123456.0f), o);
    EXPECT_EQ(decode_raw(r.data(), ValueType::Float32, o), 123456.0) << to_string(o);
  }
}

TEST(Decode, KnownRegisterImagesOfTheVirtualRig) {
  // 123456.0f = 0x47F12000: the words CONTRACTS E serves at 400..407.
  const std::uint16_t abcd[] = {0x47F1, 0x2000}, cdab[] = {0x2000, 0x47F1}, badc[] = {0xF147, 0x0020},
                      dcba[] = {0x0020, 0xF147};
  EXPECT_EQ(decode_raw(abcd, ValueType::Float32, WordOrder::ABCD), 123456.0);
  EXPECT_EQ(decode_raw(cdab, ValueType::Float32, WordOrder::CDAB), 123456.0);
  EXPECT_EQ(decode_raw(badc, ValueType::Float32, WordOrder::BADC), 123456.0);
  EXPECT_EQ(decode_raw(dcba, ValueType::Float32, WordOrder::DCBA), 123456.0);
  // A wrong word order gives a different number, so the tests above can fail.
  EXPECT_NE(decode_raw(abcd, ValueType::Float32, WordOrder::CDAB), 123456.0);
}

TEST(Decode, Int32AndUInt32EveryWordOrder) {
  for (auto o : kOrders) {
    for (std::int32_t v : {123456, -123456, std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max(), -1, 0}) {
      const auto r = regs_of(static_cast<std::uint32_t>(v), o);
      EXPECT_EQ(decode_raw(r.data(), ValueType::Int32, o), v) << to_string(o) << " " << v;
      EXPECT_EQ(decode_integer(r.data(), ValueType::Int32, o), v);
    }
    const auto r = regs_of(0xFFFFFFFEu, o);
    EXPECT_EQ(decode_raw(r.data(), ValueType::UInt32, o), 4294967294.0) << to_string(o);
  }
}

TEST(Decode, SixteenBitTypes) {
  const std::uint16_t neg = 0xFFFE, pos = 0x1234;
  EXPECT_EQ(decode_raw(&neg, ValueType::Int16, WordOrder::ABCD), -2);
  EXPECT_EQ(decode_raw(&neg, ValueType::UInt16, WordOrder::ABCD), 65534);
  EXPECT_EQ(decode_raw(&pos, ValueType::UInt16, WordOrder::CDAB), 0x1234);
  EXPECT_EQ(decode_raw(&pos, ValueType::UInt16, WordOrder::BADC), 0x3412);  // bytes swapped
  EXPECT_EQ(decode_raw(&pos, ValueType::UInt16, WordOrder::DCBA), 0x3412);
  const std::uint16_t m = 0x8001;  // -32767: FT 300 saturation value
  EXPECT_EQ(decode_raw(&m, ValueType::Int16, WordOrder::ABCD), -32767);
}

TEST(Decode, ChannelScaleOffsetNegateAndFlags) {
  ChannelSpec c;
  c.type = ValueType::Int16;
  c.registers = {10, 11, 12};
  c.scale = {0.01};
  c.offset = {1.0};
  c.negate_if_register = 13;
  const std::uint16_t regs[] = {100, 0xFF9C /* -100 */, 5, 0};
  double out[3];
  ASSERT_TRUE(decode_channel(c, regs, 10, out));
  EXPECT_DOUBLE_EQ(out[0], 2.0);
  EXPECT_DOUBLE_EQ(out[1], 0.0);
  EXPECT_DOUBLE_EQ(out[2], 1.05);
  const std::uint16_t neg[] = {100, 0, 0, 1};
  ASSERT_TRUE(decode_channel(c, neg, 10, out));
  EXPECT_DOUBLE_EQ(out[0], -2.0);
  c.max = 1.5;
  EXPECT_FALSE(decode_channel(c, regs, 10, out));  // 2.0 > max → flagged
  EXPECT_TRUE(std::isnan(out[0]));
  EXPECT_DOUBLE_EQ(out[2], 1.05);  // the valid columns keep their values
}

// A clipped register's number is a bound, not a reading: flagged for every integer type at
// its rail, while the value one count inside it, unsigned zero and any float pass.
TEST(Decode, ValuesAtTheirRegistersRailAreFlagged) {
  EXPECT_TRUE(at_rail(32767, ValueType::Int16));
  EXPECT_TRUE(at_rail(-32767, ValueType::Int16));  // the FT 300's
  EXPECT_TRUE(at_rail(-32768, ValueType::Int16));
  EXPECT_FALSE(at_rail(32766, ValueType::Int16));
  EXPECT_FALSE(at_rail(-32766, ValueType::Int16));
  EXPECT_TRUE(at_rail(2147483647.0, ValueType::Int32));
  EXPECT_TRUE(at_rail(-2147483648.0, ValueType::Int32));
  EXPECT_FALSE(at_rail(2147483646.0, ValueType::Int32));
  EXPECT_TRUE(at_rail(65535, ValueType::UInt16));
  EXPECT_FALSE(at_rail(0, ValueType::UInt16));
  EXPECT_FALSE(at_rail(65534, ValueType::UInt16));
  EXPECT_TRUE(at_rail(4294967295.0, ValueType::UInt32));
  EXPECT_FALSE(at_rail(0, ValueType::UInt32));
  EXPECT_FALSE(at_rail(3.4e38, ValueType::Float32));
  ChannelSpec c;
  c.type = ValueType::Int16;
  c.registers = {0, 1, 2};
  c.scale = {0.01};
  const std::uint16_t regs[] = {0x7FFF, 0x8001, 0x7FFE};  // 32767, −32767, 32766
  double out[3];
  EXPECT_FALSE(decode_channel(c, regs, 0, out));
  EXPECT_TRUE(std::isnan(out[0]));
  EXPECT_TRUE(std::isnan(out[1]));
  EXPECT_DOUBLE_EQ(out[2], 327.66);  // one count inside the rail is a reading
}

TEST(Decode, PerAxisScaleAndOffset) {
  ChannelSpec c;
  c.type = ValueType::Int16;
  c.registers = {0, 1, 2};
  c.scale = {0.01, 0.02, -0.5};
  c.offset = {0.0, 1.0, 10.0};
  const std::uint16_t regs[] = {100, 100, 4};
  double out[3];
  ASSERT_TRUE(decode_channel(c, regs, 0, out));
  EXPECT_DOUBLE_EQ(out[0], 1.0);
  EXPECT_DOUBLE_EQ(out[1], 3.0);
  EXPECT_DOUBLE_EQ(out[2], 8.0);
}

TEST(Decode, NanAndInfFloatsAreFlaggedNotPassedOn) {
  ChannelSpec c;
  c.type = ValueType::Float32;
  c.registers = {0};
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity()}) {
    const auto r = regs_of(bits(bad), WordOrder::ABCD);
    double out[1] = {42};
    EXPECT_FALSE(decode_channel(c, r, 0, out));
    EXPECT_TRUE(std::isnan(out[0]));
  }
}

TEST(Decode, CounterWrapIsUnwrappedAndARestartIsNot) {
  // uint16 at 1 kHz rolls over every 65.5 s: 65530 → 4 is 10 counts on, not a restart.
  EXPECT_EQ(unwrap_counter(-1, 65530, ValueType::UInt16, 100), 65530);
  EXPECT_EQ(unwrap_counter(65530, 65535, ValueType::UInt16, 100), 65535);
  EXPECT_EQ(unwrap_counter(65530, 4, ValueType::UInt16, 100), 65540);
  EXPECT_EQ(unwrap_counter(3 * 65536 + 65530, 4, ValueType::UInt16, 100), 4 * 65536 + 4);  // third wrap
  EXPECT_EQ(unwrap_counter(65540, 70, ValueType::UInt16, 100), 65536 + 70);  // after the wrap: forward
  // Back further than the device can have counted: a restart.
  EXPECT_EQ(unwrap_counter(40000, 3, ValueType::UInt16, 100), std::nullopt);
  EXPECT_EQ(unwrap_counter(65530, 200, ValueType::UInt16, 100), std::nullopt);
  // int16 counters wrap at the same 16 bits (−1 is 65535); 32-bit ones at 2^32.
  EXPECT_EQ(unwrap_counter(65535, 2, ValueType::Int16, 10), 65538);
  EXPECT_EQ(unwrap_counter(-1, -1, ValueType::Int16, 10), 65535);
  EXPECT_EQ(unwrap_counter(4294967290LL, 5, ValueType::UInt32, 100), 4294967301LL);
  EXPECT_EQ(unwrap_counter(4294967290LL, 5, ValueType::UInt32, 5), std::nullopt);
}

TEST(Decode, StatusWordMasksMarkSamplesInvalid) {
  DeviceSpec d;
  EXPECT_FALSE(status_invalid(d, std::vector<std::uint16_t>{0xFFFF}, 0));  // no status word
  d.status = StatusSpec{Field{11, ValueType::UInt16, WordOrder::ABCD}, 0x0006};
  const std::vector<std::uint16_t> ok{0xFFFF, 0x0009}, bad{0, 0x0004}, swapped{0, 0x0400};
  EXPECT_FALSE(status_invalid(d, ok, 10));
  EXPECT_TRUE(status_invalid(d, bad, 10));
  EXPECT_FALSE(status_invalid(d, swapped, 10));
  d.status->field.order = WordOrder::BADC;  // byte-swapped device
  EXPECT_TRUE(status_invalid(d, swapped, 10));
}
