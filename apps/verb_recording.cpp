// `burrbench recording import`: recordings from CSV exports (LabVIEW / NI systems).
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/csv_recording.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burr_options.hpp"
#include "output_paths.hpp"
#include "verb_registry.hpp"

namespace {
namespace fs = std::filesystem;
using namespace burrbench;
using namespace burrbench::data_schema;

struct Args {
  std::string csv, map, out, sample_id, rig_id;
  apps::BurrOptions burr;
  bool overwrite = false;
};

void setup(CLI::App& root) {
  auto* rec = root.add_subcommand("recording", "Work with recordings");
  rec->require_subcommand(1);
  auto a = std::make_shared<Args>();
  auto* imp = rec->add_subcommand("import", "Import a CSV export (canonical header, or any layout with --map) into a recording");
  imp->add_option("--csv", a->csv, "CSV file")->required();
  imp->add_option("--map", a->map, "TOML column map (format burrbench.csv_map), for non-canonical headers");
  imp->add_option("--out", a->out, "output recording (.h5)")->required();
  imp->add_flag("--overwrite", a->overwrite, "replace an existing --out recording (refused otherwise)");
  imp->add_option("--sample-id", a->sample_id, "sample id stored in the metadata");
  imp->add_option("--rig-id", a->rig_id, "rig id stored in the metadata");
  a->burr.add_to(imp);
  imp->callback([a] {
    RecordingMeta burr;
    a->burr.apply(burr);  // checked up front, not after the import
    burrbench::apps::refuse_output_over_inputs(a->out, "--out", {a->csv, a->map});
    burrbench::apps::refuse_existing(a->out, "--out", a->overwrite);
    std::optional<fs::path> map;
    if (!a->map.empty()) map = a->map;
    Recording r = import::read_csv_recording(a->csv, map);
    a->burr.apply(r.meta);
    r.meta.sample_id = a->sample_id;
    r.meta.rig_id = a->rig_id;
    std::vector<fs::path> inputs{a->csv};
    if (map) inputs.push_back(*map);
    r.provenance = make_provenance(inputs);
    write_recording(a->out, r);
    const Stream& s = r.streams.front();
    std::cout << fmt::format("wrote {}: {} samples over {:.6g} s, channels:", a->out, s.samples(),
                             double(s.t_ns.back() - s.t_ns.front()) * 1e-9);
    for (const auto& c : s.channels) std::cout << ' ' << c.name;
    std::cout << '\n';
  });
}

BURRBENCH_VERB("recording", setup);
}  // namespace
