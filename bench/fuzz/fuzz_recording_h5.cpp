// libFuzzer target: read_recording on an HDF5 file image in memory (fuzz_h5.hpp).
#include "burrbench/data_schema/recording.hpp"
#include "fuzz_h5.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return burrbench::fuzz::fuzz_h5_image(data, size, "fuzz-recording.h5", burrbench::data_schema::read_recording_image);
}
