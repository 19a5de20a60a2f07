#pragma once
// A lumpy two-class bone and its constants, shared by the contact-kernel tests.
#include <cmath>
#include <random>

#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/model_params.hpp"

namespace scenes {

// Random χ in [0.2, 1], compact (label 1) above z = 6 voxels, trabecular (2) below, under
// a wavy surface at z ≈ 8 ± 2 voxels.
inline burrbench::data_schema::SampleVolume lumpy(std::size_t n, double l, unsigned seed) {
  burrbench::data_schema::SampleVolume s;
  s.dims = {n, n, n};
  s.voxel_mm = l;
  s.labels.assign(s.voxel_count(), 0);
  s.fraction.assign(s.voxel_count(), 0.0f);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.2f, 1.0f);
  for (std::size_t z = 0; z < n; ++z)
    for (std::size_t y = 0; y < n; ++y)
      for (std::size_t x = 0; x < n; ++x) {
        const std::size_t i = s.index(x, y, z);
        const double h = 8 + 2 * std::sin(0.7 * double(x)) * std::cos(0.5 * double(y));
        if (double(z) < h) {
          s.labels[i] = z > 5 ? 1 : 2;
          s.fraction[i] = u(rng);
        }
      }
  return s;
}

inline burrbench::model::ModelParams two_classes() {
  burrbench::model::ModelParams p;
  p.by_label[1] = {50.0, 12.0, 0.4};
  p.by_label[2] = {20.0, 4.0, 0.7};
  return p;
}

}  // namespace scenes
