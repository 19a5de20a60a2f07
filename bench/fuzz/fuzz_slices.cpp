// libFuzzer target: a TIFF/PNG slice stack (read_slice_stack through OpenCV's decoders).
// The input is the first slice, and after the marker (fuzz_split.hpp) an optional second
// one; each is named .png when it starts with the PNG signature, else .tif.
#include <filesystem>
#include <system_error>

#include "burrbench/data_schema/import/volume.hpp"
#include "fuzz_file.hpp"
#include "fuzz_split.hpp"

namespace {
const std::filesystem::path& stack() {
  static const std::filesystem::path d = burrbench::fuzz::scratch() / "stack";
  return d;
}

void put_slice(const char* stem, std::string_view bytes) {
  const bool png = bytes.substr(0, 8) == std::string_view("\x89PNG\r\n\x1a\n", 8);
  std::filesystem::path p = stack() / (std::string(stem) + (png ? ".png" : ".tif"));
  std::filesystem::rename(burrbench::fuzz::put("slice", bytes), p);
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  using namespace burrbench::data_schema::import;
  std::error_code ec;
  std::filesystem::remove_all(stack(), ec);
  std::filesystem::create_directories(stack());
  const auto [first, second] = split(data, size);
  put_slice("s1", first);
  if (second) put_slice("s2", *second);
  ImportLimits lim;
  lim.max_bytes = std::size_t{64} << 20;  // far below libFuzzer's RSS limit
  return expect_input_errors_only([&] { read_slice_stack(stack(), {0.1, 0.1, 0.1}, {0, 0, 0}, lim); });
}
