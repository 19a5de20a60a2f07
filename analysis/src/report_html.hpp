#pragma once
// Small HTML helpers shared by the report's section writers (report*.cpp).
#include <cmath>
#include <string>
#include <string_view>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/analysis/report.hpp"

namespace burrbench::analysis::html {

// A number for a table cell: `prec` significant digits, "n/a" when not finite.
inline std::string num(double v, int prec = 4) {
  if (!std::isfinite(v)) return "n/a";
  return fmt::format("{:.{}g}", v, prec);
}

inline std::string esc(std::string_view s) { return html_escape(s); }

inline std::string td(const std::string& text_already_escaped, bool numeric = false) {
  return fmt::format("<td{}>{}</td>", numeric ? " class=\"num\"" : "", text_already_escaped);
}

}  // namespace burrbench::analysis::html

namespace burrbench::analysis {
// The section writers' shared vocabulary (this header is private to analysis/src).
using html::esc;
using html::num;
using html::td;
using nlohmann::json;
}  // namespace burrbench::analysis
