#pragma once
// 3-D box filters and box morphology built from OpenCV's 2-D ones (per z slice) plus a
// pass along z. Volumes are x-fastest, dims {nx, ny, nz}.
#include <array>
#include <cstdint>
#include <vector>

namespace burrbench::data_schema::import::detail {

using Dims = std::array<std::size_t, 3>;

// The number of set voxels of a 0/1 mask in the (2r+1)³ box around each voxel, zero
// outside the volume. Exact: every partial sum is an integer ≤ 201³ < 2²⁴. Uses 4 bytes
// per voxel (the result) and r + 2 planes, not a float copy of the mask (a lab CT).
std::vector<float> box_count(const std::vector<std::uint8_t>& m, const Dims& d, int r);
// Binary (0/1) erosion/dilation with a (2r+1)³ box; outside the volume never erodes
// and never dilates.
std::vector<std::uint8_t> dilate(const std::vector<std::uint8_t>& m, const Dims& d, int r);
std::vector<std::uint8_t> erode(const std::vector<std::uint8_t>& m, const Dims& d, int r);
inline std::vector<std::uint8_t> open(const std::vector<std::uint8_t>& m, const Dims& d, int r) {
  return r > 0 ? dilate(erode(m, d, r), d, r) : m;
}
inline std::vector<std::uint8_t> close(const std::vector<std::uint8_t>& m, const Dims& d, int r) {
  return r > 0 ? erode(dilate(m, d, r), d, r) : m;
}

}  // namespace burrbench::data_schema::import::detail
