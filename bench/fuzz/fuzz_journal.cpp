// libFuzzer target: what `burrbench recover` does with a journal left by a crash:
// read_journal (4096-byte blocks, CRCs, torn tail, two header copies) and
// recording_from_journal (the JSON session header, the register map text it holds, the
// raw registers decoded through that map into a recording).
#include "burrbench/rig/finalise.hpp"
#include "burrbench/rig/journal.hpp"
#include "fuzz_file.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  const auto path = put("session.journal", as_text(data, size));
  return expect_input_errors_only([&] {
    const auto contents = burrbench::rig::read_journal(path);
    burrbench::rig::recording_from_journal(contents, path.string());
  });
}
