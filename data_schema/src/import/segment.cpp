// Grey CT → labels + χ. Steps (docs/importers.md "Segmentation"):
// 1 bone = grey ≥ threshold (given, or Otsu on a 1024-bin histogram), optional open/close;
// 2 χ = clamp((grey − empty) / (bone − empty), 0, 1) on bone voxels, 0 elsewhere; the two
//   calibration greys default to medians of the interior (eroded) empty and bone voxels;
// 3 local BV/TV = box-sum(bone) / box-sum(envelope), where the envelope is the bone mask
//   closed with a radius that fills pores, so the sample's outer surface does not look
//   porous. BV/TV ≥ compact_bvtv finds the compact region robustly but blurs its edge by
//   up to the BV/TV radius; so that region, dilated by that radius, only gates a sharper
//   test: compact bone is where a box of half side compact_open_mm fits in the (closed)
//   bone mask (a morphological opening), which trabecular plates and struts do not hold.
#include "burrbench/data_schema/import/segment.hpp"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "import/morphology3d.hpp"

namespace burrbench::data_schema::import {
namespace {
using detail::Dims;

double otsu(const std::vector<float>& g) {
  const auto [mn_it, mx_it] = std::minmax_element(g.begin(), g.end());
  const double mn = *mn_it, mx = *mx_it;
  if (!(mx > mn)) return mx;
  constexpr int kBins = 1024;
  std::vector<double> h(kBins, 0.0);
  const double scale = (kBins - 1) / (mx - mn);
  for (float v : g) h[static_cast<std::size_t>((v - mn) * scale)] += 1;
  const double total = static_cast<double>(g.size());
  double sum_all = 0;
  for (int i = 0; i < kBins; ++i) sum_all += i * h[static_cast<std::size_t>(i)];
  double w0 = 0, sum0 = 0, best = -1;
  int best_i = 0;
  for (int i = 0; i < kBins - 1; ++i) {
    w0 += h[static_cast<std::size_t>(i)];
    sum0 += i * h[static_cast<std::size_t>(i)];
    const double w1 = total - w0;
    if (w0 == 0 || w1 == 0) continue;
    const double m0 = sum0 / w0, m1 = (sum_all - sum0) / w1;
    const double between = w0 * w1 * (m0 - m1) * (m0 - m1);
    if (between > best) { best = between; best_i = i; }
  }
  return mn + (best_i + 1) / scale;  // first bin of the upper class
}

std::optional<double> median_where(const std::vector<float>& g, const std::vector<std::uint8_t>& m) {
  std::vector<float> s;  // reserved exactly: growing by doubling could take 8 bytes a voxel
  s.reserve(static_cast<std::size_t>(std::count_if(m.begin(), m.end(), [](std::uint8_t x) { return x != 0; })));
  for (std::size_t i = 0; i < g.size(); ++i) if (m[i]) s.push_back(g[i]);
  if (s.empty()) return std::nullopt;
  auto mid = s.begin() + static_cast<long>(s.size() / 2);
  std::nth_element(s.begin(), mid, s.end());
  return *mid;
}

// Radii in voxels; anything beyond 1000 voxels is refused later, so clamp before casting.
int vox(double mm, double voxel_mm) { return static_cast<int>(std::lround(std::min(mm / voxel_mm, 1e4))); }

}  // namespace

Segmentation segment_ct(const ImageVolume& ct, const SegmentationSettings& s, const std::string& file,
                        Progress* progress) {
  const auto stage = [progress](const std::string& name, const std::string& detail) {
    if (progress) progress->stage(name, detail);
  };
  if (!is_cubic(ct)) throw InputError(file, "spacing", "cubic voxels (resample first: --resample)");
  const double l = ct.spacing_mm.x;
  const Dims d = ct.dims;
  const std::size_t n = ct.voxel_count();
  if (!(s.bvtv_radius_mm > 0)) throw InputError(file, "bvtv_radius_mm", "a positive radius");
  if (!(s.compact_bvtv > 0 && s.compact_bvtv <= 1)) throw InputError(file, "compact_bvtv", "a value in (0, 1]");
  if (!(s.envelope_radius_mm >= 0)) throw InputError(file, "envelope_radius_mm", "a radius ≥ 0");
  if (!(s.compact_open_mm >= 0)) throw InputError(file, "compact_open_mm", "a radius ≥ 0");
  for (int r : {s.bone_open_vox, s.bone_close_vox, s.compact_close_vox}) {
    if (r < 0 || r > 50) throw InputError(file, "open/close radius", "0..50 voxels", std::to_string(r));
  }
  const int r_bvtv = std::max(1, vox(s.bvtv_radius_mm, l));
  const int r_env = vox(s.envelope_radius_mm, l);
  const int r_open = vox(s.compact_open_mm, l);
  if (r_bvtv > 100 || r_env > 100) throw InputError(file, "bvtv_radius_mm/envelope_radius_mm", "at most 100 voxels");
  if (r_open > 100) throw InputError(file, "compact_open_mm", "at most 100 voxels", fmt::format("{} voxels", r_open));

  // 1. bone mask
  const double threshold = s.threshold ? *s.threshold : otsu(ct.values);
  std::vector<std::uint8_t> bone(n);
  for (std::size_t i = 0; i < n; ++i) bone[i] = ct.values[i] >= threshold ? 1 : 0;
  bone = detail::close(detail::open(bone, d, s.bone_open_vox), d, s.bone_close_vox);

  // 2. calibration greys and χ
  std::optional<double> empty_grey = s.empty_grey, bone_grey = s.bone_grey;
  if (!empty_grey) {
    std::vector<std::uint8_t> e(n);
    for (std::size_t i = 0; i < n; ++i) e[i] = 1 - bone[i];
    empty_grey = median_where(ct.values, detail::erode(e, d, 1));
    if (!empty_grey) throw InputError(file, "empty_grey", "--empty-grey (no empty region to calibrate from)");
  }
  if (!bone_grey) {
    bone_grey = median_where(ct.values, detail::erode(bone, d, 1));
    if (!bone_grey) throw InputError(file, "bone_grey", "--bone-grey (no solid bone region to calibrate from)");
  }
  if (!(*bone_grey > *empty_grey)) {
    throw InputError(file, "bone_grey", fmt::format("a value above empty_grey {}", *empty_grey), fmt::format("{}", *bone_grey));
  }

  // The first stage only now: every refusal above stays one line.
  stage("calibrated", fmt::format("bone where grey ≥ {:.6g} ({}), χ = 0 at grey {:.6g} and 1 at {:.6g}", threshold,
                                  s.threshold ? "given" : "Otsu", *empty_grey, *bone_grey));

  // 3. local BV/TV within the envelope
  stage("compact", fmt::format("local BV/TV in boxes of half side {} voxels, opening of {} voxels", r_bvtv, r_open));
  std::vector<std::uint8_t> compact(n);
  {  // scoped: the counts (4 bytes per voxel each) are freed before the opening below
    const auto bsum = detail::box_count(bone, d, r_bvtv);
    const auto esum = detail::box_count(detail::close(bone, d, r_env), d, r_bvtv);  // of the envelope
    for (std::size_t i = 0; i < n; ++i) compact[i] = (esum[i] > 0 && bsum[i] >= s.compact_bvtv * esum[i]) ? 1 : 0;
  }
  const auto gate = detail::dilate(compact, d, r_bvtv);
  const auto solid = detail::open(detail::close(bone, d, s.compact_close_vox), d, r_open);
  for (std::size_t i = 0; i < n; ++i) compact[i] = gate[i] & solid[i];

  Segmentation out;
  SampleVolume& v = out.sample;
  v.dims = d;
  v.voxel_mm = l;
  v.origin_mm = ct.origin_mm;
  v.labels.resize(n);
  v.fraction.resize(n);
  const double span = *bone_grey - *empty_grey;
  std::size_t counts[3] = {0, 0, 0};
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t lab = bone[i] ? (compact[i] ? kCompact : kTrabecular) : kEmpty;
    v.labels[i] = lab;
    ++counts[lab];
    v.fraction[i] = lab ? static_cast<float>(std::clamp((ct.values[i] - *empty_grey) / span, 0.0, 1.0)) : 0.0f;
  }
  out.settings_used = {
      {"method", "threshold + calibrated fraction + local BV/TV"},
      {"threshold", threshold},
      {"threshold_method", s.threshold ? "given" : "otsu"},
      {"empty_grey", *empty_grey},
      {"empty_grey_source", s.empty_grey ? "given" : "median of interior empty voxels"},
      {"bone_grey", *bone_grey},
      {"bone_grey_source", s.bone_grey ? "given" : "median of interior bone voxels"},
      {"bvtv_radius_mm", s.bvtv_radius_mm},
      {"bvtv_radius_vox", r_bvtv},
      {"bvtv_window", "box"},
      {"compact_bvtv", s.compact_bvtv},
      {"envelope_radius_mm", s.envelope_radius_mm},
      {"envelope_radius_vox", r_env},
      {"bone_open_vox", s.bone_open_vox},
      {"bone_close_vox", s.bone_close_vox},
      {"compact_close_vox", s.compact_close_vox},
      {"compact_open_mm", s.compact_open_mm},
      {"compact_open_vox", r_open},
      {"voxel_mm", l},
      {"voxels", {{"empty", counts[0]}, {"compact", counts[1]}, {"trabecular", counts[2]}}}};
  v.segmentation_json = out.settings_used.dump();
  return out;
}

}  // namespace burrbench::data_schema::import
