#pragma once
// Drilling protocols (TOML, format "burrbench.protocol"): a start point, an approach
// direction and a sequence of moves (plunge, sweep, polish, dwell, retract), sampled into
// a burr path in the VOLUME frame. Used by `burrbench synth` (and, through the synthetic
// recordings it writes, by the virtual rig). docs/replay.md documents every key.
//
// Depth convention: the approach line is the line through the start point along the
// approach direction â. Depth 0 is the burr-centre position on that line at which the
// burr's leading point (centre + R·â) first enters a bone voxel cell (label ≠ 0 and
// χ ≥ 0.5; a cell is the cube of side l centred on the voxel centre). The depth of any
// centre position p is (p − p_surface)·â: positive = into the bone.
#include <filesystem>
#include <glm/glm.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::model {

inline constexpr const char* kProtocolFormat = "burrbench.protocol";
inline constexpr int kProtocolVersionMajor = 1;

enum class MoveKind { kPlunge, kSweep, kPolish, kDwell, kRetract };
const char* to_string(MoveKind k);

struct ProtocolMove {
  MoveKind kind = MoveKind::kDwell;
  std::string label;
  std::optional<double> spindle_rpm;  // from this move on (sticky); absent: unchanged
  std::optional<double> depth_mm;     // plunge: required; sweep/polish: optional
  double speed_mm_s = 0;              // plunge: feed; sweep/polish/retract: speed
  std::optional<double> feed_mm_s;    // sweep/polish: axial feed to reach depth_mm
  glm::dvec3 direction{0};            // sweep/polish: unit, perpendicular to the approach
  double length_mm = 0;               // sweep/polish
  int strokes = 0;                    // polish: forth-and-back strokes
  double duration_s = 0;              // dwell
  std::optional<double> distance_mm;  // retract: distance back along −â; absent: to start
};

struct Protocol {
  std::string file;  // for messages
  std::string name, description;
  double sample_rate_hz = 1000;
  double spindle_rpm = 0;  // initial spindle speed
  double burr_radius_mm = 0;
  glm::dvec3 burr_axis_vol{0, 0, 1};  // shaft direction, unit
  int spin_sign = 1;                  // +1: ω along the axis, −1 against
  glm::dvec3 start_vol_mm{0};         // burr centre at t = 0
  glm::dvec3 approach_vol{0, 0, -1};  // unit, towards the bone
  std::vector<ProtocolMove> moves;
};

// Parses and validates; InputError("file", "moves[2].depth_mm", ...) on any defect,
// unknown keys included.
Protocol parse_protocol(std::string_view toml_text, const std::string& file_for_messages);
Protocol read_protocol(const std::filesystem::path& path);

// The sampled path: sample k at t_k = k / sample_rate_hz, k = 0 … ⌊T·rate⌋.
struct ProtocolPath {
  std::vector<double> t_s;
  std::vector<glm::dvec3> centre_vol_mm;
  std::vector<double> spindle_rpm;  // ≥ 0; the spin direction is the protocol's spin_sign
  std::vector<double> depth_mm;     // (centre − surface)·â
  std::vector<int> move;            // index into Protocol::moves (−1: none, only if no moves)
  glm::dvec3 surface_vol_mm{0};     // burr centre at depth 0
  double duration_s = 0;
  // ω = 2π·rpm/60 · spin_sign · axis at every sample (rad/s, volume frame).
  std::vector<glm::dvec3> omega_vol_rad_s(const Protocol& p) const;
};

// Distance s ≥ 0 from the start point along â to depth 0 (see the depth convention).
// InputError if the leading point starts inside bone or the line never meets bone.
double distance_to_surface(const data_schema::SampleVolume& sample, const glm::dvec3& start_vol_mm,
                           const glm::dvec3& approach_vol, double radius_mm,
                           const std::string& file_for_messages);

// Samples the protocol against this sample's surface. Refuses > 50 M samples.
ProtocolPath sample_protocol(const Protocol& p, const data_schema::SampleVolume& sample);

}  // namespace burrbench::model
