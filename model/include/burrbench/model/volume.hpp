#pragma once
// The in-memory sample the burr works on: per voxel a class label (uint8, < kMaxClasses)
// and a bone fraction χ ∈ [0,1] kept as float plus a float remainder, so decrements far
// below float resolution accumulate instead of stalling. An undo log records the first
// change of each voxel after begin_undo(), so repeated replays restore the start state
// without copying the volume. Per-row occupancy bounds let the kernel skip empty space.
//
// Plain data: the kernel's working space is the caller's (contact.hpp, KernelScratch), so
// copies are member-wise and threads may evaluate one Volume side by side (each with its
// own scratch); step() and the undo log change it and need it to themselves.
#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/geometry.hpp"
#include "burrbench/model/model_params.hpp"

namespace burrbench::model {

// A box of a sample's voxel grid: indices lo ≤ i < hi per axis (x, y, z).
struct VoxelBox {
  std::array<std::size_t, 3> lo{0, 0, 0}, hi{0, 0, 0};
  static VoxelBox whole(const std::array<std::size_t, 3>& dims) { return {{0, 0, 0}, dims}; }
  bool contains(const VoxelBox& b) const {
    for (int a = 0; a < 3; ++a)
      if (b.lo[a] < lo[a] || b.hi[a] > hi[a]) return false;
    return true;
  }
  VoxelBox hull(const VoxelBox& b) const {
    VoxelBox h;
    for (int a = 0; a < 3; ++a) {
      h.lo[a] = std::min(lo[a], b.lo[a]);
      h.hi[a] = std::max(hi[a], b.hi[a]);
    }
    return h;
  }
  std::size_t voxel_count() const {
    std::size_t n = 1;
    for (int a = 0; a < 3; ++a) n *= hi[a] > lo[a] ? hi[a] - lo[a] : 0;
    return n;
  }
  bool operator==(const VoxelBox&) const = default;
};

class Volume {
 public:
  // Labels ≥ kMaxClasses, χ outside [0,1] or NaN, bad dims/voxel size → InputError.
  // χ of label-0 voxels is taken as 0 (label 0 is empty by definition).
  static Volume from_sample(const data_schema::SampleVolume&);
  // Only the voxels of `box`: whole rows along x (lo.x = 0, hi.x = nx) over a non-empty
  // range of y and z within the grid. A replay that never comes within reach of the rest
  // gives bit-identical results at a fraction of the memory (reach.hpp picks the box):
  // the kernel places each voxel by its index in the sample's grid, and x, the axis its
  // sums run along, is not cut. Indices are local to the box; origin_mm() is the centre
  // of the box's first voxel, grid_origin_mm() the sample's.
  static Volume from_sample(const data_schema::SampleVolume&, const VoxelBox& box);
  // The paper's 8-bit counter: χ = n/255.
  static Volume from_counters(std::array<std::size_t, 3> dims, double voxel_mm,
                              glm::dvec3 origin_mm, std::vector<std::uint8_t> labels,
                              const std::vector<std::uint8_t>& counters);
  // Current (possibly eroded) state; classes/sources/provenance copied from the import.
  data_schema::SampleVolume to_sample() const;
  std::vector<std::uint8_t> to_counters() const;  // round(255·χ)

  const std::array<std::size_t, 3>& dims() const { return dims_; }
  double voxel_mm() const { return l_; }
  const glm::dvec3& origin_mm() const { return origin_; }
  const glm::dvec3& grid_origin_mm() const { return grid_origin_; }
  // The part of the sample's grid this volume holds (the whole grid unless cut).
  const VoxelBox& box() const { return box_; }
  std::size_t voxel_count() const { return labels_.size(); }
  std::size_t index(std::size_t x, std::size_t y, std::size_t z) const {
    return x + dims_[0] * (y + dims_[1] * z);
  }
  std::uint8_t label(std::size_t i) const { return labels_[i]; }
  double chi(std::size_t i) const { return double(chi_[i]) + double(chi_lo_[i]); }
  // Sets χ (clamped to [0,1]); recorded in the undo log when active.
  void set_chi(std::size_t i, double chi);
  // Removes dchi ≥ 0 (clamped at 0); returns the amount actually removed.
  double erode(std::size_t i, double dchi) {
    const double old = double(chi_[i]) + double(chi_lo_[i]);
    double now = old - dchi;
    if (now < 0) now = 0;
    if (undo_on_ && !(touched_[i >> 6] & (std::uint64_t(1) << (i & 63)))) log_first_touch(i);
    const float hi = static_cast<float>(now);
    chi_[i] = hi;
    chi_lo_[i] = static_cast<float>(now - double(hi));
    return old - (double(hi) + double(chi_lo_[i]));
  }
  // Bone volume l³·Σχ per class label (mm³); of a cut volume, with the scan's bone
  // outside its box.
  std::array<double, kMaxClasses> bone_volume_by_class() const;

  // Undo log: begin_undo() starts recording (clears a previous log); rollback() restores
  // every voxel changed since to its exact prior bits and ends recording; commit_undo()
  // keeps the changes and ends recording.
  void begin_undo();
  void rollback();
  void commit_undo();
  bool undo_active() const { return undo_on_; }
  std::size_t undo_entries() const { return undo_.size(); }

  // Kernel access (row-major, x fastest).
  const float* chi_data() const { return chi_.data(); }
  const std::uint8_t* label_data() const { return labels_.data(); }
  // Occupied x-range [lo, hi] of row (y,z); lo > hi when the row never held bone.
  // Computed at import; erosion only lowers χ, so the range stays a valid superset.
  std::int32_t row_lo(std::size_t row) const { return row_lo_[row]; }
  std::int32_t row_hi(std::size_t row) const { return row_hi_[row]; }
  // Label of every occupied voxel of the row when they all share one, else 0.
  std::uint8_t row_label(std::size_t row) const { return row_label_[row]; }
  // Occupied y-range [lo, hi] of layer z (rows holding any label); lo > hi when empty.
  // Lets the kernel skip empty layers and rows above a surface without visiting them.
  std::int32_t layer_lo(std::size_t z) const { return layer_lo_[z]; }
  std::int32_t layer_hi(std::size_t z) const { return layer_hi_[z]; }

 private:
  void log_first_touch(std::size_t i);
  void build_rows();

  std::array<std::size_t, 3> dims_{0, 0, 0};
  double l_ = 0;
  glm::dvec3 origin_{0}, grid_origin_{0};
  VoxelBox box_;
  std::array<double, kMaxClasses> outside_chi_{};  // Σχ per label outside box_ (scan)
  std::vector<std::uint8_t> labels_;
  std::vector<float> chi_, chi_lo_;
  std::vector<std::int32_t> row_lo_, row_hi_, layer_lo_, layer_hi_;
  std::vector<std::uint8_t> row_label_;
  struct UndoEntry { std::size_t i; float hi, lo; };
  std::vector<UndoEntry> undo_;
  std::vector<std::uint64_t> touched_;  // bitset of voxels already in undo_
  bool undo_on_ = false;
  std::map<std::uint8_t, std::string> classes_;
  std::vector<InputFile> sources_;
  std::string segmentation_json_;
  Provenance provenance_;
};

}  // namespace burrbench::model
