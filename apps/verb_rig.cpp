// burrbench rig check | tare: one-shot, read-only rig tools.
#include <iostream>

#include <fmt/format.h>
#include <fmt/ranges.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/sensor_loads.hpp"
#include "burrbench/model/sensor_pose.hpp"
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
      for (const auto& c : r.channels) {
        // A float32 register's value as the device sent it (0.02157498, not the 17 digits
        // of its double); a scaled integer to 12 digits (2.018, not the 2.0180000000000002
        // of 2018 × 0.001; an int32 has at most 10).
        std::string values;
        for (const double v : c.values)
          values += (values.empty() ? "" : " ") +
                    (double(float(v)) == v ? fmt::format("{}", float(v)) : fmt::format("{:.12g}", v));
        std::cout << fmt::format("    {:<18} {} {}{}\n", c.name, values, c.unit, c.valid ? "" : "  INVALID");
      }
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
    const auto map = rig::load_rig_map(*tare_map);
    auto t = rig::measure_tare(map, *n);
    t.rig_sha256 = sha256_file(*tare_map);
    rig::write_tare(*out, t);
    std::cout << fmt::format("tare of {} from {} samples: F {:.4f} {:.4f} {:.4f} N  T {:.3f} {:.3f} {:.3f} N*mm → {}\n",
                             t.device, t.samples, t.bias[0], t.bias[1], t.bias[2], t.bias[3], t.bias[4], t.bias[5], *out);
    std::cout << std::flush;  // the warning follows the line it is about
    if (t.drift_sigmas > rig::kTareDriftSigmas)
      std::cerr << fmt::format("warning: the force moved by {:.4f} {:.4f} {:.4f} N between the tare's first and second "
                               "half ({:.0f} standard errors; at rest it does not): the burr may have touched, or the "
                               "sensor was still settling. Tare again with the burr spinning in air (--overwrite "
                               "replaces {}).\n",
                               t.drift[0], t.drift[1], t.drift[2], t.drift_sigmas, *out);
  });

  // --- sensor-pose: the sensor's rotation and origin from static loads ---
  auto* pose = rig->add_subcommand("sensor-pose", "The force sensor's rotation and origin (rig frame) from known "
                                                  "static loads and their tare files; writes a [sensor] snippet");
  auto loads_path = std::make_shared<std::string>();
  auto pose_out = std::make_shared<std::string>();
  auto pose_overwrite = std::make_shared<bool>(false);
  pose->add_option("LOADS", *loads_path, "static loads (.toml, format burrbench.sensor_loads)")->required();
  pose->add_option("--out", *pose_out, "TOML with the [sensor] keys for the experiment manifest")->required();
  pose->add_flag("--overwrite", *pose_overwrite, "replace an existing --out file (refused otherwise)");
  pose->callback([loads_path, pose_out, pose_overwrite] {
    using namespace burrbench;
    const auto spec = data_schema::read_sensor_loads(*loads_path);
    std::vector<std::string> inputs{*loads_path, spec.unloaded.string()};
    for (const auto& l : spec.loads) inputs.push_back(l.tare.string());
    apps::refuse_output_over_inputs(*pose_out, "--out", inputs);
    apps::refuse_existing(*pose_out, "--out", *pose_overwrite);
    const auto zero = rig::read_tare(spec.unloaded);
    std::vector<model::StaticLoad> loads;
    for (const auto& l : spec.loads) {
      const auto t = rig::read_tare(l.tare);
      model::StaticLoad s{l.force_rig_N, l.point_rig_mm, {}, {}};
      for (int k = 0; k < 3; ++k) {
        s.force_sensor_N[k] = t.bias[std::size_t(k)] - zero.bias[std::size_t(k)];
        s.moment_sensor_Nmm[k] = t.bias[std::size_t(k) + 3] - zero.bias[std::size_t(k) + 3];
      }
      loads.push_back(s);
    }
    const auto fit = model::estimate_sensor_pose(loads, *loads_path);
    const glm::dmat3& Q = fit.rotation_sensor_to_rig;
    const glm::dvec3& o = fit.origin_rig_mm;
    std::string text = fmt::format(
        "# burrbench rig sensor-pose {}: {} loads, residual RMS {:.4g} N and {:.4g} N*mm ({} iterations)\n",
        *loads_path, loads.size(), fit.force_rms_N, fit.moment_rms_Nmm, fit.iterations);
    if (fit.unobservable_rig != glm::dvec3(0))
      text += fmt::format("# every load is parallel to ({:.4f}, {:.4f}, {:.4f}): the origin along it is NOT determined\n"
                          "# (kept at its least-norm value); add a load sideways (a pulley) to fix it\n",
                          fit.unobservable_rig.x, fit.unobservable_rig.y, fit.unobservable_rig.z);
    text += "[sensor]\nrotation_sensor_to_rig = [";
    for (int r = 0; r < 3; ++r)
      text += fmt::format("{}[{:.12g}, {:.12g}, {:.12g}]", r ? ", " : "", Q[0][r], Q[1][r], Q[2][r]);
    text += fmt::format("]\norigin_rig_mm = [{:.9g}, {:.9g}, {:.9g}]\n", o.x, o.y, o.z);
    data_schema::write_file_atomic(*pose_out, text);
    std::cout << text;
    for (std::size_t i = 0; i < loads.size(); ++i)
      std::cout << fmt::format("  load {}: residual {:.4g} N, {:.4g} N*mm\n", i, fit.force_residual_N[i],
                               fit.moment_residual_Nmm[i]);
    std::cout << "wrote " << *pose_out << " (paste its [sensor] keys into the experiment manifest)\n";
  });
}
BURRBENCH_VERB("rig", setup);

}  // namespace
