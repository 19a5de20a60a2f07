#include "bone_image.hpp"

#include <algorithm>
#include <cmath>

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

  // Canvas: mm axes left and below the map, a scale bar under it, the colour bar and
  // its labels on the right.
  const int bar_w = 24, margin = 10, label_w = 120, axis_l = 46, axis_b = 66;
  const int map_x = axis_l, map_y = 24;
  cv::Mat canvas(std::max(big.rows, 200) + map_y + axis_b, axis_l + big.cols + bar_w + label_w + 2 * margin,
                 CV_8UC3, cv::Scalar(255, 255, 255));
  big.copyTo(canvas(cv::Rect(map_x, map_y, big.cols, big.rows)));
  const cv::Scalar black(0, 0, 0);
  const auto put = [&](const std::string& t, int x, int y, double scale = 0.4) {
    cv::putText(canvas, t, cv::Point(x, y), cv::FONT_HERSHEY_SIMPLEX, scale, black, 1, cv::LINE_AA);
  };
  // Ticks every "nice" step (1, 2 or 5 × 10^k mm, about 5 per axis), from the volume's
  // corner (x right, y up, as the map).
  const double px_per_mm = k / s.voxel_mm;
  const double ext_mm = double(std::max(s.nx, s.ny)) * s.voxel_mm;
  const double raw = ext_mm / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw / mag < 1.5 ? mag : raw / mag < 3.5 ? 2 * mag : raw / mag < 7.5 ? 5 * mag : 10 * mag;
  cv::rectangle(canvas, cv::Rect(map_x - 1, map_y - 1, big.cols + 2, big.rows + 2), black, 1);
  for (double v = 0; v <= double(s.nx) * s.voxel_mm + 1e-9; v += step) {
    const int x = map_x + int(std::lround(v * px_per_mm));
    cv::line(canvas, {x, map_y + big.rows}, {x, map_y + big.rows + 5}, black, 1);
    put(fmt::format("{:g}", v), x - 8, map_y + big.rows + 18);
  }
  for (double v = 0; v <= double(s.ny) * s.voxel_mm + 1e-9; v += step) {
    const int y = map_y + big.rows - int(std::lround(v * px_per_mm));
    cv::line(canvas, {map_x - 5, y}, {map_x, y}, black, 1);
    put(fmt::format("{:g}", v), 4, y + 4);
  }
  put("x (mm)", map_x + big.cols / 2 - 20, map_y + big.rows + 34);
  put("y (mm)", 2, 14);
  // Scale bar: one tick step, drawn thick under the x label.
  const int sb_y = map_y + big.rows + 52, sb_len = int(std::lround(step * px_per_mm));
  cv::line(canvas, {map_x, sb_y}, {map_x + sb_len, sb_y}, black, 4);
  put(fmt::format("{:g} mm", step), map_x + sb_len + 8, sb_y + 5);

  cv::Mat ramp(big.rows, 1, CV_8U);
  for (int r = 0; r < big.rows; ++r) ramp.at<unsigned char>(r) = cv::saturate_cast<unsigned char>(255 - 255 * r / std::max(1, big.rows - 1));
  cv::Mat ramp_c;
  cv::applyColorMap(ramp, ramp_c, cv::COLORMAP_VIRIDIS);
  cv::resize(ramp_c, ramp_c, cv::Size(bar_w, big.rows), 0, 0, cv::INTER_NEAREST);
  const int bar_x = map_x + big.cols + 2 * margin;
  ramp_c.copyTo(canvas(cv::Rect(bar_x, map_y, bar_w, big.rows)));
  const auto text = [&](const std::string& t, int y) { put(t, bar_x + bar_w + 6, y, 0.45); };
  text(fmt::format("{:.3g} mm", max_mm), map_y + 12);
  text("0 mm", map_y + big.rows);
  text("removed depth", map_y + big.rows / 2 - 10);
  text(fmt::format("voxel {:.3g} mm", s.voxel_mm), map_y + big.rows / 2 + 10);
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
