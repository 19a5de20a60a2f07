#include "burrbench/rig/decode.hpp"

#include <bit>
#include <cmath>
#include <limits>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::rig {
namespace {
std::uint16_t swap_bytes(std::uint16_t v) { return static_cast<std::uint16_t>((v >> 8) | (v << 8)); }
}  // namespace

std::uint32_t assemble32(std::uint16_t r0, std::uint16_t r1, WordOrder order) {
  std::uint16_t hi = 0, lo = 0;
  switch (order) {
    case WordOrder::ABCD: hi = r0; lo = r1; break;
    case WordOrder::CDAB: hi = r1; lo = r0; break;
    case WordOrder::BADC: hi = swap_bytes(r0); lo = swap_bytes(r1); break;
    case WordOrder::DCBA: hi = swap_bytes(r1); lo = swap_bytes(r0); break;
  }
  return (static_cast<std::uint32_t>(hi) << 16) | lo;
}

std::uint16_t assemble16(std::uint16_t r0, WordOrder order) {
  return (order == WordOrder::BADC || order == WordOrder::DCBA) ? swap_bytes(r0) : r0;
}

double decode_raw(const std::uint16_t* regs, ValueType type, WordOrder order) {
  switch (type) {
    case ValueType::Int16: return static_cast<std::int16_t>(assemble16(regs[0], order));
    case ValueType::UInt16: return assemble16(regs[0], order);
    case ValueType::Int32: return static_cast<std::int32_t>(assemble32(regs[0], regs[1], order));
    case ValueType::UInt32: return assemble32(regs[0], regs[1], order);
    case ValueType::Float32: return std::bit_cast<float>(assemble32(regs[0], regs[1], order));
  }
  BURRBENCH_UNREACHABLE();
}

std::int64_t decode_integer(const std::uint16_t* regs, ValueType type, WordOrder order) {
  BURRBENCH_CHECK(type != ValueType::Float32, "counters are integers");
  return static_cast<std::int64_t>(decode_raw(regs, type, order));
}

std::int64_t counter_range(ValueType type) {
  return register_count(type) == 1 ? std::int64_t{1} << 16 : std::int64_t{1} << 32;
}

std::optional<std::int64_t> unwrap_counter(std::int64_t previous, std::int64_t raw, ValueType type,
                                           double max_advance) {
  const std::int64_t range = counter_range(type);
  const std::int64_t now = ((raw % range) + range) % range;
  if (previous < 0) return now;
  const std::int64_t before = previous % range;
  if (now >= before) return previous + (now - before);
  const std::int64_t forward = now + range - before;
  if (static_cast<double>(forward) <= max_advance) return previous + forward;
  return std::nullopt;
}

bool status_invalid(const DeviceSpec& d, std::span<const std::uint16_t> regs, int base) {
  if (!d.status) return false;
  const int at = d.status->field.address - base;
  BURRBENCH_CHECK(at >= 0 && at + register_count(d.status->field.type) <= static_cast<int>(regs.size()),
                  "checked by the map");
  const auto word = static_cast<std::uint32_t>(decode_integer(regs.data() + at, d.status->field.type, d.status->field.order));
  return (word & d.status->invalid_mask) != 0;
}

bool at_rail(double raw, ValueType type) {
  switch (type) {
    case ValueType::Int16: return std::abs(raw) >= 32767;
    case ValueType::Int32: return std::abs(raw) >= 2147483647.0;
    case ValueType::UInt16: return raw >= 65535;
    case ValueType::UInt32: return raw >= 4294967295.0;
    case ValueType::Float32: return false;  // NaN and ±Inf are flagged as non-finite
  }
  BURRBENCH_UNREACHABLE();
}

bool decode_channel(const ChannelSpec& ch, std::span<const std::uint16_t> regs, int base,
                    std::span<double> out) {
  BURRBENCH_CHECK(out.size() == ch.registers.size(), "one output per column");
  const int n = register_count(ch.type);
  bool ok = true;
  bool negate = false;
  if (ch.negate_if_register) {
    const int at = *ch.negate_if_register - base;
    BURRBENCH_CHECK(at >= 0 && at < static_cast<int>(regs.size()), "checked by the map");
    negate = regs[static_cast<std::size_t>(at)] != 0;
  }
  for (std::size_t i = 0; i < ch.registers.size(); ++i) {
    const int at = ch.registers[i] - base;
    BURRBENCH_CHECK(at >= 0 && at + n <= static_cast<int>(regs.size()), "checked by the map");
    const double scale = ch.scale.size() == 1 ? ch.scale[0] : ch.scale[i];
    const double offset = ch.offset.size() == 1 ? ch.offset[0] : ch.offset[i];
    const double raw = decode_raw(regs.data() + at, ch.type, ch.order);
    double v = raw * scale + offset;
    if (negate) v = -v;
    if (!std::isfinite(v) || at_rail(raw, ch.type) || (ch.min && v < *ch.min) || (ch.max && v > *ch.max)) {
      ok = false;
      v = std::numeric_limits<double>::quiet_NaN();
    }
    out[i] = v;
  }
  return ok;
}

}  // namespace burrbench::rig
