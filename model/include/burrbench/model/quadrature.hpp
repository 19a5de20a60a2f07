#pragma once
// Which quadrature of MODEL.md's continuum integrals the contact kernel takes
// (docs/model.md "The cube quadrature"): the paper's lens (each voxel a sphere of equal
// volume) or the cube (a voxel the burr's surface cuts is its cube cut by the burr's
// tangent plane).
#include <optional>
#include <string>
#include <string_view>

namespace burrbench::model {

enum class Quadrature { kLens, kCube };

inline const char* quadrature_name(Quadrature q) { return q == Quadrature::kCube ? "cube" : "lens"; }
inline std::optional<Quadrature> parse_quadrature(std::string_view s) {
  if (s == "lens") return Quadrature::kLens;
  if (s == "cube") return Quadrature::kCube;
  return std::nullopt;
}

}  // namespace burrbench::model
