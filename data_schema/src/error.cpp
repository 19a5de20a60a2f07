#include "burrbench/data_schema/error.hpp"

#include <cstdio>
#include <cstdlib>
#include <exception>

#include <fmt/format.h>

namespace burrbench {

namespace {
std::string compose(const std::string& file, const std::string& field,
                    const std::string& expected, const std::string& got) {
  std::string m = fmt::format("{}: {}: expected {}", file.empty() ? "<input>" : file,
                              field.empty() ? "<file>" : field, expected);
  if (!got.empty()) m += fmt::format(", got {}", got);
  return m;
}
}  // namespace

InputError::InputError(std::string file, std::string field, std::string expected,
                       std::string got)
    : std::runtime_error(compose(file, field, expected, got)),
      file_(std::move(file)),
      field_(std::move(field)),
      expected_(std::move(expected)),
      got_(std::move(got)) {}

namespace {
thread_local std::string g_reading, g_failed_reading;
}  // namespace

ReadingFile::ReadingFile(std::string path) : previous_(std::move(g_reading)), exceptions_(std::uncaught_exceptions()) {
  g_reading = std::move(path);
}

ReadingFile::~ReadingFile() {
  // Unwinding from a failure inside this reader: remember the innermost file for main.
  if (std::uncaught_exceptions() > exceptions_ && g_failed_reading.empty()) g_failed_reading = g_reading;
  g_reading = std::move(previous_);
}

const std::string& file_being_read() { return g_failed_reading.empty() ? g_reading : g_failed_reading; }

void invariant_failed(const char* expr, const char* file, int line, const std::string& detail) {
  throw InvariantError(fmt::format("internal check failed: {} ({}:{}) {}", expr, file, line, detail));
}

void unreachable(const char* file, int line) noexcept {
  std::fprintf(stderr, "burrbench: internal error: unreachable code reached (%s:%d)\n", file, line);
  std::abort();
}

}  // namespace burrbench
