#pragma once
// Helpers every format shares: the "major.minor" version rule and provenance stamping.
#include <string>

#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema::detail {

std::string version_string(int major, int minor);
// Accepts "M.m" with M == major (any minor: a newer minor only adds optional keys, which
// this reader rejects as unknown if present). Otherwise InputError(file, field, ...).
void check_version(const std::string& file, const std::string& field, const std::string& version,
                   int major);
// Format name check with a clear message.
void check_format(const std::string& file, const std::string& field, const std::string& got,
                  const std::string& want);
// Fills software version, command line and time when the caller left them empty.
Provenance stamped(Provenance p);
// A finite number check used by validators.
bool finite(double x);

}  // namespace burrbench::data_schema::detail
