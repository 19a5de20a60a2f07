#pragma once
// Scenes for the kernel tests: flat bone filling the half-space n·c < offset.
#include <cmath>

#include <glm/glm.hpp>

#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/model.hpp"
#include "burrbench/model/replay.hpp"

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

// `tr` with its samples [from, to) turned into vias (a force sensor that dropped out while
// the burr moved on; from 0: one that started late), and `d` (one entry per sample of `tr`)
// in the same order: the remaining samples', then the vias'.
inline burrbench::model::Trajectory with_vias(const burrbench::model::Trajectory& tr, std::size_t from,
                                              std::size_t to) {
  burrbench::model::Trajectory out;
  for (std::size_t k = 0; k < tr.t_s.size(); ++k) {
    if (k >= from && k < to) {
      out.vias.push_back({from == 0 ? burrbench::model::Trajectory::Via::kBeforeFirst : from - 1, tr.t_s[k],
                          tr.centre_vol_mm[k], tr.omega_vol_rad_s[k]});
      continue;
    }
    out.t_s.push_back(tr.t_s[k]);
    out.centre_vol_mm.push_back(tr.centre_vol_mm[k]);
    out.omega_vol_rad_s.push_back(tr.omega_vol_rad_s[k]);
  }
  return out;
}
inline std::vector<glm::dvec3> with_vias(const std::vector<glm::dvec3>& d, std::size_t from, std::size_t to) {
  std::vector<glm::dvec3> out(d.begin(), d.begin() + std::ptrdiff_t(from));
  out.insert(out.end(), d.begin() + std::ptrdiff_t(to), d.end());
  out.insert(out.end(), d.begin() + std::ptrdiff_t(from), d.begin() + std::ptrdiff_t(to));
  return out;
}

}  // namespace scenes
