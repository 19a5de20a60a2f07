#pragma once
// Nesting limits checked before a parser recurses: toml++ and nlohmann::json recurse once
// per level, so a small file nested 10⁴–10⁵ deep would overflow the stack (signal 11)
// instead of giving an input error. No burrbench file nests deeper than a handful.
#include <string>
#include <string_view>

namespace burrbench::data_schema {

inline constexpr int kMaxNesting = 64;  // arrays/tables (JSON, TOML), dotted-key parts (TOML)

// InputError(file, "<file>", …) naming the line when `text` nests deeper than kMaxNesting.
void check_json_nesting(std::string_view text, const std::string& file_for_messages);
void check_toml_nesting(std::string_view text, const std::string& file_for_messages);

}  // namespace burrbench::data_schema
