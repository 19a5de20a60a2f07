#pragma once
// Grey CT → class labels + bone fraction χ (see docs/importers.md, "Segmentation").
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/import/volume.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::data_schema::import {

struct SegmentationSettings {
  std::optional<double> threshold;    // bone if grey ≥ threshold; absent → Otsu
  std::optional<double> empty_grey;   // calibration: grey of empty space (χ = 0); absent →
  std::optional<double> bone_grey;    //   median below / 95th percentile above threshold
  double bvtv_radius_mm = 0.4;        // half side of the box over which BV/TV is taken
  double compact_bvtv = 0.8;          // BV/TV ≥ this marks the compact region (coarse)
  double envelope_radius_mm = 0.5;    // closing radius that fills pores to make the envelope
  double compact_open_mm = 0.4;       // compact bone holds a box of this half side (fine)
  int bone_open_vox = 0;              // open/close radii (voxels) on the bone mask
  int bone_close_vox = 0;
  int compact_close_vox = 0;          // closes small pores in compact before the opening
};

struct Segmentation {
  SampleVolume sample;                // labels, χ, geometry; segmentation_json filled
  nlohmann::json settings_used;       // every setting, including derived values
};

// `ct` must have cubic voxels (resample first). Throws InputError on unusable settings.
// `progress`, when given, gets a stage per step (a lab CT of 10⁹ voxels takes minutes).
Segmentation segment_ct(const ImageVolume& ct, const SegmentationSettings& s,
                        const std::string& file_for_messages, Progress* progress = nullptr);

}  // namespace burrbench::data_schema::import
