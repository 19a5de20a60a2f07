#pragma once
// Scenes for the kernel tests: flat bone filling the half-space n·c < offset.
#include <cmath>

#include <glm/glm.hpp>

#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/model.hpp"

namespace scenes {

inline burrbench::data_schema::SampleVolume half_space(std::size_t nx, std::size_t ny,
                                                       std::size_t nz, double l,
                                                       glm::dvec3 normal, double offset,
                                                       std::uint8_t label = 1) {
  burrbench::data_schema::SampleVolume s;
  s.dims = {nx, ny, nz};
  s.voxel_mm = l;
  s.labels.assign(s.voxel_count(), 0);
  s.fraction.assign(s.voxel_count(), 0.0f);
  const glm::dvec3 n = glm::normalize(normal);
  for (std::size_t z = 0; z < nz; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x)
        if (glm::dot(n, s.centre_mm(x, y, z)) < offset) {
          s.labels[s.index(x, y, z)] = label;
          s.fraction[s.index(x, y, z)] = 1.0f;
        }
  return s;
}

inline burrbench::model::ModelParams one_class(double c1, double mu, double alpha = INFINITY,
                                               std::uint8_t label = 1) {
  burrbench::model::ModelParams p;
  p.by_label[label] = {alpha, c1, mu};
  return p;
}

}  // namespace scenes
