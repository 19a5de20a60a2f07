// libFuzzer target: read_density_phantom (a CT's density calibration TOML: rods or a
// slope and intercept).
#include "burrbench/data_schema/import/density.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("density.toml", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::data_schema::import::read_density_phantom(path); });
}
