#include "burrbench/data_schema/sensor_loads.hpp"

#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"
#include "burrbench/data_schema/format_version.hpp"

namespace burrbench::data_schema {

SensorLoads read_sensor_loads(const std::filesystem::path& path) {
  const std::string file = path.string();
  const toml::table root = parse_toml_file(path);
  const TomlView v(root, file, "", "docs/rig.md");
  check_format(file, "format", v.str("format"), kSensorLoadsFormat);
  check_version(file, "format_version", v.str("format_version"), 1);
  const auto base = path.parent_path();
  SensorLoads out;
  out.file = path;
  out.unloaded = base / v.str("unloaded");
  const glm::dvec3 down = v.has("gravity_rig") ? v.vec3("gravity_rig") : glm::dvec3(0, 0, -1);
  if (!(glm::length(down) > 0)) throw InputError(file, "gravity_rig", "a non-zero direction (rig frame)");
  const double g = v.has("g_m_s2") ? v.positive("g_m_s2") : 9.80665;
  auto loads = v.tables("loads");
  for (std::size_t i = 0; i < loads.size(); ++i) {
    auto& l = loads[i];
    SensorLoad s;
    s.tare = base / l.str("tare");
    s.point_rig_mm = l.vec3("point_rig_mm");
    const bool mass = l.has("mass_kg"), force = l.has("force_rig_N");
    if (mass == force)
      throw InputError(file, fmt::format("loads[{}]", i), "exactly one of mass_kg (hung along gravity_rig) or force_rig_N",
                       mass ? "both" : "neither");
    s.force_rig_N = mass ? l.positive("mass_kg") * g * glm::normalize(down) : l.vec3("force_rig_N");
    if (!(glm::length(s.force_rig_N) > 0)) throw InputError(file, fmt::format("loads[{}].force_rig_N", i), "a non-zero force");
    l.done();
    out.loads.push_back(s);
  }
  if (out.loads.size() < 2)
    throw InputError(file, "loads", "at least 2 [[loads]] (3 or more, one of them sideways, recommended)",
                     std::to_string(out.loads.size()));
  v.done();
  return out;
}

}  // namespace burrbench::data_schema
