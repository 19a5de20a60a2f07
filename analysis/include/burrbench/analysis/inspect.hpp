#pragma once
// `burrbench inspect` for analysis's own formats (criteria, metrics):
// each file is read and validated by the reader the commands use, then summarised.
#include <filesystem>
#include <optional>
#include <string>

namespace burrbench::analysis {

// The summary when `declared_format` is one of analysis's formats, else nullopt (the file
// is data_schema's to describe). InputError when the file is invalid.
std::optional<std::string> describe_file(const std::filesystem::path& path, const std::string& declared_format);

}  // namespace burrbench::analysis
