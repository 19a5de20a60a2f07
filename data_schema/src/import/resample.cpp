// Resampling to cubic voxels: trilinear for grey values and fractions, nearest for labels;
// and a segmented sample split or merged by an integer factor (solution verification).
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

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

namespace burrbench::data_schema::import {
namespace {

void check_factor(int n, const char* what) {
  if (n < 1 || n > 16) throw InputError("<resample>", what, "an integer factor in [1, 16]", std::to_string(n));
}

SampleVolume same_header(const SampleVolume& in) {
  SampleVolume out;
  out.classes = in.classes;
  out.sources = in.sources;
  out.segmentation_json = in.segmentation_json;
  out.provenance = in.provenance;
  return out;
}

void allocate(SampleVolume& out, const char* what) {
  const double count = double(out.dims[0]) * double(out.dims[1]) * double(out.dims[2]);
  if (count > double(kMaxSampleVoxels))
    throw InputError("<resample>", what, fmt::format("at most {} voxels (memory budget)", kMaxSampleVoxels),
                     fmt::format("{:.0f}", count));
  out.labels.assign(out.voxel_count(), kEmpty);
  out.fraction.assign(out.voxel_count(), 0.0f);
}

}  // namespace

SampleVolume split_voxels(const SampleVolume& in, int n) {
  check_factor(n, "split factor");
  const auto un = std::size_t(n);
  SampleVolume out = same_header(in);
  out.voxel_mm = in.voxel_mm / n;
  // Centre of the first sub-voxel: the old centre moved back by (n−1)/2 new voxels.
  out.origin_mm = in.origin_mm - glm::dvec3(0.5 * (n - 1) * out.voxel_mm);
  for (int a = 0; a < 3; ++a) out.dims[std::size_t(a)] = in.dims[std::size_t(a)] * un;
  allocate(out, "split factor");
  for (std::size_t z = 0; z < out.dims[2]; ++z)
    for (std::size_t y = 0; y < out.dims[1]; ++y)
      for (std::size_t x = 0; x < out.dims[0]; ++x) {
        const std::size_t src = in.index(x / un, y / un, z / un), dst = out.index(x, y, z);
        out.labels[dst] = in.labels[src];
        out.fraction[dst] = in.fraction[src];
      }
  return out;
}

SampleVolume merge_voxels(const SampleVolume& in, int n) {
  check_factor(n, "merge factor");
  const auto un = std::size_t(n);
  SampleVolume out = same_header(in);
  out.voxel_mm = in.voxel_mm * n;
  out.origin_mm = in.origin_mm + glm::dvec3(0.5 * (n - 1) * in.voxel_mm);
  for (int a = 0; a < 3; ++a) out.dims[std::size_t(a)] = (in.dims[std::size_t(a)] + un - 1) / un;
  allocate(out, "merge factor");
  const double cells = double(un * un * un);
  std::array<double, 256> bone{};
  for (std::size_t Z = 0; Z < out.dims[2]; ++Z)
    for (std::size_t Y = 0; Y < out.dims[1]; ++Y)
      for (std::size_t X = 0; X < out.dims[0]; ++X) {
        bone.fill(0.0);
        double total = 0;
        for (std::size_t z = Z * un; z < std::min(in.dims[2], (Z + 1) * un); ++z)
          for (std::size_t y = Y * un; y < std::min(in.dims[1], (Y + 1) * un); ++y)
            for (std::size_t x = X * un; x < std::min(in.dims[0], (X + 1) * un); ++x) {
              const std::size_t i = in.index(x, y, z);
              if (in.labels[i] == kEmpty) continue;
              bone[in.labels[i]] += double(in.fraction[i]);
              total += double(in.fraction[i]);
            }
        if (!(total > 0)) continue;
        std::size_t best = 1;
        for (std::size_t l = 2; l < bone.size(); ++l)
          if (bone[l] > bone[best]) best = l;
        const std::size_t o = out.index(X, Y, Z);
        out.labels[o] = std::uint8_t(best);
        out.fraction[o] = static_cast<float>(std::min(1.0, total / cells));
      }
  return out;
}

SampleVolume crop_voxels(const SampleVolume& in, const std::array<std::size_t, 3>& lo,
                         const std::array<std::size_t, 3>& hi) {
  for (std::size_t a = 0; a < 3; ++a)
    BURRBENCH_CHECK(lo[a] < hi[a] && hi[a] <= in.dims[a], "crop_voxels: a box inside the sample");
  SampleVolume out = same_header(in);
  out.voxel_mm = in.voxel_mm;
  out.origin_mm = in.origin_mm + in.voxel_mm * glm::dvec3(double(lo[0]), double(lo[1]), double(lo[2]));
  for (std::size_t a = 0; a < 3; ++a) out.dims[a] = hi[a] - lo[a];
  allocate(out, "crop");
  for (std::size_t z = 0; z < out.dims[2]; ++z)
    for (std::size_t y = 0; y < out.dims[1]; ++y) {
      const std::size_t src = in.index(lo[0], lo[1] + y, lo[2] + z), dst = out.index(0, y, z);
      std::copy_n(in.labels.begin() + std::ptrdiff_t(src), out.dims[0], out.labels.begin() + std::ptrdiff_t(dst));
      std::copy_n(in.fraction.begin() + std::ptrdiff_t(src), out.dims[0], out.fraction.begin() + std::ptrdiff_t(dst));
    }
  return out;
}

}  // namespace burrbench::data_schema::import
