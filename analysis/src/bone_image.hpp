#pragma once
// Picture of the removed bone: the depth map (removed thickness per (x, y) column of
// the volume) rendered with OpenCV to a PNG with a colour bar.
#include <string>
#include <vector>

#include "burrbench/analysis/analysis_input.hpp"

namespace burrbench::analysis {

// PNG bytes; empty when the sample has no depth map.
std::vector<unsigned char> render_removed_depth_png(const SampleInfo& s);
std::string base64(const std::vector<unsigned char>& bytes);

}  // namespace burrbench::analysis
