#pragma once
// Analysis inputs for the tests, built in memory and written with the real writer.
#include <cmath>
#include <filesystem>
#include <numbers>
#include <string>

#include "burrbench/analysis/analysis_input.hpp"
#include "temp_dir.hpp"

namespace burrbench::testing {

// Removed with its contents when the test ends.
inline test::TempDir temp_dir(const std::string& name) { return test::TempDir("burrbench-analysis-" + name); }

// Two recordings at 100 Hz, 2 s each: "R1" calibrate with segments plunge [0,1) and
// sweep [1,2); "R2" held out. Measured force: a smooth drilling-like profile; predicted:
// 5 % low with a 30 ms lag, so every metric is non-trivial. Scale > 1 → prediction
// further off (for failing gates).
inline analysis::AnalysisInput small_input(double error_scale = 1.0) {
  using namespace analysis;
  AnalysisInput in;
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

}  // namespace burrbench::testing
