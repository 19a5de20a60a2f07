#pragma once
// Per-Volume scratch space of the contact kernel: the lens table for the current (R, l)
// and the list of lens voxels collected in the first pass (reused by the friction and
// erosion pass, so no geometry is computed twice).
#include <cstdint>
#include <vector>

#include "burrbench/model/geometry.hpp"

namespace burrbench::model::detail {

struct LensVoxel {
  std::size_t index;
  double chi, area, lever_over_d, d2;
  double vx, vy, vz;  // v = c − p
  std::uint8_t label;
};

struct Scratch {
  bool has_table = false;
  LensTable table;
  std::vector<LensVoxel> lens;
};

}  // namespace burrbench::model::detail
