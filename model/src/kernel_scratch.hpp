#pragma once
// Per-Volume scratch space of the contact kernel: the lens table for the current (R, l)
// and the list of lens voxels collected in the first pass (reused by the friction and
// erosion pass, so no geometry is computed twice).
#include <cstdint>
#include <vector>

#include "burrbench/model/geometry.hpp"

namespace burrbench::model::detail {

// 32 bytes, so even the ~6000 lens voxels of a buried micro-CT burr stay in cache; the
// table entry is looked up again in the second pass (cheaper than storing it).
struct LensVoxel {
  double vx, vy, vz;     // v = c − p
  std::uint32_t index;   // linear voxel index (volumes are < 2³¹ voxels)
  std::uint8_t label;
  std::uint8_t pad[3];
  float chi;
};
static_assert(sizeof(LensVoxel) == 40 || sizeof(LensVoxel) == 32);

struct Scratch {
  bool has_table = false;
  LensTable table;
  std::vector<LensVoxel> lens;
};

}  // namespace burrbench::model::detail
