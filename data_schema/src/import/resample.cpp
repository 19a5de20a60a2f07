// Resampling to cubic voxels: trilinear for grey values and fractions, nearest for labels.
#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "import/volume_decode.hpp"

namespace burrbench::data_schema::import {

ImageVolume resample_cubic(const ImageVolume& in, double voxel_mm, Interpolation interp, const ImportLimits& lim) {
  if (!(voxel_mm > 0) || !std::isfinite(voxel_mm)) throw InputError("<resample>", "voxel_mm", "a positive voxel size", fmt::format("{}", voxel_mm));
  ImageVolume out;
  out.source_type = in.source_type;
  out.origin_mm = in.origin_mm;
  out.spacing_mm = glm::dvec3(voxel_mm);
  glm::dvec3 step{};  // output index step in input index units
  for (int a = 0; a < 3; ++a) {
    const auto ua = static_cast<std::size_t>(a);
    const double span = in.spacing_mm[a] * double(in.dims[ua] - 1);
    // 1e-9: a span that is an exact multiple of the voxel must keep its last voxel.
    const double n = std::floor(span / voxel_mm + 1e-9) + 1;
    if (n > 1e12) throw InputError("<resample>", "voxel_mm", "a voxel size giving a volume within the memory budget");
    out.dims[ua] = static_cast<std::size_t>(n);
    step[a] = voxel_mm / in.spacing_mm[a];
  }
  const std::size_t count = detail::checked_voxel_count(out.dims, VoxelType::kFloat32, lim, "<resample>", "voxel_mm");
  out.values.resize(count);
  auto at = [&](std::size_t x, std::size_t y, std::size_t z) { return in.values[in.index(x, y, z)]; };
  std::size_t o = 0;
  for (std::size_t k = 0; k < out.dims[2]; ++k) {
    for (std::size_t j = 0; j < out.dims[1]; ++j) {
      for (std::size_t i = 0; i < out.dims[0]; ++i, ++o) {
        const glm::dvec3 u = glm::dvec3(double(i), double(j), double(k)) * step;
        if (interp == Interpolation::kNearest) {
          std::array<std::size_t, 3> n{};
          for (int a = 0; a < 3; ++a) {
            n[static_cast<std::size_t>(a)] = std::min(static_cast<std::size_t>(std::llround(u[a])), in.dims[static_cast<std::size_t>(a)] - 1);
          }
          out.values[o] = at(n[0], n[1], n[2]);
          continue;
        }
        std::array<std::size_t, 3> lo{}, hi{};
        glm::dvec3 w{};
        for (int a = 0; a < 3; ++a) {
          const auto ua = static_cast<std::size_t>(a);
          const double c = std::min(u[a], double(in.dims[ua] - 1));
          lo[ua] = static_cast<std::size_t>(std::floor(c));
          hi[ua] = std::min(lo[ua] + 1, in.dims[ua] - 1);
          w[a] = c - double(lo[ua]);
        }
        double acc = 0;
        for (int c = 0; c < 8; ++c) {
          const std::size_t x = (c & 1) ? hi[0] : lo[0], y = (c & 2) ? hi[1] : lo[1], z = (c & 4) ? hi[2] : lo[2];
          const double wt = ((c & 1) ? w.x : 1 - w.x) * ((c & 2) ? w.y : 1 - w.y) * ((c & 4) ? w.z : 1 - w.z);
          if (wt != 0) acc += wt * at(x, y, z);
        }
        out.values[o] = static_cast<float>(acc);
      }
    }
  }
  return out;
}

}  // namespace burrbench::data_schema::import
