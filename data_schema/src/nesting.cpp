#include "burrbench/data_schema/nesting.hpp"

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema {
namespace {

[[noreturn]] void too_deep(const std::string& file, std::size_t line, const char* what) {
  throw InputError(file, fmt::format("line {}", line), fmt::format("{} nested at most {} deep", what, kMaxNesting),
                   "deeper");
}

}  // namespace

void check_json_nesting(std::string_view t, const std::string& file) {
  int depth = 0;
  std::size_t line = 1;
  bool in_string = false;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '\n') ++line;
    if (in_string) {
      if (c == '\\') ++i;  // the escaped character cannot end the string
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '[' || c == '{') {
      if (++depth > kMaxNesting) too_deep(file, line, "arrays and objects");
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
}

// A lexer just good enough to skip strings and comments: brackets and braces outside them
// count as nesting, and so does each '.' of a run not broken by '=', ',', a bracket or a
// line end (a dotted key a.b.c…; a value holds at most one '.', as in 1.5 or a time).
void check_toml_nesting(std::string_view t, const std::string& file) {
  int depth = 0, dots = 0;
  std::size_t line = 1;
  for (std::size_t i = 0; i < t.size(); ++i) {
    const char c = t[i];
    if (c == '\n') {
      ++line;
      dots = 0;
      continue;
    }
    if (c == '#') {
      while (i + 1 < t.size() && t[i + 1] != '\n') ++i;
      continue;
    }
    if (c == '"' || c == '\'') {
      const bool multi = t.substr(i, 3) == std::string(3, c);
      const std::string_view close = multi ? std::string_view(c == '"' ? "\"\"\"" : "'''") : std::string_view(&t[i], 1);
      std::size_t j = i + (multi ? 3 : 1);
      for (; j < t.size(); ++j) {
        if (c == '"' && t[j] == '\\') {
          ++j;
          continue;
        }
        if (t[j] == '\n') {
          if (!multi) break;  // a basic string ends at the line (toml++ reports the error)
          ++line;
        }
        if (t.substr(j, close.size()) == close) break;
      }
      i = multi ? j + 2 : j;
      if (i < t.size() && t[i] == '\n') --i;  // let the loop count the line end
      continue;
    }
    if (c == '[' || c == '{') {
      dots = 0;
      if (++depth > kMaxNesting) too_deep(file, line, "arrays and tables");
    } else if (c == ']' || c == '}') {
      dots = 0;
      if (depth > 0) --depth;
    } else if (c == '=' || c == ',') {
      dots = 0;
    } else if (c == '.' && ++dots > kMaxNesting) {
      too_deep(file, line, "dotted keys");
    }
  }
}

}  // namespace burrbench::data_schema
