#pragma once
// The "format" / "format_version" rule of every burrbench file (TOML, JSON, HDF5, CSV
// headers): the format name must match; the version is "M.m" and a reader accepts any
// minor of its own major M (a newer minor only adds optional keys, which a reader of an
// older minor refuses as unknown if present). One check, one message, everywhere.
#include <string>

namespace burrbench::data_schema {

std::string version_string(int major, int minor);
// InputError(file, field, 'version "M.x" (major M is what this build reads)', got).
void check_version(const std::string& file, const std::string& field, const std::string& version,
                   int major);
// InputError(file, field, "\"want\"", "\"got\"") unless got == want.
void check_format(const std::string& file, const std::string& field, const std::string& got,
                  const std::string& want);

}  // namespace burrbench::data_schema
