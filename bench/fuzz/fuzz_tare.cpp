// libFuzzer target: read_tare (the bias file `rig tare` writes and `acquire --tare` reads).
#include "burrbench/rig/tools.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("tare.toml", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::rig::read_tare(path); });
}
