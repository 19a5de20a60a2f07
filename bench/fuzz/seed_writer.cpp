// Seed files for the fuzz targets whose inputs are binary formats we write ourselves:
// small, valid HDF5 files (recording, sample in both fraction encodings, prediction) and
// an acquisition journal, written by the same writers burrbench uses, so every seed is a
// file the readers accept. bench/fuzz.sh runs it in the fuzz build:
//   fuzz_seed_writer OUT_DIR RIG_MAP.toml
// writes OUT_DIR/{recording.h5, recording_nocounter.h5, sample.h5, sample_counter8.h5,
// prediction.h5, session.journal, session_unfinished.journal}.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/rig/finalise.hpp"
#include "burrbench/rig/journal.hpp"
#include "burrbench/rig/register_map.hpp"

namespace {
namespace fs = std::filesystem;
using namespace burrbench::data_schema;

Recording small_recording(int samples, bool counters) {
  Recording r;
  auto& m = r.meta;
  m.sample_id = "S1";
  m.rig_id = "seed";
  m.burr_radius_mm = 1.0;
  m.burr_axis_rig = {0, 0, 1};
  m.spin_sign = 1;
  m.bias = {0.1, -0.2, 0.3, 1, 2, 3};
  m.register_map_toml = "format = \"burrbench.rig\"\n";
  Stream ft;
  ft.name = "ft_sensor";
  ft.registers_per_sample = 2;
  Channel force{kForce, "N", 3, {}}, torque{kTorque, "N*mm", 3, {}};
  Stream stage;
  stage.name = "stage";
  Channel pos{kPosition, "mm", 3, {}};
  Stream spindle;
  spindle.name = "spindle";
  Channel rpm{kSpindle, "rpm", 1, {}};
  for (int i = 0; i < samples; ++i) {
    const std::int64_t t = 1000000 + std::int64_t(i) * 1000000;
    ft.t_ns.push_back(t);
    ft.t_send_ns.push_back(t - 1000);
    ft.t_recv_ns.push_back(t + 1000);
    ft.raw_registers.insert(ft.raw_registers.end(), {std::uint16_t(i), std::uint16_t(2 * i)});
    if (counters) ft.device_counter.push_back(i);
    ft.stale.push_back(i == 3 ? 1 : 0);
    force.values.insert(force.values.end(), {i == 3 ? NAN : 0.1 * i, -0.1 * i, 1.0});
    torque.values.insert(torque.values.end(), {0.0, 1.0, 2.0});
    stage.t_ns.push_back(t);
    pos.values.insert(pos.values.end(), {0.0, 0.0, 5.0 - 0.01 * i});
    spindle.t_ns.push_back(t);
    rpm.values.push_back(60000);
  }
  ft.channels = {force, torque};
  stage.channels = {pos};
  spindle.channels = {rpm};
  r.streams = {ft, stage, spindle};
  r.events = {{1000000, "start", "", ""}, {2000000, "gap", "ft_sensor", "late poll: counter 1 -> 3"}};
  r.provenance = burrbench::make_provenance({});
  return r;
}

SampleVolume small_sample() {
  SampleVolume v;
  v.dims = {3, 2, 2};
  v.voxel_mm = 0.5;
  v.origin_mm = {-1, 0, 1};
  v.labels = {0, 1, 2, 1, 1, 0, 2, 2, 0, 1, 1, 1};
  for (std::size_t i = 0; i < v.labels.size(); ++i) v.fraction.push_back(v.labels[i] ? float(i + 1) / 16.0f : 0.0f);
  v.sources = {{"ct.nrrd", burrbench::sha256_bytes("seed", 4)}};
  v.segmentation_json = R"({"threshold":1000})";
  v.provenance = burrbench::make_provenance({});
  return v;
}

Prediction small_prediction() {
  Prediction p;
  for (const char* id : {"plunge", "sweep"}) {
    PredictedRecording r;
    r.recording_id = id;
    for (int i = 0; i < 4; ++i) {
      r.t_s.push_back(0.001 * i);
      r.force_burr_vol_N.push_back({0.1 * i, 0, -1});
      r.force_sensor_pred_N.push_back({0.1 * i, 0, 1});
      r.force_sensor_meas_N.push_back({0.1 * i + 0.01, 0, 1});
      r.centre_vol_mm.push_back({0, 0, 1 - 0.01 * i});
      r.normal_vol.push_back(i ? glm::dvec3(0, 0, 1) : glm::dvec3(0));
      r.depth_b_mm.push_back(0.01 * i);
      r.class_mask.push_back(i ? 2 : 0);
      r.buried.push_back(0);
      r.use.push_back(1);
      r.moment_burr_vol_Nmm.push_back({0, 0, 0.1});
      r.torque_sensor_pred_Nmm.push_back({0, 0, 0.1});
      r.torque_sensor_meas_Nmm.push_back({0, 0, 0.12});
      r.spindle_torque_pred_Nmm.push_back(0.5);
      r.spindle_torque_meas_Nmm.push_back(0.6);
    }
    r.removed_mm3 = {};
    r.removed_mm3[1] = 0.01;
    r.steps = 4;
    p.recordings.push_back(r);
  }
  RemovedBone b;
  b.sample_id = "S1";
  b.voxel_mm = 0.5;
  b.nx = 2;
  b.ny = 2;
  b.removed_depth_mm = {0, 0.1f, 0, 0.2f};
  b.removed_class = {0, 1, 0, 2};
  b.removed_volume_mm3 = 0.075;
  p.removed = {b};
  p.provenance = burrbench::make_provenance({});
  return p;
}

// A journal as acquire writes it: the session header (the map's text inside), polls of
// every device of the map with its register count, a gap event, and the end marker.
void write_journal(const fs::path& path, const std::string& map_text, bool finish) {
  using namespace burrbench::rig;
  const RigMap map = parse_rig_map(map_text, "seed-rig.toml");
  SessionHeader h;
  h.rig_file = "seed-rig.toml";
  h.rig_toml = map_text;
  h.sample_id = "S1";
  h.session_wall_ns = 1790000000000000000;
  h.session_monotonic_ns = 1000;
  h.command_line = "burrbench acquire --rig seed-rig.toml --out r.h5";
  h.software_version = "seed";
  h.created_utc = "2026-01-01T00:00:00Z";
  h.operator_name = "seed";
  h.burr_radius_mm = 1.0;
  h.burr_axis_rig = {0, 0, 1};
  h.spin_sign = 1;
  fs::remove(path);
  JournalWriter w(path, to_json(h).dump());
  w.append(JournalEvent{1000, -1, "start", ""});
  for (int i = 0; i < 6; ++i) {
    for (std::size_t d = 0; d < map.devices.size(); ++d) {
      JournalSample s;
      s.device = std::uint16_t(d);
      s.t_send_ns = 1000000 + i * 1000000 + std::int64_t(d) * 1000;
      s.t_recv_ns = s.t_send_ns + 200000;
      s.counter = i;
      s.regs.assign(std::size_t(map.devices[d].count), 0);
      for (std::size_t k = 0; k < s.regs.size(); ++k) s.regs[k] = std::uint16_t(i + k);
      w.append(s);
    }
    if (i == 3) w.append(JournalEvent{4000000, 0, "gap", "late poll: counter 2 -> 3"});
  }
  if (finish) w.finish();
  else w.sync();
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::cerr << "usage: fuzz_seed_writer OUT_DIR RIG_MAP.toml\n";
    return 2;
  }
  const fs::path out = argv[1];
  fs::create_directories(out);
  std::stringstream map;
  map << std::ifstream(argv[2]).rdbuf();
  write_recording(out / "recording.h5", small_recording(6, true));
  write_recording(out / "recording_nocounter.h5", small_recording(2, false));
  write_sample(out / "sample.h5", small_sample());
  write_sample(out / "sample_counter8.h5", small_sample(), FractionEncoding::kCounter8);
  write_prediction(out / "prediction.h5", small_prediction());
  write_journal(out / "session.journal", map.str(), true);
  write_journal(out / "session_unfinished.journal", map.str(), false);
  for (const auto& e : fs::directory_iterator(out)) std::cout << e.path().filename().string() << " " << fs::file_size(e.path()) << "\n";
  return 0;
}
