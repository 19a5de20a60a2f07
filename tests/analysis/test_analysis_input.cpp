// The analysis input (DIR/analysis.json + DIR/predictions.csv): round trip and rejection
// of broken files; escaping of text from files.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "analysis/analysis_fixture.hpp"
#include "burrbench/analysis/report.hpp"
#include "burrbench/data_schema/error.hpp"

using namespace burrbench::analysis;
namespace fs = std::filesystem;

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream f(p);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}
void spit(const fs::path& p, const std::string& s) { std::ofstream(p) << s; }
void replace(std::string& s, const std::string& a, const std::string& b) {
  const auto pos = s.find(a);
  ASSERT_NE(pos, std::string::npos) << a;
  s.replace(pos, a.size(), b);
}
}  // namespace

TEST(AnalysisInput, RoundTripIsExact) {
  auto in = burrbench::testing::small_input();
  in.recordings[1].id = "odd, \"id\"";  // CSV quoting
  in.recordings[1].used[3] = 0;
  const auto dir = burrbench::testing::temp_dir("roundtrip");
  write_analysis_input(dir, in);
  const auto back = read_analysis_input(dir);
  ASSERT_EQ(back.recordings.size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& a = in.recordings[k];
    const auto& b = back.recordings[k];
    EXPECT_EQ(a.id, b.id);
    EXPECT_EQ(a.role, b.role);
    EXPECT_EQ(a.t_s, b.t_s);  // shortest round-trip formatting: bit-exact
    EXPECT_EQ(a.measured_N, b.measured_N);
    EXPECT_EQ(a.predicted_N, b.predicted_N);
    EXPECT_EQ(a.used, b.used);
    EXPECT_EQ(a.segments.size(), b.segments.size());
  }
  EXPECT_EQ(back.samples[0].removed_depth_mm, in.samples[0].removed_depth_mm);
  EXPECT_EQ(back.samples[0].removed_class, in.samples[0].removed_class);
  EXPECT_EQ(back.samples[0].classes, in.samples[0].classes);
  EXPECT_EQ(back.parameters[0].c1_N_per_mm2, 10.0);
  EXPECT_EQ(back.seed, 7u);
}

TEST(AnalysisInput, BrokenFilesAreInputErrors) {
  const auto dir = burrbench::testing::temp_dir("broken");
  write_analysis_input(dir, burrbench::testing::small_input());
  const std::string json = slurp(dir / "analysis.json"), csv = slurp(dir / "predictions.csv");
  const auto expect_error = [&](const std::string& j, const std::string& c, const std::string& what) {
    spit(dir / "analysis.json", j);
    spit(dir / "predictions.csv", c);
    try {
      read_analysis_input(dir);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const burrbench::InputError& e) {
      EXPECT_NE(std::string(e.what()).find(e.file()), std::string::npos) << what;
    }
  };
  std::string j = json;
  replace(j, "\"mode\"", "\"colour\": 1, \"mode\"");
  expect_error(j, csv, "unknown key");
  j = json;
  replace(j, "\"burrbench.analysis\"", "\"burrbench.fit\"");
  expect_error(j, csv, "wrong format");
  j = json;
  replace(j, "\"1.3\"", "\"2.0\"");
  expect_error(j, csv, "major version");
  expect_error("{ not json", csv, "not JSON");
  std::string c = csv;
  replace(c, "R2,", "R9,");
  expect_error(json, c, "unknown recording id");
  c = csv;
  replace(c, "\nR1,0.01,", "\nR1,nan,");
  expect_error(json, c, "NaN time");
  expect_error(json, csv.substr(0, csv.size() / 2), "truncated CSV");
  expect_error(json, "a,b\n", "wrong header");
  j = json;
  replace(j, "\"samples\": 200", "\"samples\": 1e12");
  expect_error(j, csv, "huge row count refused before allocating");
  // The inputs were not modified by reading (we only wrote them here).
  spit(dir / "analysis.json", json);
  spit(dir / "predictions.csv", csv);
  EXPECT_NO_THROW(read_analysis_input(dir));
}

