#pragma once
// Reading a JSON file of ours within budget: an existing regular file of at most 256 MiB,
// nested at most kMaxNesting deep (checked before nlohmann recurses), valid JSON.
// InputError naming the file (and the byte, for a syntax error) otherwise.
#include <cstdint>
#include <filesystem>

#include <nlohmann/json.hpp>

namespace burrbench::data_schema {

inline constexpr std::uintmax_t kMaxJsonBytes = 256u << 20;

nlohmann::json read_json_file(const std::filesystem::path& path);

}  // namespace burrbench::data_schema
