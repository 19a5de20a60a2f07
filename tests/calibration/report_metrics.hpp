#pragma once
// What a test of `report DIR` on a calibrate directory reads back from the report's
// metrics.json: the RMSE and R² of the calibration samples over x, y, z together,
// combined from the three per-axis rows of "calibrate / all" (SSE = n·RMSE², SST =
// SSE/(1 − R²)), to compare with fit.json's metrics.calibration.rmse_xyz_N and r2_xyz:
// one definition of each metric, the fit's summary derived from the report's rows.
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

inline double pooled_calibrate_r2_xyz(const std::filesystem::path& metrics_json) {
  std::ifstream in(metrics_json);
  const auto metrics = nlohmann::json::parse(in);
  double sse = 0, sst = 0;
  int axes = 0;
  for (const auto& row : metrics.at("rows"))
    if (row["recording"] == "" && row["role"] == "calibrate" && row["segment"] == "all" && row["axis"] != "magnitude") {
      const double n = row["n"].get<double>(), rmse = row["rmse_N"].get<double>(), r2 = row["r2"].get<double>();
      sse += n * rmse * rmse;
      sst += n * rmse * rmse / (1 - r2);
      ++axes;
    }
  if (axes != 3) throw std::runtime_error(metrics_json.string() + ": expected 3 axis rows for calibrate / all");
  return 1 - sse / sst;
}

}  // namespace burrbench::calibration::testing
