#pragma once
// The burrbench executable a C++ test runs, shared by every test folder.
#include <cstdlib>
#include <string>

namespace burrbench::testing {

// $BURRBENCH (set by CTest), else the one on PATH.
inline std::string burrbench_cli() {
  const char* b = std::getenv("BURRBENCH");
  return b ? b : "burrbench";
}

}  // namespace burrbench::testing
