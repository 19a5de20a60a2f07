#pragma once
// The replay driven by samples as they arrive. Each extend() replays, on the same volume
// and at one fixed step, from the last sample reported through the newest one, with
// model::replay itself; so the contacts are those of one batch replay of the whole
// trajectory at that step, bit for bit (tests/watch/test_incremental_replay.cpp).
#include <cstddef>
#include <vector>

#include "burrbench/model/contact.hpp"
#include "burrbench/model/model_params.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::watch {

struct ReplayChunk {
  // Contacts of samples first_index, first_index + 1, …: the first may revise the last
  // sample of the previous chunk (evaluated there, eroded from here), equal in practice.
  std::size_t first_index = 0;
  std::vector<model::ContactResult> contacts;
};

class IncrementalReplay {
 public:
  // `options.step_s` must be > 0: the step is fixed for the whole session (a batch replay
  // chooses it from the median period of all samples, not known while they arrive).
  // Vias and sensitivities are not supported (a live view has neither).
  IncrementalReplay(model::Volume volume, double radius_mm, const model::ModelParams& params,
                    const model::ReplayOptions& options);
  // `so_far`: the trajectory up to the newest sample; its earlier samples must be those
  // given before. Replays the new ones (and re-reports the previous last one).
  ReplayChunk extend(const model::Trajectory& so_far);
  std::size_t reported() const { return reported_; }
  const model::Volume& volume() const { return volume_; }
  double step_s() const { return options_.step_s; }

 private:
  model::Volume volume_;
  double radius_mm_;
  model::ModelParams params_;
  model::ReplayOptions options_;
  std::size_t reported_ = 0;
};

}  // namespace burrbench::watch
