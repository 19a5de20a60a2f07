#pragma once
// Did the force sensor's zero move during a recording? The fit holds one bias per
// recording and channel (objective.hpp: the force's, the moment's), so a zero that drifts
// (a sensor warming beside the spindle, a spindle that started between the stretches) is
// fitted as force or moment the burr made, and biases the constants. The recording's own
// free stretches tell: the channel without contact before the first contact and after
// the last one, each about its own mean (docs/calibration.md "A drifting sensor zero").
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>

namespace burrbench::calibration {

inline constexpr double kZeroDriftSigmas = 5;           // as `rig tare`'s drift check
inline constexpr std::size_t kMinZeroDriftSamples = 20;  // per stretch

// Which of the sensor's channels is checked: its name and unit in the warning.
struct DriftChannel {
  const char* name;
  const char* unit;
};
inline constexpr DriftChannel kForceChannel{"force", "N"};
inline constexpr DriftChannel kMomentChannel{"moment", "N·mm"};

struct ZeroDrift {
  std::size_t before = 0, after = 0;      // free samples in each stretch
  double before_from_s = 0, before_to_s = 0, after_from_s = 0, after_to_s = 0;
  // In the channel's unit (N for the force, N·mm for the moment; sensor frame):
  glm::dvec3 shift{0};                    // mean after − mean before
  glm::dvec3 standard_error{0};           // of that difference, per axis
  double sigmas = 0;                      // max over the axes of |shift| / standard error
  // The warning line when sigmas > kZeroDriftSigmas ("" otherwise).
  std::string text(const std::string& recording, DriftChannel channel = kForceChannel) const;
};

// The measured channel (sensor frame: the force, or the moment) at the samples with weight > 0 and no class in
// contact (class_mask 0) before the first sample in contact and after the last. The
// standard error pools the scatter of both stretches about their own means and widens
// it for their lag-1 autocorrelation (ar1_inflation: sensor noise is seldom white). None
// when a stretch has fewer than kMinZeroDriftSamples or no sample is in contact.
std::optional<ZeroDrift> zero_drift(const std::vector<double>& t_s, const std::vector<glm::dvec3>& measured,
                                    const std::vector<std::uint8_t>& class_mask, const std::vector<double>& weight);

}  // namespace burrbench::calibration
