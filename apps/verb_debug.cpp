// burrbench debug write-fixtures DIR — hidden developer verb. Writes one file of every
// format with known values, so tests outside C++ (pytest + h5py) can check what the C++
// writers store. The values below are the documentation; tests recompute them.
//
// recording.h5 — meta: sample_id "S1", rig_id "fixture-rig", operator "fixture",
//   burr_radius_mm 1.5, burr_axis_rig (0,0,1), spin_sign -1, sensor "FT300" serial
//   "FX-0001", sensor_calibration[r][c] = r + 0.5·c, date "2026-01-02", bias
//   (0.1,-0.2,0.3,1,2,3), bias_t_ns 500, session_wall_ns 1790000000000000000,
//   session_monotonic_ns 1000, register_map_toml "[device]\nname = \"fixture\"\n".
//   ft_sensor: i < 1200, t_ns = 1e6 + i·1e6, t_send_ns = t_ns − 2e5, t_recv_ns = t_ns + 2e5,
//     raw_registers[i][k] = (12·i + k) mod 65536 (12 per sample), device_counter = 10 + i,
//     stale = (i mod 100 == 99), force_N = (sin 0.01i, cos 0.01i, −0.5 + 0.001i) except
//     force_N[99][0] = NaN (a stale row), torque_Nmm = (i, −i, 0.5i).
//   stage: i < 600, t_ns = 1e6 + 2e6·i, device_counter = i, position_mm = (0.01i, −0.02i, 5 − 0.001i).
//   spindle: i < 60, t_ns = 1e6 + 2e7·i, spindle_rpm = 30000 + i.
//   events: (1e6, start, "", ""), (1.5e6, tare, ft_sensor, "bias taken"), (1.2e9, stop, "", "").
// sample.h5 / sample_counter255.h5 — nx,ny,nz = 7,5,3, voxel 0.25 mm, origin (−1, 2, 0.5);
//   z = 0: label 1, χ 1; z = 1: label 2 with χ = (x+1)/8 where (x+y) even, else label 0, χ 0;
//   z = 2: label 0, χ 0. Classes {1 compact, 2 trabecular}; segmentation {"threshold":1000}.
//   The counter255 file stores χ = round(255·χ)/255 for the same χ.
// params.toml, fit.json, experiment.toml — see the code below.
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "verb_registry.hpp"

