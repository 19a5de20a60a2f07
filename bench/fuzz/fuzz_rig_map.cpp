// libFuzzer target: parse_rig_map (the register map TOML: devices, blocks, FIFO, channels,
// RTU bus budgets, the read-only rule).
#include "burrbench/rig/register_map.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  return expect_input_errors_only([&] { burrbench::rig::parse_rig_map(as_text(data, size), "fuzz-rig.toml"); });
}
