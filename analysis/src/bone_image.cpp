#include "bone_image.hpp"

#include <algorithm>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace burrbench::analysis {

std::vector<unsigned char> render_removed_depth_png(const SampleInfo& s) {
  if (s.nx == 0 || s.ny == 0 || s.removed_depth_mm.size() != s.nx * s.ny) return {};
  // Row y of the image = volume y, column = volume x; y up like a plan view.
  cv::Mat depth(int(s.ny), int(s.nx), CV_32F, const_cast<float*>(s.removed_depth_mm.data()));
  double max_mm = 0;
  cv::minMaxLoc(depth, nullptr, &max_mm);
  cv::Mat scaled;
  depth.convertTo(scaled, CV_8U, max_mm > 0 ? 255.0 / max_mm : 0.0);
  cv::flip(scaled, scaled, 0);
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_VIRIDIS);
  colour.setTo(cv::Scalar(40, 40, 40), scaled == 0);  // untouched columns: dark grey
  const int target = 420;
  const double k = double(target) / double(std::max(s.nx, s.ny));
  cv::Mat big;
  cv::resize(colour, big, cv::Size(), k, k, cv::INTER_NEAREST);

  // Canvas: map on the left, colour bar and labels on the right.
  const int bar_w = 24, margin = 10, label_w = 120;
  cv::Mat canvas(std::max(big.rows, 200) + 2 * margin, big.cols + bar_w + label_w + 3 * margin,
                 CV_8UC3, cv::Scalar(255, 255, 255));
  big.copyTo(canvas(cv::Rect(margin, margin, big.cols, big.rows)));
  cv::Mat ramp(big.rows, 1, CV_8U);
  for (int r = 0; r < big.rows; ++r) ramp.at<unsigned char>(r) = cv::saturate_cast<unsigned char>(255 - 255 * r / std::max(1, big.rows - 1));
  cv::Mat ramp_c;
  cv::applyColorMap(ramp, ramp_c, cv::COLORMAP_VIRIDIS);
  cv::resize(ramp_c, ramp_c, cv::Size(bar_w, big.rows), 0, 0, cv::INTER_NEAREST);
  const int bar_x = big.cols + 2 * margin;
  ramp_c.copyTo(canvas(cv::Rect(bar_x, margin, bar_w, big.rows)));
  const auto text = [&](const std::string& t, int y) {
    cv::putText(canvas, t, cv::Point(bar_x + bar_w + 6, y), cv::FONT_HERSHEY_SIMPLEX, 0.45,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  };
  text(fmt::format("{:.3g} mm", max_mm), margin + 12);
  text("0 mm", margin + big.rows);
  text(fmt::format("voxel {:.3g} mm", s.voxel_mm), margin + big.rows / 2);
  std::vector<unsigned char> png;
  cv::imencode(".png", canvas, png);
  return png;
}

std::string base64(const std::vector<unsigned char>& bytes) {
  static const char* kAlphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const unsigned v = bytes[i] << 16 | bytes[i + 1] << 8 | bytes[i + 2];
    for (int s = 18; s >= 0; s -= 6) out += kAlphabet[(v >> s) & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = bytes[i] << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = bytes[i] << 16 | bytes[i + 1] << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

}  // namespace burrbench::analysis
