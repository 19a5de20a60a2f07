#pragma once
// Decoding register values in our own code: libmodbus 3.1.6's float helpers swap bytes
// (fixed upstream in 3.1.11), so nothing here calls them.
#include <cstdint>
#include <optional>
#include <span>

#include "burrbench/rig/register_map.hpp"

namespace burrbench::rig {

// Raw 32 bits (A = most significant byte) from two registers in a word order.
std::uint32_t assemble32(std::uint16_t r0, std::uint16_t r1, WordOrder order);
// 16-bit value: BADC/DCBA swap the two bytes, ABCD/CDAB keep them.
std::uint16_t assemble16(std::uint16_t r0, WordOrder order);

// The raw numeric value at regs[0..register_count(type)); a float32 may be NaN/Inf.
double decode_raw(const std::uint16_t* regs, ValueType type, WordOrder order);
// Integer value (counters); float32 is not allowed here.
std::int64_t decode_integer(const std::uint16_t* regs, ValueType type, WordOrder order);

// Device counters are unwrapped to 64 bits: a uint16 counter at 1 kHz rolls over every
// 65.5 s, and a roll-over is not a restart. `previous` is the last unwrapped value (< 0:
// none yet), `raw` the decoded counter register, `max_advance` the most counts the device
// can have taken since then. A decrease whose forward distance modulo the counter's range
// (2^16 or 2^32) is within max_advance is a wrap; any other decrease returns nullopt: the
// device restarted (the caller starts again from `raw` modulo the range).
std::optional<std::int64_t> unwrap_counter(std::int64_t previous, std::int64_t raw, ValueType type,
                                           double max_advance);
std::int64_t counter_range(ValueType type);  // 2^16 or 2^32

// True when the device's status word (if it has one) marks this sample invalid.
bool status_invalid(const DeviceSpec& d, std::span<const std::uint16_t> regs, int base);

// True for an integer register at its type's rail: int16 ±32767 and −32768, int32 likewise,
// uint16 65535, uint32 2^32 − 1. A sensor or a converter that clips holds its register
// there however far beyond the true value lies (the FT 300 gives −32767), so the number
// is a bound, not a measurement. Unsigned zero is a real reading (a stopped spindle).
bool at_rail(double raw, ValueType type);

// Decode one channel from a sample's registers (base = address of regs[0]).
// Returns false when a value is NaN/Inf, at its register's rail or outside [min, max];
// such values are NaN.
bool decode_channel(const ChannelSpec& ch, std::span<const std::uint16_t> regs, int base,
                    std::span<double> out);

}  // namespace burrbench::rig
