#pragma once
// Picture of the removed bone: the depth map (removed thickness per (x, y) column of
// the volume) and the class removed per column, rendered with OpenCV to PNGs with mm axes.
#include <string>
#include <vector>

#include "burrbench/analysis/report_data.hpp"

namespace burrbench::analysis {

// PNG bytes; empty when the sample has no depth map.
std::vector<unsigned char> render_removed_depth_png(const SampleInfo& s);
// The class of most removed bone per column, one fixed colour per class label, with a
// legend; empty when the sample has no class map (analysis input before 1.2).
std::vector<unsigned char> render_removed_class_png(const SampleInfo& s);
std::string base64(const std::vector<unsigned char>& bytes);

}  // namespace burrbench::analysis
