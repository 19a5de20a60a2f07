#pragma once
// Per-Volume scratch space of the contact kernel: the lens table for the current (R, l)
// and the list of lens voxels collected in the first pass (reused by the friction and
// erosion pass, so no geometry is computed twice).
#include <cstdint>
#include <vector>

#include "burrbench/model/geometry.hpp"

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

struct Scratch {
  bool has_table = false;
  LensTable table;
  std::vector<LensVoxel> lens;
};

}  // namespace burrbench::model::detail
