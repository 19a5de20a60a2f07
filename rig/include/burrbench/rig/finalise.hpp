#pragma once
// Journal → Recording: the one path used both when acquisition stops normally and by
// `burrbench recover` after a crash. Decoding happens here, from the raw registers the
// journal holds, with the register map the journal's header carries.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/recording.hpp"
#include "burrbench/rig/journal.hpp"

namespace burrbench::rig {

// What the journal header holds (JSON): everything the recording needs besides samples.
struct SessionHeader {
  std::string rig_file, rig_sha256, rig_toml;
  std::string sample_id, notes;
  std::string tare_file, tare_sha256;
  std::vector<double> bias;       // 6 values or empty
  std::int64_t bias_t_ns = 0;
  std::int64_t session_wall_ns = 0, session_monotonic_ns = 0;
  std::string command_line, software_version, created_utc;
  // What the operator stated of the session (acquire --operator, --burr-radius-mm,
  // --burr-axis, --spin): 0 / a zero axis = not stated. Absent from older journals.
  std::string operator_name;
  double burr_radius_mm = 0;
  std::vector<double> burr_axis_rig;  // 3 values (unit vector) or empty
  int spin_sign = 0;
};
nlohmann::json to_json(const SessionHeader& h);
SessionHeader header_from_json(const std::string& text, const std::string& file_for_messages);

struct FinaliseReport {
  std::size_t samples = 0, invalid = 0, stale = 0;
  std::vector<std::string> problems;  // from the journal reader
};

data_schema::Recording recording_from_journal(const JournalContents& j, const std::string& journal_file,
                                              FinaliseReport* report = nullptr);

}  // namespace burrbench::rig
