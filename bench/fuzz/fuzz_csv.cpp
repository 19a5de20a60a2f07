// libFuzzer target: the CSV recording importer on bytes; a TOML column map, if any, is
// the part of the input after the marker (fuzz_split.hpp).
#include <string>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/csv_recording.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "fuzz_split.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::data_schema;
  const auto [csv, map] = burrbench::fuzz::split(data, size);
  try {
    const Recording r = import::parse_csv_recording(csv, "fuzz.csv", map, "fuzz.toml");
    validate(r, "fuzz");  // what the importer returns must be a valid recording
  } catch (const burrbench::InputError&) {
  }
  return 0;
}