namespace {

using namespace burrbench::data_schema;

Recording fixture_recording() {
  Recording r;
  auto& m = r.meta;
  m.sample_id = "S1";
  m.rig_id = "fixture-rig";
  m.operator_name = "fixture";
  m.burr_radius_mm = 1.5;
  m.burr_axis_rig = {0, 0, 1};
  m.spin_sign = -1;
  m.sensor_model = "FT300";
  m.sensor_serial = "FX-0001";
  for (int rr = 0; rr < 6; ++rr)
    for (int c = 0; c < 6; ++c) m.sensor_calibration.push_back(rr + 0.5 * c);
  m.sensor_calibration_date = "2026-01-02";
  m.bias = {0.1, -0.2, 0.3, 1, 2, 3};
  m.bias_t_ns = 500;
  m.session_wall_ns = 1790000000000000000;
  m.session_monotonic_ns = 1000;
  m.register_map_toml = "[device]\nname = \"fixture\"\n";
  m.notes = "fixture";

  Stream ft;
  ft.name = "ft_sensor";
  ft.registers_per_sample = 12;
  Channel force{kForce, "N", 3, {}}, torque{kTorque, "N*mm", 3, {}};
  for (int i = 0; i < 1200; ++i) {
    const std::int64_t t = 1000000 + std::int64_t(i) * 1000000;
    ft.t_ns.push_back(t);
    ft.t_send_ns.push_back(t - 200000);
    ft.t_recv_ns.push_back(t + 200000);
    for (int k = 0; k < 12; ++k) ft.raw_registers.push_back(std::uint16_t((12 * i + k) % 65536));
    ft.device_counter.push_back(10 + i);
    ft.stale.push_back(i % 100 == 99 ? 1 : 0);
    force.values.insert(force.values.end(),
                        {i == 99 ? NAN : std::sin(0.01 * i), std::cos(0.01 * i), -0.5 + 0.001 * i});
    torque.values.insert(torque.values.end(), {double(i), -double(i), 0.5 * i});
  }
  ft.channels = {force, torque};

  Stream stage;
  stage.name = "stage";
  Channel pos{kPosition, "mm", 3, {}};
  for (int i = 0; i < 600; ++i) {
    stage.t_ns.push_back(1000000 + std::int64_t(i) * 2000000);
    stage.device_counter.push_back(i);
    pos.values.insert(pos.values.end(), {0.01 * i, -0.02 * i, 5 - 0.001 * i});
  }
  stage.channels = {pos};

  Stream spindle;
  spindle.name = "spindle";
  Channel rpm{kSpindle, "rpm", 1, {}};
  for (int i = 0; i < 60; ++i) {
    spindle.t_ns.push_back(1000000 + std::int64_t(i) * 20000000);
    rpm.values.push_back(30000 + i);
  }
  spindle.channels = {rpm};

  r.streams = {ft, stage, spindle};
  r.events = {{1000000, "start", "", ""}, {1500000, "tare", "ft_sensor", "bias taken"}, {1200000000, "stop", "", ""}};
  r.provenance = burrbench::make_provenance({});
  return r;
}

SampleVolume fixture_sample() {
  SampleVolume v;
  v.dims = {7, 5, 3};
  v.voxel_mm = 0.25;
  v.origin_mm = {-1.0, 2.0, 0.5};
  v.labels.assign(v.voxel_count(), 0);
  v.fraction.assign(v.voxel_count(), 0.0f);
  for (std::size_t z = 0; z < 3; ++z)
    for (std::size_t y = 0; y < 5; ++y)
      for (std::size_t x = 0; x < 7; ++x) {
        const std::size_t i = v.index(x, y, z);
        if (z == 0) {
          v.labels[i] = kCompact;
          v.fraction[i] = 1.0f;
        } else if (z == 1 && (x + y) % 2 == 0) {
          v.labels[i] = kTrabecular;
          v.fraction[i] = float(x + 1) / 8.0f;
        }
      }
  v.sources = {{"ct.nrrd", burrbench::sha256_bytes("fixture", 7)}};
  v.segmentation_json = R"({"threshold":1000})";
  v.provenance = burrbench::make_provenance({});
  return v;
}

void write_fixtures(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  write_recording(dir / "recording.h5", fixture_recording());
  const SampleVolume v = fixture_sample();
  write_sample(dir / "sample.h5", v);
  write_sample(dir / "sample_counter255.h5", v, FractionEncoding::kCounter8);

  ParameterSet p;
  p.classes[1] = {"compact", 25.5, 12.0, 0.3};
  p.classes[2] = {"trabecular", INFINITY, 4.5, 0.25};
  p.notes = "fixture";
  write_params(dir / "params.toml", p);

  ExperimentManifest m;
  m.name = "fixture";
  m.samples = {{"S1", std::filesystem::absolute(dir / "sample.h5")}};
  m.burr.radius_mm = 1.5;
  RecordingRef rr;
  rr.id = "plunge";
  rr.path = std::filesystem::absolute(dir / "recording.h5");
  rr.sample = "S1";
  rr.registration.translation_mm = {1, 2, 3};
  rr.segments = {{0.0, 0.5, true, "plunge"}};
  m.recordings = {rr};
  m.fit.classes = {{"compact", 1, {20, 0.1, 1000, false}, {10, 0.01, 1000, false}, {0.3, 0.01, 2, false}}};
  write_manifest(dir / "experiment.toml", m);

  FitResult f;
  f.parameters = {{1, "compact", "c1", "N/mm^2", 12.0, 0.5, 11.0, 13.0, NAN, NAN, false, true, ""},
                  {1, "compact", "mu", "1", 0.3, 0.01, 0.28, 0.32, NAN, NAN, false, true, ""},
                  {1, "compact", "alpha", "N/mm^2", NAN, NAN, NAN, NAN, NAN, NAN, false, false,
                   "burr buried: no erosion signal"}};
  f.nuisance = {{"plunge", "lag", "ms", 1.5, 0.2, 1.1, 1.9, false}};
  f.covariance = {{"c1", "mu"}, {0.25, 0.001, 0.001, 0.0001}};
  f.correlation = {{"c1", "mu"}, {1.0, 0.2, 0.2, 1.0}};
  f.residuals_summary = {1000, 20, 5, 0.02, 1.05};
  f.solver = {12, 100.0, 1.0, 0.5, 40, "CONVERGENCE", 1};
  f.experiment_path = (dir / "experiment.toml").string();
  f.experiment_sha256 = burrbench::sha256_file(dir / "experiment.toml");
  f.provenance = burrbench::make_provenance({dir / "experiment.toml"});
  write_fit(dir / "fit.json", f);
}

void setup(CLI::App& root) {
  auto* debug = root.add_subcommand("debug", "Developer tools (fixtures for tests)");
  debug->group("");  // hidden from --help
  debug->require_subcommand(1);
  auto* wf = debug->add_subcommand("write-fixtures", "Write one file of every format with known values");
  auto dir = std::make_shared<std::string>();
  wf->add_option("DIR", *dir, "output folder")->required();
  wf->callback([dir] {
    write_fixtures(*dir);
    std::cout << "fixtures written to " << *dir << "\n";
  });
}
BURRBENCH_VERB("debug", setup);
}  // namespace
