#pragma once
// The versions of the libraries the command line links, for the report's reproducibility
// section (analysis/ does not link them itself).
#include <string>
#include <utility>
#include <vector>

namespace burrbench::apps {
std::vector<std::pair<std::string, std::string>> library_versions();
}  // namespace burrbench::apps
