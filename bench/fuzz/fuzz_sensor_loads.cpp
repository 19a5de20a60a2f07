// libFuzzer target: read_sensor_loads (the static loads `rig sensor-pose` fits the sensor's
// rotation and origin from).
#include "burrbench/data_schema/sensor_loads.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("loads.toml", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::data_schema::read_sensor_loads(path); });
}
