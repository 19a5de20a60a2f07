// libFuzzer target: the experiment manifest's TOML parsing and checks, through
// parse_manifest (read_manifest's own parse, on the text in memory) as if the file were
// scratch/manifest.toml: the private scratch folder (fuzz_file.hpp, tmpfs) holds the files
// the seed manifest names, letting inputs get past the existence checks into the deeper
// validation. read_manifest's file read (parse_toml_file, shared by every TOML reader) is
// fuzzed by the other TOML targets, which go through files.
// Until issue 59 each input was written to a file under /tmp and read back with
// read_manifest, and ran at ~330 executions a second over 10 minutes; per execution most
// of the time went to AddressSanitizer's allocator touching fresh pages (its quarantine),
// the file's stream buffers among the allocations.
#include <fstream>

#include "burrbench/data_schema/manifest.hpp"
#include "fuzz_file.hpp"

namespace {
const std::filesystem::path& folder() {
  static const std::filesystem::path d = [] {
    using burrbench::fuzz::scratch;
    for (const char* f : {"sample.h5", "plunge.h5", "sweep.h5"}) std::ofstream(scratch() / f) << "x";
    return scratch();
  }();
  return d;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  static const auto path = folder() / "manifest.toml";
  return expect_input_errors_only([&] { burrbench::data_schema::parse_manifest(as_text(data, size), path); });
}
