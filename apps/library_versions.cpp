#include "library_versions.hpp"

#include <ceres/version.h>
#include <fmt/format.h>
#include <modbus/modbus-version.h>
#include <opencv2/core/utility.hpp>

// HDF5's own header would bring its macros into this file; its one C function suffices.
extern "C" int H5get_libversion(unsigned* majnum, unsigned* minnum, unsigned* relnum);

namespace burrbench::apps {

std::vector<std::pair<std::string, std::string>> library_versions() {
  unsigned a = 0, b = 0, c = 0;
  H5get_libversion(&a, &b, &c);
  return {{"Ceres Solver", CERES_VERSION_STRING},
          {"libmodbus", LIBMODBUS_VERSION_STRING},
          {"OpenCV", cv::getVersionString()},
          {"HDF5", fmt::format("{}.{}.{}", a, b, c)}};
}

}  // namespace burrbench::apps
