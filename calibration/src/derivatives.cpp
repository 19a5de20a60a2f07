#include "burrbench/calibration/derivatives.hpp"

#include "burrbench/data_schema/error.hpp"

namespace burrbench::calibration {

const char* to_string(Derivatives d) {
  switch (d) {
    case Derivatives::kSensitivities: return "sensitivities";
    case Derivatives::kFiniteDifferences: return "fd";
  }
  BURRBENCH_UNREACHABLE();
}

}  // namespace burrbench::calibration
