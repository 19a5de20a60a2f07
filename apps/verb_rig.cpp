// burrbench rig check | tare: one-shot, read-only rig tools.
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/rig/tools.hpp"
#include "output_paths.hpp"
#include "verb_registry.hpp"

namespace {

void setup(CLI::App& root) {
  auto* rig = root.add_subcommand("rig", "Rig tools: check the devices, tare the force sensor");
  rig->require_subcommand(1);

  auto* check = rig->add_subcommand("check", "Read each device once; print decoded values and round-trip times");
  auto check_map = std::make_shared<std::string>();
  check->add_option("--rig", *check_map, "register map (TOML)")->required();
  check->callback([check_map] {
    using namespace burrbench;
    const auto map = rig::load_rig_map(*check_map);  // refuses a bus it cannot carry, before connecting
    for (const auto& b : rig::rtu_bus_budgets(map.devices)) {
      std::string polls;
      for (std::size_t k = 0; k < b.devices.size(); ++k)
        polls += fmt::format("  {} {:.2f} ms", b.devices[k], b.poll_wire_ms[k]);
      std::cout << fmt::format("bus {} {} baud: {:.0f} % busy at the map's rates (limit {:.0f} %); a poll on the wire:{}\n",
                               b.serial, b.baud, b.load * 100, rig::kMaxBusLoad * 100, polls);
    }
    const auto results = rig::check_rig(map);
    bool all = true;
    for (const auto& r : results) {
      if (!r.ok) {
        all = false;
        std::cout << fmt::format("{:<12} {:<28} FAILED  {}\n", r.device, r.link, r.error);
        continue;
      }
      std::cout << fmt::format("{:<12} {:<28} ok  {:.2f} ms{}\n", r.device, r.link, r.round_trip_ms,
                               r.counter >= 0 ? fmt::format("  counter {}", r.counter) : "");
      for (const auto& c : r.channels)
        std::cout << fmt::format("    {:<14} {} {}{}\n", c.name, fmt::join(c.values, " "), c.unit, c.valid ? "" : "  INVALID");
    }
    if (!all) apps::set_exit_code(1);
  });

  auto* tare = rig->add_subcommand("tare", "Average N force/torque samples (burr spinning in air) into a tare file");
  auto tare_map = std::make_shared<std::string>();
  auto out = std::make_shared<std::string>();
  auto overwrite = std::make_shared<bool>(false);
  auto n = std::make_shared<std::size_t>(200);
  tare->add_option("--rig", *tare_map, "register map (TOML)")->required();
  tare->add_option("--out", *out, "tare file to write (pass it to `burrbench acquire --tare`)")->required();
  tare->add_flag("--overwrite", *overwrite, "replace an existing --out file (refused otherwise)");
  tare->add_option("--samples", *n, "samples to average")->capture_default_str()->check(CLI::Range(1, 1000000));
  tare->callback([tare_map, out, n, overwrite] {
    using namespace burrbench;
    apps::refuse_output_over_inputs(*out, "--out", {*tare_map});
    apps::refuse_existing(*out, "--out", *overwrite);
    apps::check_output_location(*out, "--out");
    const auto map = rig::load_rig_map(*tare_map);
    auto t = rig::measure_tare(map, *n);
    t.rig_sha256 = sha256_file(*tare_map);
    rig::write_tare(*out, t);
    std::cout << fmt::format("tare of {} from {} samples: F {:.4f} {:.4f} {:.4f} N  T {:.3f} {:.3f} {:.3f} N*mm → {}\n",
                             t.device, t.samples, t.bias[0], t.bias[1], t.bias[2], t.bias[3], t.bias[4], t.bias[5], *out);
  });
}
BURRBENCH_VERB("rig", setup);

}  // namespace
