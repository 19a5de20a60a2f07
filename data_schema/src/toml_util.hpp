#pragma once
// The [provenance] table of our TOML outputs (parameter set, ...), read strictly.
#include <toml++/toml.h>

#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace burrbench::data_schema::detail {

// [provenance] table: software_version, command_line, created_utc, inputs = [{path, sha256}].
toml::table provenance_to_toml(const Provenance& p);
Provenance provenance_from_toml(const TomlView& v);

}  // namespace burrbench::data_schema::detail
