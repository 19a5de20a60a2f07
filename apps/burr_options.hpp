#pragma once
// The operator and the burr of a session, stated on the command line of `acquire` and of
// `recording import` and stored in the recording's metadata, where `inspect` shows them
// and the replay checks them against the manifest's [burr] (docs/formats.md). Checked up
// front, not after the session or the import: a tilted burr must not pass as [0, 0, 1].
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <glm/glm.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/recording.hpp"

namespace burrbench::apps {

struct BurrOptions {
  std::string operator_name;
  double radius_mm = 0;      // 0: not stated
  std::vector<double> axis;  // empty: not stated
  int spin = 0;              // 0: not stated
  CLI::Option* spin_option = nullptr;

  void add_to(CLI::App* cmd) {
    cmd->add_option("--operator", operator_name, "operator stored in the metadata");
    cmd->add_option("--burr-radius-mm", radius_mm, "burr radius stored in the metadata (0 = unknown)");
    cmd->add_option("--burr-axis", axis, "burr shaft axis in the rig frame, 3 numbers (normalised; default: not stated)")
        ->expected(3);
    spin_option = cmd->add_option(
        "--spin", spin, "spin sign: +1 counter-clockwise about --burr-axis, -1 clockwise (default: not stated)");
  }

  // Checks the options (InputError naming the option) and writes them into `meta`.
  void apply(data_schema::RecordingMeta& meta) const {
    if (!std::isfinite(radius_mm) || radius_mm < 0)
      throw InputError("command line", "--burr-radius-mm", "a radius ≥ 0 mm (0 = unknown)", fmt::format("{}", radius_mm));
    const glm::dvec3 a = axis.empty() ? glm::dvec3(0) : glm::dvec3(axis[0], axis[1], axis[2]);
    const double len = glm::length(a);
    if (!axis.empty() && (!std::isfinite(len) || len < 1e-9))
      throw InputError("command line", "--burr-axis", "a non-zero finite vector (x y z)", fmt::format("{} {} {}", a.x, a.y, a.z));
    if (spin_option && spin_option->count() > 0 && spin != 1 && spin != -1)
      throw InputError("command line", "--spin", "+1 or -1", std::to_string(spin));
    meta.operator_name = operator_name;
    meta.burr_radius_mm = radius_mm;
    meta.burr_axis_rig = axis.empty() ? a : a / len;
    meta.spin_sign = spin;
  }
};

}  // namespace burrbench::apps
