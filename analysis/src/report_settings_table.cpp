// fit.json's settings and the run's context as tables a reviewer reads, not raw JSON.
#include <algorithm>

#include "report_page.hpp"

namespace burrbench::analysis {

namespace {

// Whether every element (of a list) or value (of an object) is a record with the same
// non-empty set of fields as the first: then they read best as one table.
bool like_records(const json& v) {
  if (v.empty() || !v.begin()->is_object() || v.begin()->empty()) return false;
  const json& first = *v.begin();
  return std::all_of(v.begin(), v.end(), [&](const json& e) {
    if (!e.is_object() || e.size() != first.size()) return false;
    for (const auto& [k, _] : first.items())
      if (!e.contains(k)) return false;
    return true;
  });
}

// Records as a table, their fields as columns; each row headed by its name (an object's
// key) or by nothing (a list's element).
std::string records_table(const json& v) {
  const json& first = *v.begin();
  std::string h = "<table><tr>";
  if (v.is_object()) h += "<th></th>";
  for (const auto& [k, _] : first.items()) h += "<th>" + esc(k) + "</th>";
  h += "</tr>";
  for (auto it = v.begin(); it != v.end(); ++it) {
    h += "<tr>";
    if (v.is_object()) h += "<th>" + esc(it.key()) + "</th>";
    for (const auto& [k, _] : first.items()) h += td(value_html(it->at(k)), it->at(k).is_number());
    h += "</tr>";
  }
  return h + "</table>";
}

}  // namespace

// One value of a settings table as a reader takes it in: a real number to 6 significant
// digits (the JSON file keeps every digit), null as "—", a flag as yes/no, an object as a
// nested table, a list of texts (warnings) as a list, records of the same fields (the
// stages, the registration of each recording) as one table. Anything else stays JSON.
std::string value_html(const json& v) {
  if (v.is_null()) return "—";
  if (v.is_string()) return esc(v.get<std::string>());
  if (v.is_boolean()) return v.get<bool>() ? "yes" : "no";
  if (v.is_number_float()) return num(v.get<double>(), 6);
  if (v.is_number()) return v.dump();
  if (v.empty()) return v.is_object() ? "—" : "none";
  if ((v.is_array() || v.size() >= 2) && like_records(v)) return records_table(v);
  if (v.is_object()) return kv_table(v);
  const auto all = [&](auto pred) { return std::all_of(v.begin(), v.end(), pred); };
  if (all([](const json& e) { return e.is_string(); })) {
    std::string h = "<ul>";
    for (const auto& e : v) h += "<li>" + esc(e.get<std::string>()) + "</li>";
    return h + "</ul>";
  }
  if (all([](const json& e) { return e.is_primitive(); })) {
    std::string h;
    for (const auto& e : v) h += (h.empty() ? "" : ", ") + value_html(e);
    return h;
  }
  return "<code>" + esc(v.dump()) + "</code>";
}

std::string kv_table(const json& j) {
  std::string h = "<table>";
  for (const auto& [k, v] : j.items()) h += "<tr><th>" + esc(k) + "</th>" + td(value_html(v)) + "</tr>";
  return h + "</table>";
}

}  // namespace burrbench::analysis
