#pragma once
// The static loads of a sensor-pose measurement (format "burrbench.sensor_loads", TOML;
// docs/rig.md "Sensor pose"): known forces applied at known points of the rig, each with
// the tare file (`burrbench rig tare`) that averaged the sensor's reading under it, and the
// tare of the unloaded sensor.
#include <filesystem>
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::data_schema {

inline constexpr const char* kSensorLoadsFormat = "burrbench.sensor_loads";

struct SensorLoad {
  std::filesystem::path tare;      // resolved against the loads file's folder
  glm::dvec3 force_rig_N{0};       // mass_kg·g along gravity_rig, or force_rig_N as given
  glm::dvec3 point_rig_mm{0};
};

struct SensorLoads {
  std::filesystem::path file;
  std::filesystem::path unloaded;  // tare of the sensor without load
  std::vector<SensorLoad> loads;
};

// InputError naming the file and field on any defect (unknown keys, a load with both or
// neither of mass_kg and force_rig_N, a zero gravity direction, fewer than 2 loads).
SensorLoads read_sensor_loads(const std::filesystem::path& path);

}  // namespace burrbench::data_schema
