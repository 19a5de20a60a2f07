// libFuzzer target: read_manifest (the experiment manifest's TOML parsing and checks).
// read_manifest takes a path, so each input is written to a private temp folder that
// also holds the files the seed manifest names, letting inputs get past the existence
// checks into the deeper validation.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/manifest.hpp"

namespace {
std::filesystem::path folder() {
  static const std::filesystem::path dir = [] {
    auto d = std::filesystem::temp_directory_path() / ("burrbench-fuzz-manifest-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    for (const char* f : {"sample.h5", "plunge.h5", "sweep.h5"}) std::ofstream(d / f) << "x";
    return d;
  }();
  return dir;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto path = folder() / "manifest.toml";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    burrbench::data_schema::read_manifest(path);
  } catch (const burrbench::InputError&) {
  }
  return 0;
}
