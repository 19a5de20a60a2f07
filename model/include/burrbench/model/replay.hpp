#pragma once
// The replay engine: drives the burr through a trajectory in the volume frame at a fixed
// internal step, eroding the volume, and reports the contact at every sample time.
#include <array>
#include <cstddef>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/data_schema/cancel.hpp"
#include "burrbench/data_schema/progress.hpp"
#include "burrbench/model/contact.hpp"
#include "burrbench/model/sensitivity.hpp"

namespace burrbench::model {

struct Trajectory {                          // the burr's path in the VOLUME frame
  std::vector<double> t_s;                   // sample times, strictly increasing
  std::vector<glm::dvec3> centre_vol_mm;     // burr centre at each t
  std::vector<glm::dvec3> omega_vol_rad_s;   // angular velocity vector at each t
  // Points the path passes through between two samples, where a straight line from one
  // sample to the next would not be where the burr went: the stage's path across a long
  // gap of the force stream, or before its first sample (AlignedRecording::via_times). No
  // contact is reported at a via; the burr erodes along them as between samples.
  struct Via {
    static constexpr std::size_t kBeforeFirst = std::size_t(-1);
    // It lies strictly inside (t_s[after], t_s[after + 1]); kBeforeFirst: before t_s[0].
    std::size_t after = 0;
    double t_s = 0;
    glm::dvec3 centre_vol_mm{0}, omega_vol_rad_s{0};
  };
  std::vector<Via> vias;                     // in time order
  // Every point's centre: the samples', then the vias' (the order of Direction::dcentre_vol_mm).
  std::vector<glm::dvec3> path_centres_vol_mm() const;
};

struct ReplayOptions {
  double step_s = 0;     // internal step; 0 → half the median sample period
  bool erosion = true;   // false: forces only (as α = ∞ for every class)
  Quadrature quadrature = Quadrature::kLens;  // of the contact kernel (quadrature.hpp)
  // Forward sensitivities (sensitivity.hpp): with both set, the replay also fills
  // `sensitivities` with ∂F/∂θ_j for every direction. Null: a plain replay, bit-identical
  // to one without them.
  const std::vector<Direction>* directions = nullptr;
  Sensitivities* sensitivities = nullptr;
  bool moment_sensitivities = false;  // also ∂T/∂θ_j (Sensitivities::dmoment_Nmm)
  // true: directions that follow exactly from others are assembled, not carried (docs/model.md
  // "Directions that follow from others"); false: every direction is carried (the test of
  // those identities, and the bench's comparison).
  bool derive_directions = true;
  // Polled every 64 samples: once requested, the replay throws Cancelled (with `restore`,
  // after rolling the volume back; without, the erosion so far stays, as for any error).
  const CancelToken* cancel = nullptr;
};

struct ReplaySample { ContactResult contact; };  // at each trajectory time

struct ReplayResult {
  std::vector<ReplaySample> samples;
  std::array<double, kMaxClasses> removed_mm3{};
  std::array<double, kMaxClasses> friction_energy_mJ{};
  std::size_t steps = 0;   // internal erosion steps taken
  double wall_s = 0;       // wall-clock time (the only non-deterministic field)
};

// The step used when ReplayOptions::step_s is 0: half the median sample period (0 for
// fewer than 2 samples).
double default_step_s(const std::vector<double>& t_s);
// The step a replay takes: `step_s`, or default_step_s when 0, cut to the median sample
// period. A longer step would still take one sub-step per interval, and a record of it
// would name a step not taken: synth's truth, or verify's "half the step" (no finer than
// the step itself, so its step error would read 0).
double replay_step_s(double step_s, const std::vector<double>& t_s);

// Each sample interval [t_k, t_k+1] (each of its pieces between vias, when it has some) is
// split into n = ceil(Δt/step) equal sub-steps; position and ω are interpolated linearly;
// the contact reported at t_k is evaluated on the volume as eroded up to t_k. Replays from the volume's current state; leaves the
// volume ERODED unless `restore` is true (then rolls back through the undo log).
// Bad trajectory (sizes differ, times not strictly increasing, non-finite, a via outside
// its interval or out of order) or bad
// radius/step → InputError.
ReplayResult replay(Volume&, double radius_mm, const ModelParams&, const Trajectory&,
                    const ReplayOptions& = {}, bool restore = true,
                    Progress* progress = nullptr);

}  // namespace burrbench::model
