// A slice stack hands OpenCV only files with a TIFF or PNG signature (BMP too for SkyScan):
// OpenCV picks its decoder by content, and a ".tif" with "DICM" at byte 128 reached GDCM,
// whose assert aborted the process (bench/fuzz.sh, fuzz_slices, issue 59). The command
// line routes such a folder to the DICOM reader first; the library call must not crash.
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"

namespace fs = std::filesystem;
using burrbench::InputError;
using burrbench::data_schema::import::read_slice_stack;

TEST(SliceSignature, AFileWithoutATiffOrPngSignatureIsBadInputNotACrash) {
  const fs::path d = fs::temp_directory_path() / ("burrbench_slice_sig_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  {
    // The fuzzer's find, cut to its essence: no image signature, "DICM" at byte 128.
    std::ofstream f(d / "s1.tif", std::ios::binary);
    f << std::string(128, '\0') << "DICM" << std::string("\xf0\x00\x02\x01", 4);
  }
  try {
    read_slice_stack(d, {0.1, 0.1, 0.1}, {0, 0, 0});
    ADD_FAILURE() << "read a slice with no image signature";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("s1.tif"), std::string::npos) << what;
    EXPECT_NE(what.find("a TIFF or PNG file"), std::string::npos) << what;
  }
  fs::remove_all(d);
}
