#pragma once
// The HDF5 readers' fuzz targets: each input is an HDF5 file image, opened in memory
// through the core driver (H5Pset_fapl_core + H5Pset_file_image: data_schema's
// read_*_image), so no execution touches the disk. libhdf5 itself is not instrumented:
// coverage guides through our reader's checks, crashes anywhere are findings.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_file.hpp"

namespace burrbench::fuzz {

template <class Read>
int fuzz_h5_image(const std::uint8_t* data, std::size_t size, const char* name, Read read) {
  return expect_input_errors_only([&] { read(as_text(data, size), std::string(name)); });
}

}  // namespace burrbench::fuzz
