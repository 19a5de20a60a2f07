#pragma once
// Splits a fuzz input at a marker: the part before is the main file, the part after a
// second in-memory file (a detached NRRD/MetaImage data file, or a CSV column map).
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>
#include <utility>

namespace burrbench::fuzz {

inline constexpr std::string_view kMarker{"\0\0FILE\0\0", 8};

inline std::pair<std::string_view, std::optional<std::string_view>> split(const std::uint8_t* data, std::size_t size) {
  const std::string_view all(reinterpret_cast<const char*>(data), size);
  const auto at = all.find(kMarker);
  if (at == std::string_view::npos) return {all, std::nullopt};
  return {all.substr(0, at), all.substr(at + kMarker.size())};
}

}  // namespace burrbench::fuzz
