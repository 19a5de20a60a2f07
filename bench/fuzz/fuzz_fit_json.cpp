// libFuzzer target: read_fit, i.e. the bounded JSON read (nesting pre-scan, nlohmann),
// the strict JsonView and the fit's validation. read_fit takes a path, so each input is
// written to the private scratch folder first (fuzz_file.hpp: tmpfs).
#include "burrbench/data_schema/fit_result.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("fit.json", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::data_schema::read_fit(path); });
}
