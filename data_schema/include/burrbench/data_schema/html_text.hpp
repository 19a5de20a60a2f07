#pragma once
// Text from files (ids, names, notes, paths) placed in the HTML pages burrbench writes —
// the validation report (analysis/) and the study report (study/): one escaping for
// both, here because both folders may use data_schema and neither may use the other.
#include <string>
#include <string_view>

namespace burrbench::data_schema {

// & < > " ' → entities: safe in HTML text and in quoted attribute values.
std::string html_escape(std::string_view s);

}  // namespace burrbench::data_schema
