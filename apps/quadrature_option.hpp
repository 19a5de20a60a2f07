#pragma once
// `--quadrature lens|cube` (replay, verify): the contact kernel's quadrature
// (model/quadrature.hpp, docs/model.md "The cube quadrature").
#include <string>

#include <CLI/CLI.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/quadrature.hpp"

namespace burrbench::apps {

inline void add_quadrature_option(CLI::App* cmd, std::string& value) {
  cmd->add_option("--quadrature", value,
                  "contact quadrature: lens (the paper's voxel spheres) or cube (cut voxels as cubes cut by the "
                  "burr's tangent plane; docs/model.md)")
      ->capture_default_str();
}

inline model::Quadrature quadrature_option(const std::string& value) {
  if (const auto q = model::parse_quadrature(value)) return *q;
  throw InputError("command line", "--quadrature", "lens or cube", value);
}

}  // namespace burrbench::apps
