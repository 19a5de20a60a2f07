// libFuzzer target: read_criteria (the release gate's acceptance criteria TOML).
#include "burrbench/analysis/criteria.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("criteria.toml", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::analysis::read_criteria(path); });
}
