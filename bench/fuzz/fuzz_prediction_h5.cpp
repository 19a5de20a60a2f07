// libFuzzer target: read_prediction on an HDF5 file image in memory (fuzz_h5.hpp).
#include "burrbench/data_schema/prediction.hpp"
#include "fuzz_h5.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return burrbench::fuzz::fuzz_h5_image(data, size, "fuzz-prediction.h5", burrbench::data_schema::read_prediction_image);
}
