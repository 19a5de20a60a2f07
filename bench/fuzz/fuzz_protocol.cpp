// libFuzzer target: parse_protocol (a synthetic drilling protocol TOML: moves, rates, burr).
#include "burrbench/model/protocol.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  return expect_input_errors_only([&] { burrbench::model::parse_protocol(as_text(data, size), "fuzz-protocol.toml"); });
}
