// libFuzzer target: the CSV importer's column map (TOML) alone, against a fixed LabVIEW-
// style export whose columns the seed maps (fuzz_csv mutates the CSV and the map together).
#include "burrbench/data_schema/import/csv_recording.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "fuzz_file.hpp"

namespace {
constexpr std::string_view kCsv =
    "LabVIEW export\n"
    "Time (ms)\tX [um]\tY\tZ\tFx\tFy\tFz\tTx\tTy\tTz\trpm\tnote\n"
    "0\t1\t2\t3\t0,5\t5\t6\t0,1\t0,2\t0,3\t60000\t\"a\tb\"\n"
    "2\t1\t2\t3,5\t1,5\t5\t6\t0,1\t0,2\t0,3\t60010\tx\n"
    "4\t1,5\t2\t4\t2,5\t5\t6\t0,1\t0,2\t0,3\t60020\t\n";
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  using namespace burrbench::data_schema;
  return expect_input_errors_only([&] {
    const Recording r = import::parse_csv_recording(kCsv, "fuzz.csv", as_text(data, size), "fuzz-map.toml");
    validate(r, "fuzz");  // what the importer returns must be a valid recording
  });
}
