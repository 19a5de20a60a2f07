#pragma once
// Errors shared by every folder. Bad input raises InputError, whose message names the
// file, the field and what was expected; `main` prints it as one line and exits 2.
// Broken programmer invariants raise InvariantError through BURRBENCH_CHECK (always on);
// code after an exhaustive enum switch is BURRBENCH_UNREACHABLE() (aborts, always on).
#include <stdexcept>
#include <string>

namespace burrbench {

class InputError : public std::runtime_error {
 public:
  // Message: "<file>: <field>: expected <expected>" (got appended when given).
  InputError(std::string file, std::string field, std::string expected, std::string got = {});
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }
  const std::string& expected() const { return expected_; }
  const std::string& got() const { return got_; }
  // The same error about one part of a larger input: "<file>: <field> (<part>): …".
  InputError in(const std::string& part) const { return {file_, field_ + " (" + part + ")", expected_, got_}; }

 private:
  std::string file_, field_, expected_, got_;
};

class InvariantError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

// The input file a reader is reading, for failures that cannot name it themselves: an
// std::bad_alloc from a file too large for this machine is reported as "FILE: out of
// memory while reading it" (exit 3). Readers hold one for their duration; they nest.
class ReadingFile {
 public:
  explicit ReadingFile(std::string path);
  ~ReadingFile();
  ReadingFile(const ReadingFile&) = delete;
  ReadingFile& operator=(const ReadingFile&) = delete;

 private:
  std::string previous_;
  int exceptions_;
};
// The innermost file being read when an exception left a reader (else the one being
// read now, else "").
const std::string& file_being_read();

[[noreturn]] void invariant_failed(const char* expr, const char* file, int line,
                                   const std::string& detail);
// Prints "burrbench: internal error: unreachable code reached (FILE:LINE)" and aborts.
[[noreturn]] void unreachable(const char* file, int line) noexcept;

}  // namespace burrbench

#define BURRBENCH_CHECK(cond, detail)                                          \
  do {                                                                         \
    if (!(cond)) ::burrbench::invariant_failed(#cond, __FILE__, __LINE__, detail); \
  } while (0)

// After a switch that returns for every enumerator (no `default:`, so -Wswitch names a
// new enumerator left out). Reached only with a value outside the enum: never from a file,
// whose enums are parsed from names and refused there (exit 2). Aborts in every build
// rather than __builtin_unreachable(): a wrong value must not become undefined behaviour.
#define BURRBENCH_UNREACHABLE() ::burrbench::unreachable(__FILE__, __LINE__)
