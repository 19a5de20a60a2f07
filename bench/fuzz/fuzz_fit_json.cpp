// libFuzzer target: read_fit, i.e. the bounded JSON read (nesting pre-scan, nlohmann),
// the strict JsonView and the fit's validation. read_fit takes a path, so each input is
// written to a private temp file first.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"

namespace {
std::filesystem::path file() {
  static const std::filesystem::path p = [] {
    const auto d = std::filesystem::temp_directory_path() / ("burrbench-fuzz-fit-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    return d / "fit.json";
  }();
  return p;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  {
    std::ofstream out(file(), std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    burrbench::data_schema::read_fit(file());
  } catch (const burrbench::InputError&) {
  }
  return 0;
}
