#pragma once
// Report data for the tests, built in memory, and the prediction (with its context) that
// gives it, written with the real prediction writer for the command-line tests.
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "burrbench/analysis/report_data.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "temp_dir.hpp"

namespace burrbench::testing {

// Removed with its contents when the test ends.
inline test::TempDir temp_dir(const std::string& name) { return test::TempDir("burrbench-analysis-" + name); }

// Two recordings at 100 Hz, 2 s each: "R1" calibrate with segments plunge [0,1) and
// sweep [1,2); "R2" held out. Measured force: a smooth drilling-like profile; predicted:
// 5 % low with a 30 ms lag, so every metric is non-trivial. Scale > 1 → prediction
// further off (for failing gates).
inline analysis::ReportData small_input(double error_scale = 1.0) {
  using namespace analysis;
  ReportData in;
  in.mode = "validate";
  in.experiment_name = "unit";
  in.experiment_description = "synthetic series for the analysis tests";
  in.experiment_path = "/tmp/unit.toml";
  in.experiment_sha256 = std::string(64, 'a');
  in.context_of_use = "Test fixture.";
  in.seed = 7;
  in.model = {{"replay", "test fixture"}};
  in.calibration = {{"method", "none"}};
  in.limitations = {"fixture"};
  in.parameters = {{1, "compact", 20.0, 10.0, 0.3}};
  SampleInfo s{"S1", "/tmp/s1.h5", std::string(64, 'b'), 0.1, 10, 8, {}, 0.0, {}, {{1, "compact"}, {2, "trabecular"}}};
  for (std::size_t y = 0; y < 8; ++y)
    for (std::size_t x = 0; x < 10; ++x) {
      s.removed_depth_mm.push_back(float(std::max(0.0, 0.5 - 0.1 * std::hypot(x - 5.0, y - 4.0))));
      s.removed_class.push_back(s.removed_depth_mm.back() > 0 ? (x < 5 ? 1 : 2) : 0);
    }
  in.samples.push_back(s);
  for (int k = 0; k < 2; ++k) {
    RecordingSeries r;
    r.id = k == 0 ? "R1" : "R2";
    r.sample_id = "S1";
    r.role = k == 0 ? "calibrate" : "validate";
    r.path = "/tmp/" + r.id + ".h5";
    r.sha256 = std::string(64, 'c');
    if (k == 0) r.segments = {{"plunge", 0.0, 1.0}, {"sweep", 1.0, 2.0}};
    const auto force = [&](double t) {
      return glm::dvec3(std::sin(3 * t + k), 0.5 * std::cos(2 * t), 2.0 + std::sin(5 * t));
    };
    for (int i = 0; i < 200; ++i) {
      const double t = 0.01 * i;
      r.t_s.push_back(t);
      r.measured_N.push_back(force(t));
      r.predicted_N.push_back(force(t - 0.03 * error_scale) * (1.0 - 0.05 * error_scale));
      r.used.push_back(1);
    }
    in.recordings.push_back(std::move(r));
  }
  in.provenance = make_provenance({});
  return in;
}

// The prediction file's record of a ReportData whose recordings each carry one role: what
// validate would write for it (analysis::report_data inverts it; tested in test_report).
inline data_schema::Prediction prediction_of(const analysis::ReportData& in) {
  using nlohmann::json;
  data_schema::Prediction p;
  json recs = json::object(), samples = json::object(), params = json::array();
  for (const auto& c : in.parameters)
    params.push_back({{"class_label", c.class_label}, {"class_name", c.class_name},
                      {"alpha_N_per_mm2", c.alpha_N_per_mm2}, {"c1_N_per_mm2", c.c1_N_per_mm2}, {"mu", c.mu}});
  for (const auto& s : in.samples) {
    json classes = json::object();
    for (const auto& [label, name] : s.classes) classes[std::to_string(label)] = name;
    samples[s.id] = {{"path", s.path}, {"sha256", s.sha256}, {"classes", classes}};
    p.removed.push_back({s.id, s.voxel_mm, s.nx, s.ny, s.removed_depth_mm, s.removed_class, s.removed_volume_mm3});
  }
  for (const auto& r : in.recordings) {
    json segs = json::array();
    for (const auto& g : r.segments) segs.push_back({{"label", g.label}, {"start_s", g.start_s}, {"end_s", g.end_s}, {"role", r.role}});
    json events = json::array();
    for (const auto& e : r.quality.events) events.push_back({{"t_s", e.t_s}, {"kind", e.kind}, {"stream", e.stream}, {"detail", e.detail}});
    recs[r.id] = {{"sample", r.sample_id}, {"path", r.path}, {"sha256", r.sha256}, {"notes", r.notes},
                  {"registration", r.registration}, {"segments", segs},
                  {"quality", {{"dropped_force_samples", r.quality.dropped_force_samples},
                               {"stale_rows", r.quality.stale_rows}, {"events", events}}}};
    data_schema::PredictedRecording q;
    const std::size_t n = r.t_s.size();
    q.recording_id = r.id;
    q.role = r.role;
    q.t_s = r.t_s;
    q.force_sensor_meas_N = r.measured_N;
    q.force_sensor_pred_N = r.predicted_N;
    q.force_burr_vol_N = r.predicted_N;
    q.centre_vol_mm = q.normal_vol = std::vector<glm::dvec3>(n, glm::dvec3(0));
    q.depth_b_mm = std::vector<double>(n, 0.0);
    q.class_mask = q.buried = std::vector<std::uint8_t>(n, 0);
    q.use = r.used;
    (r.role == "calibrate" ? q.used_calibrate : q.used_validate) = r.used;
    (r.role == "calibrate" ? q.used_validate : q.used_calibrate) = std::vector<std::uint8_t>(n, 0);
    q.band95_N = r.band95_N;
    q.torque_sensor_meas_Nmm = r.torque_measured_Nmm;
    q.torque_sensor_pred_Nmm = r.torque_predicted_Nmm;
    q.spindle_torque_meas_Nmm = r.spindle_measured_Nmm;
    q.spindle_torque_pred_Nmm = r.spindle_predicted_Nmm;
    q.spindle_offset_Nmm = r.spindle_offset_Nmm;
    q.spin_rad_s = r.spin_rad_s;
    if (r.has_spindle()) q.spindle_offset_source = r.spindle_offset_source;
    for (const auto& e : r.energy) {
      q.removed_mm3[std::size_t(e.class_label)] = e.removed_mm3;
      q.friction_energy_mJ[std::size_t(e.class_label)] = e.friction_energy_mJ;
    }
    p.recordings.push_back(std::move(q));
  }
  p.context = {{"made_by", in.mode},
               {"experiment", {{"name", in.experiment_name}, {"description", in.experiment_description},
                               {"path", in.experiment_path}, {"sha256", in.experiment_sha256}}},
               {"context_of_use", in.context_of_use}, {"seed", in.seed},
               {"params", {{"path", in.params_path}, {"sha256", in.params_sha256}}},
               {"model", in.model}, {"calibration", in.calibration}, {"findings", in.limitations},
               {"parameters", params}, {"samples", samples}, {"recordings", recs}};
  if (!in.verification.is_null()) p.context["verification"] = in.verification;
  p.provenance = in.provenance;
  return p;
}

}  // namespace burrbench::testing
