#pragma once
// The part of a sample a replay can touch. The kernel only reads voxels whose centre lies
// within R + η of the burr's centre, and between samples the centre moves on straight
// lines, so a replay of a trajectory needs only the box around its centres grown by R + η.
// A lab's CT block is mostly bone the burr never comes near: replaying on that box alone
// gives the same results, bit for bit (volume.hpp), without copying the whole block into
// every worker, nor a tangent slot per voxel of it in a sensitivity replay. docs/model.md
// "Memory".
#include <map>
#include <optional>
#include <string>

#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::model {

// The rows (along x, whole) holding every voxel within radius_mm + η + margin_mm of any
// centre of `tr` (its vias too), clamped to the grid; none when no voxel is in reach (an empty path, or
// one wholly outside the sample): any volume then replays as the whole sample does.
std::optional<VoxelBox> reach_box(const data_schema::SampleVolume& sample, const Trajectory& tr,
                                  double radius_mm, double margin_mm = 0);
// reach_box, or the sample's first row when nothing is in reach: a volume to replay on.
VoxelBox replay_box(const data_schema::SampleVolume& sample, const Trajectory& tr, double radius_mm);

// One worker's volumes, each cut to what the replays it was asked for can reach. A
// trajectory beyond the box (another lag, depth offset or pose) rebuilds it from the
// sample, grown by a margin, so the next small change does not. The samples must outlive
// this; the volumes are at their scanned state whenever a replay restored them.
class ReachVolumes {
 public:
  explicit ReachVolumes(const std::map<std::string, data_schema::SampleVolume>& samples)
      : samples_(samples) {}
  // The volume of sample `id` holding every voxel a replay of `tr` can touch.
  Volume& for_replay(const std::string& id, const Trajectory& tr, double radius_mm);
  std::size_t builds() const { return builds_; }  // volumes cut so far (tests, benches)

 private:
  struct Held {
    Volume volume;
    bool reaches = false;  // cut for a path in reach (else the placeholder first row)
    const VoxelBox& box() const { return volume.box(); }
  };
  const std::map<std::string, data_schema::SampleVolume>& samples_;
  std::map<std::string, Held> volumes_;
  std::size_t builds_ = 0;
};

}  // namespace burrbench::model
