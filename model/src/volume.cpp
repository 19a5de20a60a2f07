#include "burrbench/model/volume.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::model {

namespace {
// 2³¹ voxels (8 GiB of labels+χ): far beyond any sample; refuse before allocating.
constexpr std::size_t kMaxVoxels = std::size_t(1) << 31;

void check_grid(std::array<std::size_t, 3> dims, double voxel_mm, glm::dvec3 origin,
                const std::string& file) {
  for (int a = 0; a < 3; ++a)
    if (dims[a] == 0 || dims[a] > (std::size_t(1) << 20))
      throw InputError(file, "dims", "1..2^20 voxels per axis", std::to_string(dims[a]));
  if (dims[0] * dims[1] > kMaxVoxels || dims[0] * dims[1] * dims[2] > kMaxVoxels)
    throw InputError(file, "dims", "at most 2^31 voxels in total");
  if (!(voxel_mm > 0) || !std::isfinite(voxel_mm))
    throw InputError(file, "voxel_mm", "finite voxel size > 0 mm", std::to_string(voxel_mm));
  if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.z))
    throw InputError(file, "origin_mm", "finite coordinates");
}
}  // namespace

Volume Volume::from_sample(const data_schema::SampleVolume& s) {
  return from_sample(s, VoxelBox::whole(s.dims));
}

Volume Volume::from_sample(const data_schema::SampleVolume& s, const VoxelBox& box) {
  const std::string file = "sample volume";
  check_grid(s.dims, s.voxel_mm, s.origin_mm, file);
  const std::size_t n = s.voxel_count();
  if (s.labels.size() != n)
    throw InputError(file, "labels", std::to_string(n) + " values",
                     std::to_string(s.labels.size()));
  if (s.fraction.size() != n)
    throw InputError(file, "fraction", std::to_string(n) + " values",
                     std::to_string(s.fraction.size()));
  BURRBENCH_CHECK(box.voxel_count() > 0 && VoxelBox::whole(s.dims).contains(box) && box.lo[0] == 0 &&
                      box.hi[0] == s.dims[0],
                  "voxel box outside the sample's grid, or not of whole rows along x");
  Volume v;
  v.box_ = box;
  for (int a = 0; a < 3; ++a) v.dims_[a] = box.hi[a] - box.lo[a];
  v.l_ = s.voxel_mm;
  v.grid_origin_ = s.origin_mm;
  v.origin_ = s.origin_mm + s.voxel_mm * glm::dvec3(0.0, double(box.lo[1]), double(box.lo[2]));
  if (box != VoxelBox::whole(s.dims))
    for (std::size_t z = 0; z < s.dims[2]; ++z)
      for (std::size_t y = 0; y < s.dims[1]; ++y) {
        if (z >= box.lo[2] && z < box.hi[2] && y >= box.lo[1] && y < box.hi[1]) continue;
        for (std::size_t j = s.index(0, y, z), x = 0; x < s.dims[0]; ++x, ++j)
          if (s.labels[j] != 0 && s.labels[j] < kMaxClasses) v.outside_chi_[s.labels[j]] += double(s.fraction[j]);
      }
  const std::size_t nx = v.dims_[0], m = box.voxel_count();
  v.labels_.resize(m);
  v.chi_.resize(m);
  v.chi_lo_.assign(m, 0.0f);
  std::size_t i = 0;  // index in the box; j in the sample
  for (std::size_t z = box.lo[2]; z < box.hi[2]; ++z)
    for (std::size_t y = box.lo[1]; y < box.hi[1]; ++y)
      for (std::size_t j = box.lo[0] + s.dims[0] * (y + s.dims[1] * z), x = 0; x < nx; ++x, ++i, ++j) {
        const std::uint8_t label = s.labels[j];
        if (label >= kMaxClasses)
          throw InputError(file, "labels[" + std::to_string(j) + "]",
                           "class label 0.." + std::to_string(kMaxClasses - 1),
                           std::to_string(int(label)));
        const float f = s.fraction[j];
        if (!(f >= 0.0f && f <= 1.0f))
          throw InputError(file, "fraction[" + std::to_string(j) + "]", "bone fraction in [0,1]",
                           std::to_string(f));
        v.labels_[i] = label;
        v.chi_[i] = label == 0 ? 0.0f : f;  // label 0 is empty by definition
      }
  v.classes_ = s.classes;
  v.sources_ = s.sources;
  v.segmentation_json_ = s.segmentation_json;
  v.provenance_ = s.provenance;
  v.build_rows();
  return v;
}

Volume Volume::from_counters(std::array<std::size_t, 3> dims, double voxel_mm,
                             glm::dvec3 origin_mm, std::vector<std::uint8_t> labels,
                             const std::vector<std::uint8_t>& counters) {
  const std::string file = "8-bit volume";
  check_grid(dims, voxel_mm, origin_mm, file);
  const std::size_t n = dims[0] * dims[1] * dims[2];
  if (counters.size() != n)
    throw InputError(file, "counters", std::to_string(n) + " values",
                     std::to_string(counters.size()));
  data_schema::SampleVolume s;
  s.dims = dims;
  s.voxel_mm = voxel_mm;
  s.origin_mm = origin_mm;
  s.labels = std::move(labels);
  s.fraction.resize(n);
  for (std::size_t i = 0; i < n; ++i) s.fraction[i] = float(counters[i]) / 255.0f;
  return from_sample(s);
}

