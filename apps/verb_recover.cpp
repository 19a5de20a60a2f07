// burrbench recover: rebuild a recording from the journal a crashed acquisition left.
// The journal is only read (never truncated in place): a torn tail is ignored and a
// damaged block skipped, each noted as an event in the recording.
#include <filesystem>
#include <iostream>

#include <fmt/format.h>

#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/rig/finalise.hpp"
#include "burrbench/rig/journal.hpp"
#include "output_paths.hpp"
#include "verb_registry.hpp"

namespace {

void setup(CLI::App& root) {
  auto* cmd = root.add_subcommand("recover", "Rebuild a recording from an acquisition journal after a crash");
  auto journal = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto overwrite = std::make_shared<bool>(false);
  cmd->add_option("JOURNAL", *journal, "journal left by `burrbench acquire`")->required();
  cmd->add_option("--out", *out, "recording to write (HDF5)")->required();
  cmd->add_flag("--overwrite", *overwrite, "replace an existing --out recording (refused otherwise)");
  cmd->callback([journal, out, overwrite] {
    using namespace burrbench;
    apps::refuse_output_over_inputs(*out, "--out", {*journal});  // the journal is never modified
    apps::refuse_existing(*out, "--out", *overwrite);
    const auto contents = rig::read_journal(*journal);
    rig::FinaliseReport rep;
    auto rec = rig::recording_from_journal(contents, *journal, &rep);
    rec.provenance = make_provenance({*journal});
    data_schema::validate(rec, *journal);  // a defect is the journal's, so the message names it
    data_schema::write_recording(*out, rec);
    for (const auto& p : rep.problems) std::cerr << "recover: " << p << "\n";
    std::cout << fmt::format("wrote {}: {} samples from {} blocks ({} damaged block(s) skipped, {} torn tail bytes ignored, {})\n",
                             *out, rep.samples, contents.blocks, contents.corrupt_blocks, contents.torn_tail_bytes,
                             contents.clean_end ? "clean end" : "no end marker");
  });
}
BURRBENCH_VERB("recover", setup);

}  // namespace
