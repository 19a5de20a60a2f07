#pragma once
// Format detection and human summaries of every burrbench file (`burrbench inspect`).
#include <filesystem>
#include <string>

namespace burrbench::data_schema {

enum class FileFormat { kRecording, kSample, kParams, kManifest, kFit, kPrediction };
const char* format_name(FileFormat f);  // "burrbench.recording", ...

// The `format` string a file declares (HDF5 root attribute, or the `format` key of a TOML
// or JSON file), whatever it is. InputError when the file declares none.
std::string declared_format(const std::filesystem::path& path);
// detect_format: the declared format, when it is one of data_schema's. InputError when the
// file is none of ours (analysis's criteria, metrics and analysis files are inspected by
// the inspect verb, which knows both folders).
FileFormat detect_format(const std::filesystem::path& path);

// Reads the file with its full validation and returns a multi-line summary (dims,
// classes and voxel counts; streams, rates, durations, events; parameters; predicted
// recordings ...).
// InputError (naming file, field, expectation) when the file is invalid.
std::string describe_file(const std::filesystem::path& path);

}  // namespace burrbench::data_schema
