#pragma once
// Parsing a TOML input (manifest, parameters, protocol, rig map, CSV map) with the house
// error rule: a syntax error becomes an InputError naming the file, line and column.
#include <filesystem>
#include <string>
#include <string_view>

#include <toml++/toml.h>

namespace burrbench::data_schema {

// At most 16 MiB; larger inputs are refused before reading them whole.
toml::table parse_toml_file(const std::filesystem::path& path);
toml::table parse_toml_text(std::string_view text, const std::string& file_for_messages);

}  // namespace burrbench::data_schema
