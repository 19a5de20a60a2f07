// Recording (HDF5): round trip, validation rules, and refusal of broken files.
#include <cmath>
#include <cstring>

#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::test::expect_input_error;
using burrbench::test::expect_rejected_unchanged;
using burrbench::test::TempDir;

namespace {

bb::Recording make_recording(const std::filesystem::path& input) {
  bb::Recording r;
  auto& m = r.meta;
  m.sample_id = "S7";
  m.rig_id = "rig-ß";  // UTF-8 survives
  m.operator_name = "op";
  m.burr_radius_mm = 2.5;
  m.burr_axis_rig = glm::normalize(glm::dvec3(1, 2, 3));
  m.spin_sign = -1;
  m.sensor_model = "FT300";
  m.sensor_serial = "123";
  for (int i = 0; i < 36; ++i) m.sensor_calibration.push_back(1.0 / (i + 3));
  m.sensor_calibration_date = "2026-03-04";
  m.bias = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  m.bias_t_ns = 123456789;
  m.register_map_toml = "[force]\naddress = 180\n# comment\n";
  m.session_wall_ns = 1790000000123456789;
  m.session_monotonic_ns = 987654321;
  m.notes = "line1\nline2";
  bb::Stream ft;
  ft.name = "ft_sensor";
  ft.registers_per_sample = 2;
  bb::Channel f{bb::kForce, "N", 3, {}}, extra{"temperature_C", "C", 1, {}};
  for (int i = 0; i < 50; ++i) {
    ft.t_ns.push_back(1000 + i * 1000003LL);
    ft.t_send_ns.push_back(ft.t_ns.back() - 7);
    ft.t_recv_ns.push_back(ft.t_ns.back() + 9);
    ft.raw_registers.push_back(std::uint16_t(65535 - i));
    ft.raw_registers.push_back(std::uint16_t(i * 1000));
    ft.device_counter.push_back(4294967295LL + i);
    ft.stale.push_back(i == 7 ? 1 : 0);
    f.values.insert(f.values.end(), {i == 7 ? NAN : 0.1 * i, -1e-300 * i, 1e300 / (i + 1)});
    extra.values.push_back(20.0 + 1.0 / 3.0 * i);
  }
  ft.channels = {f, extra};
  bb::Stream stage;
  stage.name = "stage";
  bb::Channel p{bb::kPosition, "mm", 3, {}};
  for (int i = 0; i < 20; ++i) {
    stage.t_ns.push_back(5 + i * 2);
    p.values.insert(p.values.end(), {std::nextafter(1.0, 2.0) * i, -0.1 * i, 3.0});
  }
  stage.channels = {p};
  r.streams = {ft, stage};
  r.events = {{10, "start", "", ""}, {30, "fault", "ft_sensor", "timeout après 3 essais"}, {20, "tare", "", "x"}};
  r.provenance = input.empty() ? burrbench::make_provenance({}) : burrbench::make_provenance({input});
  return r;
}

bool same_doubles(const std::vector<double>& a, const std::vector<double>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0;
}

}  // namespace

