#include "burrbench/data_schema/json_input.hpp"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/nesting.hpp"

namespace burrbench::data_schema {

nlohmann::json read_json_file(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(file, "<file>", "an existing regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxJsonBytes) throw InputError(file, "<file>", "a JSON file of at most 256 MiB");
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  check_json_nesting(text, file);  // before nlohmann::json recurses
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file, fmt::format("byte {}", e.byte), "valid JSON", e.what());
  }
}

}  // namespace burrbench::data_schema
