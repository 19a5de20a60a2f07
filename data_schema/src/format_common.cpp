#include "format_common.hpp"

#include <charconv>
#include <cmath>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/version.hpp"

namespace burrbench::data_schema::detail {

Provenance stamped(Provenance p) {
  if (p.software_version.empty() || p.created_utc.empty()) {
    const Provenance now = make_provenance({});
    if (p.software_version.empty()) p.software_version = now.software_version;
    if (p.created_utc.empty()) p.created_utc = now.created_utc;
    if (p.command_line.empty()) p.command_line = now.command_line;
  }
  return p;
}

bool finite(double x) { return std::isfinite(x); }

}  // namespace burrbench::data_schema::detail

namespace burrbench::data_schema {

std::string version_string(int major, int minor) { return fmt::format("{}.{}", major, minor); }

void check_version(const std::string& file, const std::string& field, const std::string& version,
                   int major) {
  const std::string want = fmt::format("version \"{}.x\" (major {} is what this build reads)", major, major);
  const auto dot = version.find('.');
  int got_major = -1, got_minor = -1;
  if (dot != std::string::npos) {
    const char* b = version.data();
    const auto r1 = std::from_chars(b, b + dot, got_major);
    const auto r2 = std::from_chars(b + dot + 1, b + version.size(), got_minor);
    if (r1.ec != std::errc() || r1.ptr != b + dot || r2.ec != std::errc() ||
        r2.ptr != b + version.size() || dot == 0)
      got_major = -1;
  }
  if (got_major < 0 || got_minor < 0) throw InputError(file, field, want, "\"" + version + "\"");
  if (got_major != major)
    throw InputError(file, field, want, fmt::format("\"{}\" (unknown major version)", version));
}

void check_format(const std::string& file, const std::string& field, const std::string& got,
                  const std::string& want) {
  if (got != want) throw InputError(file, field, "\"" + want + "\"", "\"" + got + "\"");
}

}  // namespace burrbench::data_schema
