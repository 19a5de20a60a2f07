#pragma once
// Whether two paths name one file: through another spelling, a symlink or a hard link.
// Used to keep outputs off inputs (apps/output_paths.hpp) and to tell a recording file
// listed twice from two drillings (model::predict_experiment).
#include <filesystem>

namespace burrbench::data_schema {

inline bool same_file(const std::filesystem::path& a, const std::filesystem::path& b) {
  std::error_code ec;
  if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec)) return std::filesystem::equivalent(a, b, ec);
  return std::filesystem::weakly_canonical(a, ec) == std::filesystem::weakly_canonical(b, ec);
}

}  // namespace burrbench::data_schema
