#pragma once
// Splits a fuzz input at a marker: the part before is the main file, the part after a
// second in-memory file (a detached NRRD/MetaImage data file, or a CSV column map).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"

namespace burrbench::fuzz {

inline constexpr std::string_view kMarker{"\0\0FILE\0\0", 8};

inline std::pair<std::string_view, std::optional<std::string_view>> split(const std::uint8_t* data, std::size_t size) {
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  const auto at = all.find(kMarker);
  if (at == std::string_view::npos) return {all, std::nullopt};
  return {all.substr(0, at), all.substr(at + kMarker.size())};
}

// One fuzz run of a volume header parser (NRRD, MetaImage): the detached data file, if
// the header names one, is the part after the marker. InputError is the only acceptable
// outcome for bad input; anything else is a finding.
template <class Parse>
int fuzz_volume_parser(const std::uint8_t* data, std::size_t size, Parse parse) {
  using namespace burrbench::data_schema::import;
  const auto [header, detached] = split(data, size);
  const DataFileReader reader = [d = detached](const std::string& name) -> std::string {
    if (!d) throw burrbench::InputError("fuzz", "data file", "an in-memory data file", name);
    return std::string(*d);
  };
  ImportLimits lim;
  lim.max_bytes = std::size_t{64} << 20;  // stay far below libFuzzer's 2 GB RSS limit
  try {
    parse(header, "fuzz", reader, lim);
  } catch (const burrbench::InputError&) {
  }
  return 0;
}

}  // namespace burrbench::fuzz
