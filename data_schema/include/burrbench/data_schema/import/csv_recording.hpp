#pragma once
// Recordings from CSV exports (LabVIEW / NI). A header of canonical names
//   t_s,x_mm,y_mm,z_mm,fx_N,fy_N,fz_N[,tx_Nmm,ty_Nmm,tz_Nmm][,spindle_rpm]
// imports as is; other layouts need a TOML column map (docs/importers.md).
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "burrbench/data_schema/recording.hpp"

namespace burrbench::data_schema::import {

inline constexpr const char* kCsvMapFormat = "burrbench.csv_map";
inline constexpr std::size_t kMaxCsvBytes = std::size_t{1} << 30;  // 1 GiB

// Parses CSV text (and an optional map's TOML text) into a Recording with one stream
// "csv". Errors name the file, line number and column. Provenance is left empty.
Recording parse_csv_recording(std::string_view csv, const std::string& csv_name,
                              std::optional<std::string_view> map_toml = std::nullopt,
                              const std::string& map_name = {});

Recording read_csv_recording(const std::filesystem::path& csv,
                             const std::optional<std::filesystem::path>& map = std::nullopt);

}  // namespace burrbench::data_schema::import