namespace {
// R1 with moments, a spindle load and its energy; R2 with moments only.
AnalysisInput wrench_input() {
  auto in = burrbench::testing::small_input();
  for (std::size_t k = 0; k < 2; ++k) {
    auto& r = in.recordings[k];
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      r.torque_measured_Nmm.emplace_back(std::sin(r.t_s[i]), 0.1 * double(i), -1.0 / 3.0);
      r.torque_predicted_Nmm.push_back(r.torque_measured_Nmm.back() * 0.9);
      if (k == 1) continue;
      r.spindle_measured_Nmm.push_back(0.3 + 0.01 * std::cos(7 * r.t_s[i]));
      r.spindle_predicted_Nmm.push_back(0.31);
      r.spindle_offset_Nmm.push_back(0.3);
      r.spin_rad_s.push_back(3141.5926535897934);
    }
  }
  in.recordings[0].spindle_offset_source = "tare";
  in.recordings[0].energy = {{1, "compact", 500.0, 0.125, 62.5}};
  return in;
}
}  // namespace

TEST(AnalysisInput, WrenchSeriesRoundTripExactly) {
  const auto in = wrench_input();
  const auto dir = burrbench::testing::temp_dir("wrench");
  write_analysis_input(dir, in);
  ASSERT_TRUE(fs::exists(dir / "wrench.csv"));
  const auto back = read_analysis_input(dir);
  for (std::size_t k = 0; k < 2; ++k) {
    const auto& a = in.recordings[k];
    const auto& b = back.recordings[k];
    EXPECT_EQ(a.torque_measured_Nmm, b.torque_measured_Nmm);
    EXPECT_EQ(a.torque_predicted_Nmm, b.torque_predicted_Nmm);
    EXPECT_EQ(a.spindle_measured_Nmm, b.spindle_measured_Nmm);
    EXPECT_EQ(a.spindle_predicted_Nmm, b.spindle_predicted_Nmm);
    EXPECT_EQ(a.spindle_offset_Nmm, b.spindle_offset_Nmm);
    EXPECT_EQ(a.spin_rad_s, b.spin_rad_s);
    EXPECT_EQ(a.spindle_offset_source, b.spindle_offset_source);
    ASSERT_EQ(a.energy.size(), b.energy.size());
  }
  EXPECT_FALSE(back.recordings[1].has_spindle());
  EXPECT_EQ(back.recordings[0].energy[0].friction_energy_mJ, 62.5);
  EXPECT_EQ(back.recordings[0].energy[0].class_name, "compact");
  // Without moments or a spindle load nothing is written, and nothing is looked for.
  const auto plain = burrbench::testing::temp_dir("no_wrench");
  write_analysis_input(plain, burrbench::testing::small_input());
  EXPECT_FALSE(fs::exists(plain / "wrench.csv"));
  EXPECT_NO_THROW(read_analysis_input(plain));
}

