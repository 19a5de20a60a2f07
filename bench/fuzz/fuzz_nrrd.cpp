// libFuzzer target: the nrrd parser on bytes. A detached data file, if the header names
// one, is the part of the input after the marker (fuzz_split.hpp). InputError is the
// only acceptable outcome for bad input; anything else is a finding.
#include <string>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "fuzz_split.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::data_schema::import;
  const auto [header, detached] = burrbench::fuzz::split(data, size);
  const DataFileReader reader = [d = detached](const std::string& name) -> std::string {
    if (!d) throw burrbench::InputError("fuzz", "data file", "an in-memory data file", name);
    return std::string(*d);
  };
  ImportLimits lim;
  lim.max_bytes = std::size_t{64} << 20;  // stay far below libFuzzer's 2 GB RSS limit
  try {
    parse_nrrd(header, "fuzz", reader, lim);
  } catch (const burrbench::InputError&) {
  }
  return 0;
}
