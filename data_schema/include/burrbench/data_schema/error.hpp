#pragma once
// Errors shared by every folder. Bad input raises InputError, whose message names the
// file, the field and what was expected; `main` prints it as one line and exits 2.
// Broken programmer invariants raise InvariantError through BURRBENCH_CHECK (always on).
#include <stdexcept>
#include <string>

namespace burrbench {

class InputError : public std::runtime_error {
 public:
  // Message: "<file>: <field>: expected <expected>" (got appended when given).
  InputError(std::string file, std::string field, std::string expected, std::string got = {});
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }

 private:
  std::string file_, field_;
};

class InvariantError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

[[noreturn]] void invariant_failed(const char* expr, const char* file, int line,
                                   const std::string& detail);

}  // namespace burrbench

#define BURRBENCH_CHECK(cond, detail)                                          \
  do {                                                                         \
    if (!(cond)) ::burrbench::invariant_failed(#cond, __FILE__, __LINE__, detail); \
  } while (0)
