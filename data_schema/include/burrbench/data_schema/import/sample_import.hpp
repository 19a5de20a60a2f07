#pragma once
// Ready label + bone-fraction volumes → SampleVolume (the `sample import --labels` path),
// and the reverse views used by the NRRD export.
#include <optional>
#include <string>

#include "burrbench/data_schema/import/volume.hpp"
#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::data_schema::import {

// labels: integer voxels 0..255 (0 empty, 1 compact, 2 trabecular, others become
// "class_<id>"). fraction: float in [0,1] or an integer counter χ = n/255; absent → χ = 1
// on every labelled voxel. Both need cubic voxels and identical geometry. χ on label-0
// voxels is set to 0 (the label decides) and the count is noted in segmentation_json.
SampleVolume sample_from_labels(const ImageVolume& labels, const std::optional<ImageVolume>& fraction,
                                const std::string& labels_file, const std::string& fraction_file);

ImageVolume labels_image(const SampleVolume& s);
ImageVolume fraction_image(const SampleVolume& s);

}  // namespace burrbench::data_schema::import
