#include "burrbench/data_schema/import/sample_import.hpp"

#include <cmath>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema::import {
namespace {

std::string voxel(const ImageVolume& v, std::size_t i) {
  const std::size_t x = i % v.dims[0], y = (i / v.dims[0]) % v.dims[1], z = i / (v.dims[0] * v.dims[1]);
  return fmt::format("voxel ({},{},{})", x, y, z);
}

void check_cubic(const ImageVolume& v, const std::string& file) {
  if (!is_cubic(v)) {
    throw InputError(file, "spacing", "cubic voxels (add --resample, optionally --voxel-mm)",
                     fmt::format("{} x {} x {} mm", v.spacing_mm.x, v.spacing_mm.y, v.spacing_mm.z));
  }
}

}  // namespace

SampleVolume sample_from_labels(const ImageVolume& labels, const std::optional<ImageVolume>& fraction,
                                const std::string& labels_file, const std::string& fraction_file) {
  check_cubic(labels, labels_file);
  SampleVolume s;
  s.dims = labels.dims;
  s.voxel_mm = labels.spacing_mm.x;
  s.origin_mm = labels.origin_mm;
  const std::size_t n = labels.voxel_count();
  s.labels.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const float l = labels.values[i];
    if (!(l >= 0 && l <= 255 && l == std::floor(l))) {
      throw InputError(labels_file, voxel(labels, i), "an integer label 0..255", fmt::format("{}", l));
    }
    s.labels[i] = static_cast<std::uint8_t>(l);
    if (s.labels[i] > kTrabecular && !s.classes.count(s.labels[i])) s.classes[s.labels[i]] = fmt::format("class_{}", s.labels[i]);
  }
  s.fraction.assign(n, 0.0f);
  std::size_t zeroed = 0;
  if (fraction) {
    const ImageVolume& f = *fraction;
    check_cubic(f, fraction_file);
    const double tol = 1e-6 * s.voxel_mm;
    if (f.dims != labels.dims || std::abs(f.spacing_mm.x - s.voxel_mm) > tol || glm::length(f.origin_mm - labels.origin_mm) > tol) {
      throw InputError(fraction_file, "geometry",
                       fmt::format("the label volume's {}x{}x{} voxels of {} mm at origin ({},{},{})", labels.dims[0],
                                   labels.dims[1], labels.dims[2], s.voxel_mm, labels.origin_mm.x, labels.origin_mm.y, labels.origin_mm.z),
                       fmt::format("{}x{}x{} voxels of {} mm at origin ({},{},{})", f.dims[0], f.dims[1], f.dims[2], f.spacing_mm.x,
                                   f.origin_mm.x, f.origin_mm.y, f.origin_mm.z));
    }
    for (std::size_t i = 0; i < n; ++i) {
      double chi = f.values[i];
      if (f.is_integer()) {
        if (!(chi >= 0 && chi <= 255)) throw InputError(fraction_file, voxel(f, i), "a counter 0..255 (χ = n/255)", fmt::format("{}", chi));
        chi /= 255.0;
      } else {
        if (!(chi >= -1e-6 && chi <= 1 + 1e-6)) throw InputError(fraction_file, voxel(f, i), "a bone fraction in [0, 1]", fmt::format("{}", chi));
        chi = std::clamp(chi, 0.0, 1.0);
      }
      if (s.labels[i] == kEmpty && chi != 0) { ++zeroed; chi = 0; }
      s.fraction[i] = static_cast<float>(chi);
    }
  } else {
    for (std::size_t i = 0; i < n; ++i) s.fraction[i] = s.labels[i] ? 1.0f : 0.0f;
  }
  nlohmann::json j = {{"method", "imported labels"},
                      {"fraction", fraction ? (fraction->is_integer() ? "counter n/255" : "float") : "1 on labelled voxels"},
                      {"fraction_zeroed_where_label_empty", zeroed}};
  s.segmentation_json = j.dump();
  return s;
}

ImageVolume labels_image(const SampleVolume& s) {
  ImageVolume v;
  v.dims = s.dims;
  v.spacing_mm = glm::dvec3(s.voxel_mm);
  v.origin_mm = s.origin_mm;
  v.source_type = VoxelType::kUint8;
  v.values.assign(s.labels.begin(), s.labels.end());
  return v;
}

ImageVolume fraction_image(const SampleVolume& s) {
  ImageVolume v = labels_image(s);
  v.source_type = VoxelType::kFloat32;
  v.values = s.fraction;
  return v;
}

}  // namespace burrbench::data_schema::import
