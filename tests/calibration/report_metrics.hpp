#pragma once
// What a test of `report DIR` on a calibrate directory reads back from the report's
// metrics.json: the pooled RMSE of the calibration samples (the three axes' rows of
// "calibrate / all" combined), to compare with fit.json's metrics.calibration.rmse_N.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

namespace burrbench::calibration::testing {

inline double pooled_calibrate_rmse_N(const std::filesystem::path& metrics_json) {
  std::ifstream in(metrics_json);
  const auto metrics = nlohmann::json::parse(in);
  double sq = 0;
  int axes = 0;
  for (const auto& row : metrics.at("rows"))
    if (row["recording"] == "" && row["role"] == "calibrate" && row["segment"] == "all" && row["axis"] != "magnitude") {
      sq += std::pow(row["rmse_N"].get<double>(), 2);
      ++axes;
    }
  if (axes != 3) throw std::runtime_error(metrics_json.string() + ": expected 3 axis rows for calibrate / all");
  return std::sqrt(sq / 3);
}

}  // namespace burrbench::calibration::testing