data_schema::SampleVolume Volume::to_sample() const {
  data_schema::SampleVolume s;
  s.dims = dims_;
  s.voxel_mm = l_;
  s.origin_mm = origin_;
  s.labels = labels_;
  s.fraction.resize(chi_.size());
  for (std::size_t i = 0; i < chi_.size(); ++i) s.fraction[i] = float(chi(i));
  s.classes = classes_;
  s.sources = sources_;
  s.segmentation_json = segmentation_json_;
  s.provenance = provenance_;
  return s;
}

std::vector<std::uint8_t> Volume::to_counters() const {
  std::vector<std::uint8_t> c(chi_.size());
  for (std::size_t i = 0; i < chi_.size(); ++i)
    c[i] = static_cast<std::uint8_t>(std::lround(std::clamp(chi(i), 0.0, 1.0) * 255.0));
  return c;
}

void Volume::set_chi(std::size_t i, double value) {
  BURRBENCH_CHECK(i < chi_.size(), "voxel index out of range");
  if (labels_[i] == 0) value = 0;
  value = std::clamp(value, 0.0, 1.0);
  if (undo_on_) log_first_touch(i);
  const float hi = static_cast<float>(value);
  chi_[i] = hi;
  chi_lo_[i] = static_cast<float>(value - double(hi));
}

std::array<double, kMaxClasses> Volume::bone_volume_by_class() const {
  std::array<double, kMaxClasses> v{};
  for (std::size_t i = 0; i < chi_.size(); ++i) v[labels_[i]] += chi(i);
  for (std::size_t k = 0; k < v.size(); ++k) v[k] += outside_chi_[k];
  const double l3 = l_ * l_ * l_;
  for (auto& x : v) x *= l3;
  v[0] = 0;
  return v;
}

void Volume::build_rows() {
  // Bounds over every labelled voxel (not only χ > 0): labels never change, so the
  // bounds stay valid whatever set_chi, erosion or rollback do to χ.
  const std::size_t nx = dims_[0], rows = dims_[1] * dims_[2];
  row_lo_.assign(rows, std::numeric_limits<std::int32_t>::max());
  row_hi_.assign(rows, -1);
  row_label_.assign(rows, 0);
  for (std::size_t r = 0; r < rows; ++r) {
    const std::uint8_t* lab = &labels_[r * nx];
    std::uint8_t uniform = 0;
    bool mixed = false;
    for (std::size_t x = 0; x < nx; ++x) {
      if (lab[x] == 0) continue;
      if (row_lo_[r] > std::int32_t(x)) row_lo_[r] = std::int32_t(x);
      row_hi_[r] = std::int32_t(x);
      if (uniform == 0) uniform = lab[x];
      else if (uniform != lab[x]) mixed = true;
    }
    // Uniform: every labelled voxel shares one label (label-0 gaps have χ = 0).
    row_label_[r] = mixed ? 0 : uniform;
  }
  const std::size_t ny = dims_[1], nz = dims_[2];
  layer_lo_.assign(nz, std::numeric_limits<std::int32_t>::max());
  layer_hi_.assign(nz, -1);
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      if (row_lo_[y + ny * z] <= row_hi_[y + ny * z]) {
        layer_lo_[z] = std::min(layer_lo_[z], std::int32_t(y));
        layer_hi_[z] = std::int32_t(y);
      }
}

void Volume::begin_undo() {
  // Clear bits of a previous (committed) log, then start afresh.
  for (const auto& e : undo_) touched_[e.i >> 6] &= ~(std::uint64_t(1) << (e.i & 63));
  undo_.clear();
  if (touched_.size() != (chi_.size() + 63) / 64) touched_.assign((chi_.size() + 63) / 64, 0);
  undo_on_ = true;
}

void Volume::log_first_touch(std::size_t i) {
  std::uint64_t& w = touched_[i >> 6];
  const std::uint64_t bit = std::uint64_t(1) << (i & 63);
  if (w & bit) return;
  w |= bit;
  undo_.push_back({i, chi_[i], chi_lo_[i]});
}

void Volume::rollback() {
  for (auto it = undo_.rbegin(); it != undo_.rend(); ++it) {
    chi_[it->i] = it->hi;
    chi_lo_[it->i] = it->lo;
    touched_[it->i >> 6] &= ~(std::uint64_t(1) << (it->i & 63));
  }
  undo_.clear();
  undo_on_ = false;
}

void Volume::commit_undo() {
  for (const auto& e : undo_) touched_[e.i >> 6] &= ~(std::uint64_t(1) << (e.i & 63));
  undo_.clear();
  undo_on_ = false;
}

}  // namespace burrbench::model
