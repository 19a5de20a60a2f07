#include <string>

#include "burrbench/analysis/report.hpp"

namespace burrbench::analysis {

// ensure_ascii turns U+2028/2029 into \u escapes; <, > and & are escaped too, so no
// "</script>" or "<!--" can appear — all valid inside JSON strings, the only place
// these characters can occur in a JSON text.
std::string json_for_script(const nlohmann::json& j) {
  const std::string raw = j.dump(-1, ' ', true, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(raw.size());
  for (char c : raw) {
    switch (c) {
      case '<': out += "\\u003c"; break;
      case '>': out += "\\u003e"; break;
      case '&': out += "\\u0026"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace burrbench::analysis
