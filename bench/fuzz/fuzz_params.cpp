// libFuzzer target: read_params (parameter set TOML: α, C1, μ per class and nuisances).
#include "burrbench/data_schema/parameter_set.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("params.toml", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::data_schema::read_params(path); });
}
