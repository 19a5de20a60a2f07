#include "toml_util.hpp"

namespace burrbench::data_schema::detail {

toml::table provenance_to_toml(const Provenance& p) {
  toml::array inputs;
  for (const auto& f : p.inputs) inputs.push_back(toml::table{{"path", f.path}, {"sha256", f.sha256}});
  return toml::table{{"software_version", p.software_version},
                     {"command_line", p.command_line},
                     {"created_utc", p.created_utc},
                     {"inputs", inputs}};
}

Provenance provenance_from_toml(const TomlView& v) {
  Provenance p;
  p.software_version = v.str("software_version");
  p.command_line = v.str("command_line");
  p.created_utc = v.str("created_utc");
  for (auto& f : v.tables("inputs")) {
    p.inputs.push_back({f.str("path"), f.str("sha256")});
    f.done();
  }
  v.done();
  return p;
}

}  // namespace burrbench::data_schema::detail
