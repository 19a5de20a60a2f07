#include "burrbench/data_schema/toml_input.hpp"

#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/nesting.hpp"

namespace burrbench::data_schema {

namespace {
constexpr std::uintmax_t kMaxTomlBytes = 16u << 20;
}

toml::table parse_toml_file(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(file, "<file>", "an existing regular file");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || size > kMaxTomlBytes)
    throw InputError(file, "<file>", "a TOML file of at most 16 MiB", ec ? ec.message() : std::to_string(size) + " bytes");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(file, "<file>", "a readable file");
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_toml_text(ss.str(), file);
}

toml::table parse_toml_text(std::string_view text, const std::string& file) {
  if (text.size() > kMaxTomlBytes)
    throw InputError(file, "<file>", "a TOML file of at most 16 MiB", std::to_string(text.size()) + " bytes");
  check_toml_nesting(text, file);  // before toml++ recurses
  try {
    return toml::parse(text, file);
  } catch (const toml::parse_error& e) {
    const auto& b = e.source().begin;
    throw InputError(file, fmt::format("line {} column {}", b.line, b.column), "valid TOML",
                     std::string(e.description()));
  }
}

}  // namespace burrbench::data_schema