TEST(FormatsRecording, RoundTripIsBitExact) {
  TempDir dir;
  burrbench::test::write_text(dir / "input.csv", "t_s\n0\n");
  const bb::Recording a = make_recording(dir / "input.csv");
  bb::write_recording(dir / "r.h5", a);
  // Written via a temporary name: only the target remains.
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 2u);
  const bb::Recording b = bb::read_recording(dir / "r.h5");

  const auto& ma = a.meta;
  const auto& mb = b.meta;
  EXPECT_EQ(mb.sample_id, ma.sample_id);
  EXPECT_EQ(mb.rig_id, ma.rig_id);
  EXPECT_EQ(mb.operator_name, ma.operator_name);
  EXPECT_EQ(mb.burr_radius_mm, ma.burr_radius_mm);
  EXPECT_EQ(mb.burr_axis_rig, ma.burr_axis_rig);
  EXPECT_EQ(mb.spin_sign, -1);
  EXPECT_EQ(mb.sensor_model, ma.sensor_model);
  EXPECT_EQ(mb.sensor_serial, ma.sensor_serial);
  EXPECT_TRUE(same_doubles(mb.sensor_calibration, ma.sensor_calibration));
  EXPECT_EQ(mb.sensor_calibration_date, ma.sensor_calibration_date);
  EXPECT_TRUE(same_doubles(mb.bias, ma.bias));
  EXPECT_EQ(mb.bias_t_ns, ma.bias_t_ns);
  EXPECT_EQ(mb.register_map_toml, ma.register_map_toml);
  EXPECT_EQ(mb.session_wall_ns, ma.session_wall_ns);
  EXPECT_EQ(mb.session_monotonic_ns, ma.session_monotonic_ns);
  EXPECT_EQ(mb.notes, ma.notes);

  ASSERT_EQ(b.streams.size(), 2u);
  for (std::size_t s = 0; s < 2; ++s) {
    const auto& sa = a.streams[s];
    const auto& sb = b.streams[s];
    EXPECT_EQ(sb.name, sa.name);
    EXPECT_EQ(sb.t_ns, sa.t_ns);
    EXPECT_EQ(sb.t_send_ns, sa.t_send_ns);
    EXPECT_EQ(sb.t_recv_ns, sa.t_recv_ns);
    EXPECT_EQ(sb.registers_per_sample, sa.registers_per_sample);
    EXPECT_EQ(sb.raw_registers, sa.raw_registers);
    EXPECT_EQ(sb.device_counter, sa.device_counter);
    EXPECT_EQ(sb.stale, sa.stale);
    ASSERT_EQ(sb.channels.size(), sa.channels.size());
    for (std::size_t c = 0; c < sa.channels.size(); ++c) {
      EXPECT_EQ(sb.channels[c].name, sa.channels[c].name);  // order preserved
      EXPECT_EQ(sb.channels[c].unit, sa.channels[c].unit);
      EXPECT_EQ(sb.channels[c].width, sa.channels[c].width);
      EXPECT_TRUE(same_doubles(sb.channels[c].values, sa.channels[c].values)) << sa.channels[c].name;
    }
  }
  EXPECT_TRUE(std::isnan(b.stream("ft_sensor")->channel(bb::kForce)->values[21]));
  EXPECT_EQ(b.stream_with(bb::kPosition)->name, "stage");
  ASSERT_EQ(b.events.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(b.events[i].t_ns, a.events[i].t_ns);
    EXPECT_EQ(b.events[i].kind, a.events[i].kind);
    EXPECT_EQ(b.events[i].stream, a.events[i].stream);
    EXPECT_EQ(b.events[i].detail, a.events[i].detail);
  }
  EXPECT_EQ(b.provenance.software_version, a.provenance.software_version);
  EXPECT_FALSE(b.provenance.software_version.empty());
  EXPECT_EQ(b.provenance.created_utc, a.provenance.created_utc);
  ASSERT_EQ(b.provenance.inputs.size(), 1u);
  EXPECT_EQ(b.provenance.inputs[0].sha256, burrbench::sha256_file(dir / "input.csv"));
}

TEST(FormatsRecording, EmptyOptionalVectorsRoundTrip) {
  TempDir dir;
  bb::Recording a;
  bb::Stream s;
  s.name = "spindle";
  s.t_ns = {1, 2, 2, 3};
  s.channels = {{bb::kSpindle, "rpm", 1, {0, 1000, 1000, 2000}}};
  a.streams = {s};
  bb::write_recording(dir / "r.h5", a);
  const bb::Recording b = bb::read_recording(dir / "r.h5");
  ASSERT_EQ(b.streams.size(), 1u);
  EXPECT_TRUE(b.streams[0].t_send_ns.empty());
  EXPECT_TRUE(b.streams[0].stale.empty());
  EXPECT_EQ(b.streams[0].registers_per_sample, 0u);
  EXPECT_EQ(b.streams[0].channels[0].values, s.channels[0].values);
  EXPECT_TRUE(b.meta.bias.empty());
  EXPECT_TRUE(b.events.empty());
  EXPECT_FALSE(b.provenance.software_version.empty());  // stamped by the writer
}

