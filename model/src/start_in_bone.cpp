// Does a recording begin with the burr already in bone? (experiment.hpp StartInBone)
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/model/contact.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/reach.hpp"

namespace burrbench::model {

StartInBone start_in_bone(const Experiment& e, const AlignedRecording& r) {
  const Trajectory tr = r.trajectory();
  StartInBone s;
  const auto& sample = e.samples.at(r.sample_id);
  s.tolerance_mm = sample.voxel_mm;
  if (std::isfinite(r.registration.tre_path_max_mm)) s.tolerance_mm = std::max(s.tolerance_mm, r.registration.tre_path_max_mm);
  if (tr.t_s.empty()) return s;
  // The path's first point: a lead-in via comes before every sample (vias are in time order).
  Trajectory first;
  const bool lead = !tr.vias.empty() && tr.vias.front().after == Trajectory::Via::kBeforeFirst;
  first.t_s = {lead ? tr.vias.front().t_s : tr.t_s.front()};
  first.centre_vol_mm = {lead ? tr.vias.front().centre_vol_mm : tr.centre_vol_mm.front()};
  first.omega_vol_rad_s = {lead ? tr.vias.front().omega_vol_rad_s : tr.omega_vol_rad_s.front()};
  s.t_s = first.t_s[0];
  // Only the voxels within reach of that point: the immersion depth is geometry alone
  // (the bone volume inside the sphere), so any constants will do.
  const auto box = reach_box(sample, first, r.radius_mm);
  if (!box) return s;
  const Volume v = Volume::from_sample(sample, *box);
  s.depth_b_mm = evaluate(v, first.centre_vol_mm[0], first.omega_vol_rad_s[0], r.radius_mm, ModelParams{}).depth_b_mm;
  return s;
}

std::string StartInBone::text(const AlignedRecording& r) const {
  if (!(depth_b_mm > tolerance_mm)) return "";
  return fmt::format(
      "Recording {}: the burr is already {:.3g} mm deep in the bone of sample {} where its path begins (t = {:.4g} s "
      "at the manifest's lag; one voxel or the registration's error is {:.3g} mm): the replay starts from the bone "
      "as scanned, so if the burr cut its way there before the recording began, the forces near that hole are "
      "predicted against bone that is gone, and fitted and scored so. Start recording before the burr touches the "
      "bone, or check the registration (`burrbench verify`).",
      r.id, depth_b_mm, r.sample_id, t_s, tolerance_mm);
}

}  // namespace burrbench::model
