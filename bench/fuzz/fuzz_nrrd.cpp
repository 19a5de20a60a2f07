// libFuzzer target: the nrrd parser on bytes (fuzz_split.hpp: a detached data file
// follows the marker). InputError is the only acceptable outcome for bad input.
#include "fuzz_split.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return burrbench::fuzz::fuzz_volume_parser(data, size, burrbench::data_schema::import::parse_nrrd);
}
