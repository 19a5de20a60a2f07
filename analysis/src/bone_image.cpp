#include "bone_image.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::analysis {

namespace {

struct Framed {
  cv::Mat canvas;
  int map_x = 0, map_y = 0, map_w = 0, map_h = 0;
  int legend_x = 0;  // where the legend column starts
  void put(const std::string& t, int x, int y, double scale = 0.4) {
    cv::putText(canvas, t, cv::Point(x, y), cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  }
};

// A plan-view map (row 0 = volume y = 0, x right) scaled to about 420 px, on a white
// canvas with x and y axes in mm from the volume's corner (ticks every 1, 2 or 5 × 10^k
// mm, about 5 per axis), a scale bar of one tick step under it, and `legend_w` px of
// room on the right.
Framed framed_map(const cv::Mat& plan, const SampleInfo& s, int legend_w) {
  cv::Mat flipped;
  cv::flip(plan, flipped, 0);  // y up
  const int target = 420;
  const double k = double(target) / double(std::max(s.nx, s.ny));
  cv::Mat big;
  cv::resize(flipped, big, cv::Size(), k, k, cv::INTER_NEAREST);
  Framed f;
  const int axis_l = 46, axis_b = 66, margin = 10;
  f.map_x = axis_l;
  f.map_y = 24;
  f.map_w = big.cols;
  f.map_h = big.rows;
  f.canvas = cv::Mat(std::max(big.rows, 200) + f.map_y + axis_b, axis_l + big.cols + legend_w + 2 * margin, CV_8UC3,
                     cv::Scalar(255, 255, 255));
  big.copyTo(f.canvas(cv::Rect(f.map_x, f.map_y, big.cols, big.rows)));
  const cv::Scalar black(0, 0, 0);
  const double px_per_mm = k / s.voxel_mm;
  const double ext_mm = double(std::max(s.nx, s.ny)) * s.voxel_mm;
  const double raw = ext_mm / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw / mag < 1.5 ? mag : raw / mag < 3.5 ? 2 * mag : raw / mag < 7.5 ? 5 * mag : 10 * mag;
  cv::rectangle(f.canvas, cv::Rect(f.map_x - 1, f.map_y - 1, big.cols + 2, big.rows + 2), black, 1);
  for (double v = 0; v <= double(s.nx) * s.voxel_mm + 1e-9; v += step) {
    const int x = f.map_x + int(std::lround(v * px_per_mm));
    cv::line(f.canvas, {x, f.map_y + big.rows}, {x, f.map_y + big.rows + 5}, black, 1);
    f.put(fmt::format("{:g}", v), x - 8, f.map_y + big.rows + 18);
  }
  for (double v = 0; v <= double(s.ny) * s.voxel_mm + 1e-9; v += step) {
    const int y = f.map_y + big.rows - int(std::lround(v * px_per_mm));
    cv::line(f.canvas, {f.map_x - 5, y}, {f.map_x, y}, black, 1);
    f.put(fmt::format("{:g}", v), 4, y + 4);
  }
  f.put("x (mm)", f.map_x + big.cols / 2 - 20, f.map_y + big.rows + 34);
  f.put("y (mm)", 2, 14);
  const int sb_y = f.map_y + big.rows + 52, sb_len = int(std::lround(step * px_per_mm));
  cv::line(f.canvas, {f.map_x, sb_y}, {f.map_x + sb_len, sb_y}, black, 4);
  f.put(fmt::format("{:g} mm", step), f.map_x + sb_len + 8, sb_y + 5);
  f.legend_x = f.map_x + big.cols + 2 * margin;
  return f;
}

std::vector<unsigned char> png_of(const cv::Mat& m) {
  std::vector<unsigned char> png;
  cv::imencode(".png", m, png);
  return png;
}

}  // namespace

std::vector<unsigned char> render_removed_depth_png(const SampleInfo& s) {
  if (s.nx == 0 || s.ny == 0 || s.removed_depth_mm.size() != s.nx * s.ny) return {};
  // Row y of the image = volume y, column = volume x.
  cv::Mat depth(int(s.ny), int(s.nx), CV_32F, const_cast<float*>(s.removed_depth_mm.data()));
  double max_mm = 0;
  cv::minMaxLoc(depth, nullptr, &max_mm);
  cv::Mat scaled;
  depth.convertTo(scaled, CV_8U, max_mm > 0 ? 255.0 / max_mm : 0.0);
  cv::Mat colour;
  cv::applyColorMap(scaled, colour, cv::COLORMAP_VIRIDIS);
  colour.setTo(cv::Scalar(40, 40, 40), scaled == 0);  // untouched columns: dark grey
  const int bar_w = 24;
  Framed f = framed_map(colour, s, bar_w + 120);
  cv::Mat ramp(f.map_h, 1, CV_8U);
  for (int r = 0; r < f.map_h; ++r)
    ramp.at<unsigned char>(r) = cv::saturate_cast<unsigned char>(255 - 255 * r / std::max(1, f.map_h - 1));
  cv::Mat ramp_c;
  cv::applyColorMap(ramp, ramp_c, cv::COLORMAP_VIRIDIS);
  cv::resize(ramp_c, ramp_c, cv::Size(bar_w, f.map_h), 0, 0, cv::INTER_NEAREST);
  ramp_c.copyTo(f.canvas(cv::Rect(f.legend_x, f.map_y, bar_w, f.map_h)));
  const int tx = f.legend_x + bar_w + 6;
  f.put(fmt::format("{:.3g} mm", max_mm), tx, f.map_y + 12, 0.45);
  f.put("0 mm", tx, f.map_y + f.map_h, 0.45);
  f.put("removed depth", tx, f.map_y + f.map_h / 2 - 10, 0.45);
  f.put(fmt::format("voxel {:.3g} mm", s.voxel_mm), tx, f.map_y + f.map_h / 2 + 10, 0.45);
  return png_of(f.canvas);
}

std::vector<unsigned char> render_removed_class_png(const SampleInfo& s) {
  if (s.nx == 0 || s.ny == 0 || s.removed_class.size() != s.nx * s.ny) return {};
  // Fixed colours per label (BGR), so a class looks the same in every report.
  static const std::array<cv::Vec3b, data_schema::kModelClassLabels> kPalette = {{{40, 40, 40},   {60, 160, 235}, {170, 110, 40}, {80, 175, 75},
                                        {180, 90, 200}, {60, 60, 220},  {200, 200, 60}, {140, 140, 140}}};
  auto colour_of = [&](unsigned label) { return kPalette[label % kPalette.size()]; };
  cv::Mat colour(int(s.ny), int(s.nx), CV_8UC3);
  for (std::size_t y = 0; y < s.ny; ++y)
    for (std::size_t x = 0; x < s.nx; ++x)
      colour.at<cv::Vec3b>(int(y), int(x)) = colour_of(s.removed_class[x + s.nx * y]);
  Framed f = framed_map(colour, s, 150);
  int row = 0;
  for (const auto& [label, name] : s.classes) {
    const int y = f.map_y + 8 + 24 * row++;
    const auto& c = colour_of(label);
    cv::rectangle(f.canvas, cv::Rect(f.legend_x, y, 18, 14), cv::Scalar(c[0], c[1], c[2]), cv::FILLED);
    f.put(name, f.legend_x + 26, y + 12, 0.45);
  }
  const int y = f.map_y + 8 + 24 * row;
  cv::rectangle(f.canvas, cv::Rect(f.legend_x, y, 18, 14), cv::Scalar(40, 40, 40), cv::FILLED);
  f.put("none removed", f.legend_x + 26, y + 12, 0.45);
  return png_of(f.canvas);
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
