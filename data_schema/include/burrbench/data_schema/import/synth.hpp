#pragma once
// A seeded synthetic sample: a compact layer on top (high z) over a trabecular core made
// of plates (a band around the zero level of smoothed Gaussian noise), with χ as float.
#include <cstdint>

#include <glm/glm.hpp>

#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::data_schema::import {

struct SynthSettings {
  double voxel_mm = 0.1;
  glm::dvec3 extent_mm{10, 10, 6};
  double compact_mm = 1.0;    // thickness of the compact layer at the top
  double porosity = 0.6;      // pore volume fraction of the trabecular core, (0, 1)
  double strut_mm = 0.25;     // correlation length of the noise (plate spacing scale)
  std::uint64_t seed = 1;
};

// Deterministic: same settings → same labels and χ on every platform (own RNG and
// normal sampler). segmentation_json records the settings and the porosity achieved.
SampleVolume synth_sample(const SynthSettings& s);

}  // namespace burrbench::data_schema::import
