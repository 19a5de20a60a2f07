#pragma once
// Per-Volume scratch space of the contact kernel: the lens table for the current (R, l)
// and the list of lens voxels collected in the first pass (reused by the friction and
// erosion pass, so no geometry is computed twice).
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/model/geometry.hpp"
#include "burrbench/model/model_params.hpp"

namespace burrbench::model::detail {

// 56 bytes. d² and r/d from the first pass are kept, so the friction/erosion pass needs
// neither the distance nor a second lever lookup (only Δσ and 1/d, for voxels on the disc).
struct LensVoxel {
  double vx, vy, vz;     // v = c − p
  double d2, rd;         // |v|², r/d
  std::uint32_t index;   // linear voxel index (volumes are < 2³¹ voxels)
  std::uint8_t label;
  float chi;
};
static_assert(sizeof(LensVoxel) == 56);

// The cube quadrature's per-voxel surface data, beside its LensVoxel (same index): the
// cut's area A and 1/d (the lens takes both from its table).
struct CutArea {
  double area, inv_d;
};

// What the last contact evaluation derived from the moments, for the tangent pass of the
// forward sensitivities (sensitivity.cpp), which differentiates the same quantities.
struct KernelState {
  bool force = false;     // a contact normal and an elastic force exist
  bool cube = false;      // the cube quadrature made it (its voxels are in Scratch::lens and cut)
  double radius = 0, voxel = 0;
  bool friction = false;  // the friction pass ran (a² > 0, |F_e| > 0, |ω| > 0)
  glm::dvec3 p{0}, m1{0}, n{0}, w{0};  // centre, M₁, n̂, ω̂
  double M = 0, m1n = 0, b = 0, g = 0, c1_eff = 0, fe = 0, a2 = 0, p0 = 0, wn = 0;
  double inside_chi = 0;  // Σ χ of the fully-inside voxels (× inside volume = their mass)
  std::array<double, kMaxClasses> mass{}, kero{}, wmu{};
  std::size_t lens_count = 0;
};

// A row's run of fully-inside voxels (d ≤ R − η), x in [lo, hi].
struct InsideSpan {
  std::uint32_t row;  // y + ny·z
  std::int32_t lo, hi;
};

struct Scratch {
  bool has_table = false;
  LensTable table;
  std::vector<LensVoxel> lens;  // lens voxels, or the cube quadrature's cut voxels (rd = R/d)
  std::vector<CutArea> cut;     // cube quadrature: per entry of `lens`
  KernelState state;
  // While a tangent pass runs (TangentState), the first pass also lists the fully-inside
  // voxels it summed without geometry: their spans, and the few that rounding moved from a
  // lens span to the inside. The tangent pass needs them for voxels that were eroded
  // earlier and are now inside the burr.
  bool keep_inside = false;
  std::vector<InsideSpan> inside_spans;
  std::vector<std::uint32_t> inside_extra;
};

}  // namespace burrbench::model::detail
