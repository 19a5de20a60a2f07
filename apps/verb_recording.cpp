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
#include "output_paths.hpp"
#include "verb_registry.hpp"

namespace {
namespace fs = std::filesystem;
using namespace burrbench;
using namespace burrbench::data_schema;

struct Args {
  std::string csv, map, out, sample_id, rig_id, operator_name;
  double burr_radius_mm = 0;
  std::vector<double> burr_axis;  // empty: not stated
  int spin = 0;  // 0: not stated
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
  imp->add_option("--operator", a->operator_name, "operator stored in the metadata");
  imp->add_option("--burr-radius-mm", a->burr_radius_mm, "burr radius stored in the metadata (0 = unknown)");
  imp->add_option("--burr-axis", a->burr_axis, "burr shaft axis in the rig frame, 3 numbers (normalised; default: not stated)")
      ->expected(3);
  auto* spin_opt = imp->add_option("--spin", a->spin, "spin sign: +1 counter-clockwise about --burr-axis, -1 clockwise (default: not stated)");
  imp->callback([a, spin_opt] {
    // Stated up front, not after the import: a tilted burr must not pass as [0, 0, 1].
    const glm::dvec3 axis = a->burr_axis.empty() ? glm::dvec3(0) : glm::dvec3(a->burr_axis[0], a->burr_axis[1], a->burr_axis[2]);
    const double len = glm::length(axis);
    if (!a->burr_axis.empty() && (!std::isfinite(len) || len < 1e-9))
      throw InputError("command line", "--burr-axis", "a non-zero finite vector (x y z)",
                       fmt::format("{} {} {}", axis.x, axis.y, axis.z));
    if (spin_opt->count() > 0 && a->spin != 1 && a->spin != -1)
      throw InputError("command line", "--spin", "+1 or -1", std::to_string(a->spin));
    burrbench::apps::refuse_output_over_inputs(a->out, "--out", {a->csv, a->map});
    burrbench::apps::refuse_existing(a->out, "--out", a->overwrite);
    std::optional<fs::path> map;
    if (!a->map.empty()) map = a->map;
    Recording r = import::read_csv_recording(a->csv, map);
    r.meta.sample_id = a->sample_id;
    r.meta.rig_id = a->rig_id;
    r.meta.operator_name = a->operator_name;
    r.meta.burr_radius_mm = a->burr_radius_mm;
    r.meta.burr_axis_rig = a->burr_axis.empty() ? axis : axis / len;
    r.meta.spin_sign = a->spin;
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
