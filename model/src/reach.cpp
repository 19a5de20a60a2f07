#include "burrbench/model/reach.hpp"

#include <algorithm>
#include <cmath>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/geometry.hpp"

namespace burrbench::model {

std::optional<VoxelBox> reach_box(const data_schema::SampleVolume& s, const Trajectory& tr,
                                  double radius_mm, double margin_mm) {
  if (tr.centre_vol_mm.empty()) return std::nullopt;
  VoxelBox box;
  glm::dvec3 lo = tr.centre_vol_mm.front(), hi = lo;
  for (const auto& p : tr.path_centres_vol_mm()) {  // the vias too: the burr erodes there
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  // One voxel more than R + η: the box is in whole voxels, and rounding must not drop one.
  const double grow = radius_mm + voxel_sphere_radius(s.voxel_mm) + margin_mm + s.voxel_mm;
  // Whole rows along x (volume.hpp: what keeps a replay on the cut bit-identical).
  box.lo[0] = 0;
  box.hi[0] = s.dims[0];
  for (int a = 1; a < 3; ++a) {
    const double n = double(s.dims[std::size_t(a)]);
    // Voxel i's centre lies at origin + i·l.
    const double u0 = std::floor((lo[a] - grow - s.origin_mm[a]) / s.voxel_mm);
    const double u1 = std::ceil((hi[a] + grow - s.origin_mm[a]) / s.voxel_mm) + 1;
    if (!(std::isfinite(u0) && std::isfinite(u1)) || u1 <= 0 || u0 >= n) return std::nullopt;
    box.lo[std::size_t(a)] = std::size_t(std::max(0.0, u0));
    box.hi[std::size_t(a)] = std::size_t(std::min(n, u1));
  }
  return box;
}

VoxelBox replay_box(const data_schema::SampleVolume& s, const Trajectory& tr, double radius_mm) {
  return reach_box(s, tr, radius_mm).value_or(VoxelBox{{0, 0, 0}, {s.dims[0], 1, 1}});
}

Volume& ReachVolumes::for_replay(const std::string& id, const Trajectory& tr, double radius_mm) {
  const data_schema::SampleVolume& s = samples_.at(id);
  auto it = volumes_.find(id);
  const std::optional<VoxelBox> reach = reach_box(s, tr, radius_mm);
  // A path that reaches no voxel replays on any volume: the one held, else the first row.
  if (it != volumes_.end() && (!reach || it->second.box().contains(*reach))) return it->second.volume;
  VoxelBox box = replay_box(s, tr, radius_mm);
  if (reach) {
    // Grown by the burr's radius: lags, depth offsets and pose corrections move the path
    // by less, so a calibration cuts each volume once or twice, not at every trial point.
    // The hull with the cut held keeps both paths' rows when recordings alternate.
    box = reach_box(s, tr, radius_mm, std::max(radius_mm, 4 * s.voxel_mm)).value_or(*reach).hull(*reach);
    if (it != volumes_.end() && it->second.reaches) box = box.hull(it->second.box());
  }
  ++builds_;
  if (it == volumes_.end()) it = volumes_.emplace(id, Held{}).first;
  BURRBENCH_CHECK(!it->second.volume.undo_active(), "volume cut again in the middle of a replay");
  it->second.volume = Volume();  // free the old cut before the new one is made
  it->second.volume = Volume::from_sample(s, box);
  it->second.reaches = reach.has_value();
  return it->second.volume;
}

}  // namespace burrbench::model