TEST(FormatsRecording, ValidatorNamesFieldAndExpectation) {
  TempDir dir;
  const auto base = make_recording({});
  auto check = [&](auto mutate, std::initializer_list<std::string> frags) {
    bb::Recording r = base;
    mutate(r);
    expect_input_error([&] { bb::write_recording(dir / "bad.h5", r); }, frags);
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.h5"));  // nothing half-written
  };
  check([](bb::Recording& r) { r.streams[1].channels[0].values[4] = NAN; },
        {"bad.h5", "/streams/stage/channels/position_mm[1][1]", "finite position"});
  check([](bb::Recording& r) { r.streams[0].channels[0].values[0] = INFINITY; },
        {"/streams/ft_sensor/channels/force_N[0][0]", "NaN only on rows flagged stale"});
  check([](bb::Recording& r) { r.streams[0].channels[0].values[3] = NAN; },  // row 1 not stale
        {"/streams/ft_sensor/channels/force_N[1][0]"});
  check([](bb::Recording& r) { std::swap(r.streams[0].t_ns[3], r.streams[0].t_ns[4]); },
        {"/streams/ft_sensor/t_ns[4]", "non-decreasing"});
  check([](bb::Recording& r) { r.streams[0].t_recv_ns.pop_back(); },
        {"/streams/ft_sensor/t_recv_ns", "50 values"});
  check([](bb::Recording& r) { r.streams[0].channels[0].width = 1; r.streams[0].channels[0].values.resize(50); },
        {"force_N", "width 3 and unit \"N\""});
  check([](bb::Recording& r) { r.streams[0].raw_registers.pop_back(); }, {"raw_registers", "50×2"});
  check([](bb::Recording& r) { r.meta.burr_axis_rig = {0, 0, 2}; }, {"/meta/@burr_axis_rig", "unit vector"});
  check([](bb::Recording& r) { r.meta.bias.resize(5); }, {"/meta/bias", "6 values"});
  check([](bb::Recording& r) { r.events[1].stream = "nope"; }, {"/events/stream[1]", "name of a stream"});
  check([](bb::Recording& r) { r.streams[1].name = "ft_sensor"; }, {"unique stream names"});
}

TEST(FormatsRecording, FailedWriteKeepsPreviousFile) {
  TempDir dir;
  bb::write_recording(dir / "r.h5", make_recording({}));
  const std::string before = burrbench::test::file_bytes(dir / "r.h5");
  bb::Recording bad = make_recording({});
  bad.streams[1].channels[0].values[0] = NAN;
  expect_input_error([&] { bb::write_recording(dir / "r.h5", bad); }, {"position_mm"});
  EXPECT_EQ(before, burrbench::test::file_bytes(dir / "r.h5"));
}

TEST(FormatsRecording, TruncatedFileIsRejected) {
  TempDir dir;
  bb::write_recording(dir / "r.h5", make_recording({}));
  const auto size = std::filesystem::file_size(dir / "r.h5");
  for (const double frac : {0.9, 0.5, 0.1}) {
    std::filesystem::copy_file(dir / "r.h5", dir / "t.h5", std::filesystem::copy_options::overwrite_existing);
    std::filesystem::resize_file(dir / "t.h5", std::uintmax_t(double(size) * frac));
    const std::string p = (dir / "t.h5").string();
    expect_rejected_unchanged(dir / "t.h5", [&] { bb::read_recording(p); }, {p + ": "});
  }
}

TEST(FormatsRecording, NonHdf5AndMissingFilesAreRejected) {
  TempDir dir;
  burrbench::test::write_text(dir / "x.h5", "t_s,x_mm\n0,1\n");
  const std::string p = (dir / "x.h5").string();
  expect_rejected_unchanged(dir / "x.h5", [&] { bb::read_recording(p); }, {p, "expected an HDF5 file"});
  expect_input_error([&] { bb::read_recording(dir / "missing.h5"); }, {"missing.h5", "an existing regular file"});
}

TEST(FormatsRecording, OtherFormatIsRejectedByName) {
  TempDir dir;
  bb::SampleVolume v;
  v.dims = {1, 1, 1};
  v.voxel_mm = 1;
  v.labels = {0};
  v.fraction = {0};
  bb::write_sample(dir / "s.h5", v);
  expect_input_error([&] { bb::read_recording(dir / "s.h5"); },
                     {"s.h5: /@format: expected \"burrbench.recording\", got \"burrbench.sample\""});
  burrbench::test::write_text(dir / "empty.h5", "");
  expect_input_error([&] { bb::read_recording(dir / "empty.h5"); }, {"empty.h5", "HDF5"});
}

TEST(FormatsRecording, CorruptedFilesOnlyEverRaiseInputError) {
  TempDir dir;
  bb::write_recording(dir / "r.h5", make_recording({}));
  const std::string base = burrbench::test::file_bytes(dir / "r.h5");
  const int rejected = burrbench::test::count_rejected_corruptions(
      base, dir / "c.h5", 300, 31337, 4, false, [](const auto& p) { bb::read_recording(p); });
  EXPECT_GT(rejected, 100);
}
