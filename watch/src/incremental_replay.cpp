#include "burrbench/watch/incremental_replay.hpp"

#include <cmath>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::watch {

IncrementalReplay::IncrementalReplay(model::Volume volume, double radius_mm,
                                     const model::ModelParams& params,
                                     const model::ReplayOptions& options)
    : volume_(std::move(volume)), radius_mm_(radius_mm), params_(params), options_(options) {
  if (!(options_.step_s > 0) || !std::isfinite(options_.step_s))
    throw InputError("watch", "step_s", "a fixed step > 0 s for a live replay",
                     std::to_string(options_.step_s));
  BURRBENCH_CHECK(options_.directions == nullptr && options_.sensitivities == nullptr,
                  "a live replay carries no sensitivities");
}

ReplayChunk IncrementalReplay::extend(const model::Trajectory& so_far) {
  const std::size_t n = so_far.t_s.size();
  ReplayChunk out;
  out.first_index = reported_;
  if (n <= reported_) return out;
  // From the last sample reported: the batch replay erodes from it to the next sample
  // in sub-steps, which only now are known.
  const std::size_t from = reported_ == 0 ? 0 : reported_ - 1;
  model::Trajectory chunk;
  chunk.t_s.assign(so_far.t_s.begin() + std::ptrdiff_t(from), so_far.t_s.end());
  chunk.centre_vol_mm.assign(so_far.centre_vol_mm.begin() + std::ptrdiff_t(from),
                             so_far.centre_vol_mm.end());
  chunk.omega_vol_rad_s.assign(so_far.omega_vol_rad_s.begin() + std::ptrdiff_t(from),
                               so_far.omega_vol_rad_s.end());
  const model::ReplayResult r =
      model::replay(volume_, radius_mm_, params_, chunk, options_, /*restore=*/false);
  out.first_index = from;
  out.contacts.reserve(r.samples.size());
  for (const auto& s : r.samples) out.contacts.push_back(s.contact);
  reported_ = n;
  return out;
}

}  // namespace burrbench::watch
