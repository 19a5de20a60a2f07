// libFuzzer target: read_isq (a Scanco ISQ file: 512-byte header, then int16 voxels).
#include "burrbench/data_schema/import/volume.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  using namespace burrbench::data_schema::import;
  const auto path = put("fuzz.isq", as_text(data, size));
  ImportLimits lim;
  lim.max_bytes = std::size_t{64} << 20;  // far below libFuzzer's RSS limit
  return expect_input_errors_only([&] { read_isq(path, lim); });
}