TEST(AnalysisInput, OlderDirectoriesWithTheirHeadersAreReadAndMixedOnesRefused) {
  // 1.3 names the CSV columns as the prediction file's datasets; a 1.2 directory (older
  // headers) still reads to the same series, while 1.3 with an old header is refused.
  const auto in = wrench_input();
  const auto dir = burrbench::testing::temp_dir("v12");
  write_analysis_input(dir, in);
  std::string json = slurp(dir / "analysis.json"), pred = slurp(dir / "predictions.csv"),
              wrench = slurp(dir / "wrench.csv");
  EXPECT_NE(json.find("\"1.3\""), std::string::npos);
  replace(pred, "force_sensor_meas_N_x,force_sensor_meas_N_y,force_sensor_meas_N_z,force_sensor_pred_N_x,"
                "force_sensor_pred_N_y,force_sensor_pred_N_z",
          "measured_x_N,measured_y_N,measured_z_N,predicted_x_N,predicted_y_N,predicted_z_N");
  spit(dir / "predictions.csv", pred);
  EXPECT_THROW(read_analysis_input(dir), burrbench::InputError);  // 1.3 with a 1.2 header
  replace(wrench, "torque_sensor_meas_Nmm_x,torque_sensor_meas_Nmm_y,torque_sensor_meas_Nmm_z,"
                  "torque_sensor_pred_Nmm_x,torque_sensor_pred_Nmm_y,torque_sensor_pred_Nmm_z,"
                  "spindle_torque_meas_Nmm,spindle_torque_pred_Nmm",
          "torque_meas_x_Nmm,torque_meas_y_Nmm,torque_meas_z_Nmm,torque_pred_x_Nmm,torque_pred_y_Nmm,"
          "torque_pred_z_Nmm,spindle_meas_Nmm,spindle_pred_Nmm");
  spit(dir / "wrench.csv", wrench);
  replace(json, "\"1.3\"", "\"1.2\"");
  spit(dir / "analysis.json", json);
  const auto back = read_analysis_input(dir);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(back.recordings[k].predicted_N, in.recordings[k].predicted_N);
    EXPECT_EQ(back.recordings[k].torque_predicted_Nmm, in.recordings[k].torque_predicted_Nmm);
    EXPECT_EQ(back.recordings[k].spindle_measured_Nmm, in.recordings[k].spindle_measured_Nmm);
  }
}

TEST(AnalysisInput, BrokenWrenchFilesAreInputErrors) {
  const auto dir = burrbench::testing::temp_dir("wrench_broken");
  write_analysis_input(dir, wrench_input());
  const std::string json = slurp(dir / "analysis.json"), csv = slurp(dir / "wrench.csv");
  const auto expect_error = [&](const std::string& j, const std::string& c, const std::string& what,
                                const std::string& file) {
    spit(dir / "analysis.json", j);
    spit(dir / "wrench.csv", c);
    try {
      read_analysis_input(dir);
      ADD_FAILURE() << "accepted: " << what;
    } catch (const burrbench::InputError& e) {
      EXPECT_EQ(e.file(), (dir / file).string()) << what;
    }
  };
  std::string c = csv;
  replace(c, "\nR1,0.01,", "\nR1,0.011,");
  expect_error(json, c, "a time that is not the force row's", "wrench.csv");
  expect_error(json, csv.substr(0, csv.size() / 2), "truncated", "wrench.csv");
  expect_error(json, "recording_id,t_s\n", "wrong header", "wrench.csv");
  c = csv;
  c.insert(c.find('\n', c.find("\nR2,") + 1), "3141");  // spin speed in R2, which logged no spindle load
  expect_error(json, c, "a value in a channel not logged", "wrench.csv");
  std::string j = json;
  replace(j, "\"spindle_offset_source\": \"tare\"", "\"spindle_offset_source\": \"guess\"");
  expect_error(j, csv, "unknown offset source", "analysis.json");
  j = json;
  replace(j, "\"friction_energy_mJ\": 62.5", "\"friction_energy_mJ\": \"much\"");
  expect_error(j, csv, "energy not a number", "analysis.json");
  fs::remove(dir / "wrench.csv");
  spit(dir / "analysis.json", json);
  try {
    read_analysis_input(dir);
    ADD_FAILURE() << "accepted a missing wrench.csv";
  } catch (const burrbench::InputError& e) {
    EXPECT_EQ(e.file(), (dir / "wrench.csv").string());
  }
  spit(dir / "wrench.csv", csv);
  EXPECT_NO_THROW(read_analysis_input(dir));
}

TEST(Escaping, TextAndScriptJson) {
  EXPECT_EQ(html_escape("<script>alert(1)</script> & \"q\" 'a'"),
            "&lt;script&gt;alert(1)&lt;/script&gt; &amp; &quot;q&quot; &#39;a&#39;");
  const nlohmann::json j = {{"id", "</script><script>alert(1)</script>\u2028<!--"}};
  const std::string s = json_for_script(j);
  EXPECT_EQ(s.find('<'), std::string::npos);
  EXPECT_EQ(s.find('>'), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(s), j);  // still the same data for the page's JSON.parse
}
