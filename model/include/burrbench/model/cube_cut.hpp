#pragma once
// A plane cutting a voxel's cube, in closed form (docs/model.md "The cube quadrature").
// The cube quadrature replaces the burr's sphere, inside a voxel it cuts, by its tangent
// plane on the ray from the burr centre p to the voxel centre c: with v = c − p, d = |v|,
// n̂ = v/d, the burr holds the part {u : n̂·u ≤ h} of the cube (u = x − c ∈ [−l/2, l/2]³),
// h = R − d. Everything here is an integral over that part or over its section
// {n̂·u = h} (the piece of the burr's surface inside the cube), from truncated power sums
// over the cube's corners (the B-spline form of a sum of three uniform variables).
#include <glm/glm.hpp>

namespace burrbench::model {

struct CubeCut {
  double volume_mm3 = 0;        // ΔV = |{n̂·u ≤ h}|
  double area_mm2 = 0;          // A = area of the section {n̂·u = h} (= ∂ΔV/∂h)
  double normal_moment_mm4 = 0; // μₙ = ∫ n̂·u dV over the part (its centroid's offset along n̂, × ΔV)
  // With derivatives only (the tangent pass and the tests):
  double area_dh_mm = 0;        // ∂A/∂h
  glm::dvec3 moment_mm4{0};     // ∫ u dV over the part
  glm::dvec3 section_mm3{0};    // ∫ u dA over the section
  glm::dvec3 section_dh_mm2{0}; // ∂/∂h of section_mm3
  // 1 per axis whose normal component is taken as is, 0 where it was raised to 1e-3 (the
  // cut does not change with it there; section_* are 0 on those axes).
  glm::dvec3 free_axes{1.0};
};

// n̂ a unit vector, l > 0. h ≤ −(l/2)‖n̂‖₁: empty; h ≥ (l/2)‖n̂‖₁: the whole cube. Normal
// components below 1e-3 in size are raised to 1e-3 (the error is O(10⁻⁶ l³) in volume,
// O(10⁻³ l) in the centroid; ΔV, A and μₙ stay continuous in n̂).
CubeCut cube_cut(const glm::dvec3& normal, double h_mm, double voxel_mm, bool derivatives);

// Gradients in v = c − p of a burr of radius R (h = R − |v|, n̂ = v/|v|), from a cut with
// derivatives (docs/model.md): ∇ΔV, ∇A and ∇m of the radial first moment m = ΔV·d + μₙ.
struct CubeCutGradient {
  glm::dvec3 volume{0}, area{0}, radial_moment{0};
};
CubeCutGradient cube_cut_gradient(const CubeCut& cut, const glm::dvec3& v_mm, double h_mm);

}  // namespace burrbench::model
