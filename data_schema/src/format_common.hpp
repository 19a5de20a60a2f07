#pragma once
// Helpers every format shares: provenance stamping (the version rule is public:
// burrbench/data_schema/format_version.hpp).
#include <string>

#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema::detail {

// Fills software version, command line and time when the caller left them empty.
Provenance stamped(Provenance p);
// A finite number check used by validators.
bool finite(double x);

}  // namespace burrbench::data_schema::detail
