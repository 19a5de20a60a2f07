// Prediction (HDF5): exact round trip, validation, refusal of broken files, and the
// storage rules shared with the other HDF5 formats (1.8 file format, no variable-length
// strings), checked on the real file with the HDF5 C API.
#include <cmath>
#include <cstring>

#include <hdf5.h>

#include "burrbench/data_schema/inspect.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::test::expect_input_error;
using burrbench::test::expect_rejected_unchanged;
using burrbench::test::TempDir;

namespace {

bb::PredictedRecording make_recording(const std::string& id, std::size_t n, double phase) {
  bb::PredictedRecording r;
  r.recording_id = id;
  for (std::size_t k = 0; k < n; ++k) {
    const double x = double(k) + phase;
    r.t_s.push_back(std::nextafter(1e-3 * x, 1.0));
    r.force_burr_vol_N.push_back({std::sin(x), -1e-300 * x, 1e3 / (x + 1)});
    r.force_sensor_pred_N.push_back(-r.force_burr_vol_N.back());
    r.force_sensor_meas_N.push_back(-r.force_burr_vol_N.back() + glm::dvec3(0.1, -0.2, 1.0 / 3.0));
    r.centre_vol_mm.push_back({4.0, 4.0 + 1e-4 * x, 4.5 - 2e-4 * x});
    r.normal_vol.push_back(k % 3 ? glm::normalize(glm::dvec3(1, x, 2)) : glm::dvec3(0));
    r.depth_b_mm.push_back(k % 3 ? 0.01 * x : 0.0);
    r.class_mask.push_back(std::uint8_t(k % 3 ? (k % 2 ? 0b110 : 0b010) : 0));
    r.buried.push_back(k % 7 == 5 ? 1 : 0);
    r.use.push_back(k < n / 2 ? 1 : 0);
  }
  r.removed_mm3 = {0, 0.125 * phase, 1.0 / 3.0, 0, 0, 0, 0, 7e-9};
  r.steps = (std::int64_t{1} << 40) + std::int64_t(n);
  return r;
}

bb::Prediction make_prediction(const std::filesystem::path& input) {
  bb::Prediction p;
  // Not alphabetical: the file keeps replay order. One recording is empty.
  p.recordings = {make_recording("sweep", 40, 0.5), make_recording("plunge-ß", 25, 1.25),
                  make_recording("polish", 0, 0)};
  // 2.1: the first was registered from fiducials, the second from a given transform.
  auto& fid = p.recordings[0];
  fid.registration_method = "fiducials";
  fid.registration_rms_mm = 0.0057;
  fid.registration_max_mm = 1.0 / 3.0 * 0.02;
  fid.fiducial_error_mm = 0.005;
  fid.tre_path_rms_mm = 0.0031;
  fid.tre_path_max_mm = 0.0042;
  p.recordings[1].registration_method = "vol_from_rig";
  // 2.3: what a fit's prediction applied, its band and role flags, and the removed bone.
  fid.role = "calibrate";
  fid.quadrature = "cube";  // 2.4
  fid.used_calibrate = fid.use;
  fid.used_validate.assign(fid.samples(), 0);
  fid.used_validate[39] = 1;
  fid.force_bias_N = {0.1, -0.2, 1.0 / 3.0};
  fid.force_bias_source = "fit";
  fid.torque_bias_Nmm = {1e-3, 0, -7.5};
  fid.torque_bias_source = "tare";
  fid.spindle_offset_Nmm.assign(fid.samples(), 2.0 / 3.0);
  fid.spindle_torque_pred_Nmm.assign(fid.samples(), 1.5);
  fid.spindle_offset_source = "fit";
  fid.lag_ms = 4.0 + 1.0 / 7.0;
  fid.depth_offset_mm = -0.012;
  for (std::size_t k = 0; k < fid.samples(); ++k) fid.band95_N.push_back({0.01 * double(k), 0.02, 1e-9});
  fid.friction_energy_mJ = {0, 12.5, 1.0 / 3.0, 0, 0, 0, 0, 0};
  bb::RemovedBone rb;
  rb.sample_id = "femur-ß";
  rb.voxel_mm = 0.05;
  rb.nx = 3;
  rb.ny = 2;
  rb.removed_depth_mm = {0, 0.05f, 0.1f, 0, 1.0f / 3.0f, 0};
  rb.removed_class = {0, 1, 1, 0, 2, 0};
  rb.removed_volume_mm3 = 0.0012;
  p.removed = {rb};
  p.provenance =
      input.empty() ? burrbench::make_provenance({}) : burrbench::make_provenance({input});
  p.provenance.command_line = "burrbench replay --out 'p.h5'";
  return p;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() &&
         (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

// ---- direct edits of a written file through the HDF5 C API (to build broken inputs)

struct File {
  hid_t id;
  explicit File(const std::filesystem::path& p, unsigned mode = H5F_ACC_RDWR)
      : id(H5Fopen(p.string().c_str(), mode, H5P_DEFAULT)) {}
  ~File() {
    if (id >= 0) H5Fclose(id);
  }
};

void set_string_attr(const std::filesystem::path& p, const char* obj, const char* name,
                     const std::string& value) {
  File f(p);
  ASSERT_GE(f.id, 0);
  if (H5Aexists_by_name(f.id, obj, name, H5P_DEFAULT) > 0) {
    ASSERT_GE(H5Adelete_by_name(f.id, obj, name, H5P_DEFAULT), 0);
  }
  const hid_t t = H5Tcopy(H5T_C_S1);
  H5Tset_size(t, value.size() + 1);
  const hid_t s = H5Screate(H5S_SCALAR);
  const hid_t a = H5Acreate_by_name(f.id, obj, name, t, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  ASSERT_GE(a, 0);
  EXPECT_GE(H5Awrite(a, t, value.c_str()), 0);
  H5Aclose(a);
  H5Sclose(s);
  H5Tclose(t);
}

void delete_link(const std::filesystem::path& p, const char* path) {
  File f(p);
  ASSERT_GE(f.id, 0);
  ASSERT_GE(H5Ldelete(f.id, path, H5P_DEFAULT), 0);
}

void delete_attr(const std::filesystem::path& p, const char* obj, const char* name) {
  File f(p);
  ASSERT_GE(f.id, 0);
  ASSERT_GE(H5Adelete_by_name(f.id, obj, name, H5P_DEFAULT), 0);
}

// Replaces (or adds) a dataset: a float64 one of the given shape (zeros), with a unit attribute.
void replace_dataset(const std::filesystem::path& p, const char* path, std::vector<hsize_t> dims,
                     const std::string& unit) {
  {
    File f(p);
    ASSERT_GE(f.id, 0);
    if (H5Lexists(f.id, path, H5P_DEFAULT) > 0) {
      ASSERT_GE(H5Ldelete(f.id, path, H5P_DEFAULT), 0);
    }
    const hid_t s = H5Screate_simple(int(dims.size()), dims.data(), nullptr);
    const hid_t d =
        H5Dcreate2(f.id, path, H5T_IEEE_F64LE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(d, 0);
    std::size_t n = 1;
    for (hsize_t x : dims) n *= x;
    const std::vector<double> zeros(n, 0.0);
    EXPECT_GE(H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, zeros.data()), 0);
    H5Dclose(d);
    H5Sclose(s);
  }
  set_string_attr(p, path, "unit", unit);
}

// Every string-typed attribute and dataset of the file: name → variable length?
struct StringScan {
  std::vector<std::pair<std::string, bool>> strings;
};

herr_t scan_attr(hid_t obj, const char* name, const H5A_info_t*, void* data) {
  auto* scan = static_cast<StringScan*>(data);
  const hid_t a = H5Aopen(obj, name, H5P_DEFAULT);
  const hid_t t = H5Aget_type(a);
  if (H5Tget_class(t) == H5T_STRING)
    scan->strings.emplace_back(std::string("@") + name, H5Tis_variable_str(t) > 0);
  H5Tclose(t);
  H5Aclose(a);
  return 0;
}

herr_t scan_object(hid_t root, const char* name, const H5O_info_t* info, void* data) {
  auto* scan = static_cast<StringScan*>(data);
  const hid_t o = H5Oopen(root, name, H5P_DEFAULT);
  hsize_t idx = 0;
  H5Aiterate2(o, H5_INDEX_NAME, H5_ITER_INC, &idx, scan_attr, scan);
  if (info->type == H5O_TYPE_DATASET) {
    const hid_t t = H5Dget_type(o);
    if (H5Tget_class(t) == H5T_STRING) scan->strings.emplace_back(name, H5Tis_variable_str(t) > 0);
    H5Tclose(t);
  }
  H5Oclose(o);
  return 0;
}

}  // namespace

TEST(FormatsPrediction, RoundTripIsExact) {
  TempDir dir;
  burrbench::test::write_text(dir / "experiment.toml", "name = 'x'\n");
  const bb::Prediction a = make_prediction(dir / "experiment.toml");
  bb::write_prediction(dir / "p.h5", a);
  std::size_t files = 0;  // written through a temporary name: only the target remains
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 2u);

  const bb::Prediction b = bb::read_prediction(dir / "p.h5");
  ASSERT_EQ(b.recordings.size(), a.recordings.size());
  for (std::size_t i = 0; i < a.recordings.size(); ++i) {
    const auto &ra = a.recordings[i], &rb = b.recordings[i];
    SCOPED_TRACE(ra.recording_id);
    EXPECT_EQ(rb.recording_id, ra.recording_id);  // order and UTF-8 kept
    EXPECT_TRUE(same_bits(rb.t_s, ra.t_s));
    EXPECT_TRUE(same_bits(rb.force_burr_vol_N, ra.force_burr_vol_N));
    EXPECT_TRUE(same_bits(rb.force_sensor_pred_N, ra.force_sensor_pred_N));
    EXPECT_TRUE(same_bits(rb.force_sensor_meas_N, ra.force_sensor_meas_N));
    EXPECT_TRUE(same_bits(rb.centre_vol_mm, ra.centre_vol_mm));
    EXPECT_TRUE(same_bits(rb.normal_vol, ra.normal_vol));
    EXPECT_TRUE(same_bits(rb.depth_b_mm, ra.depth_b_mm));
    EXPECT_EQ(rb.class_mask, ra.class_mask);
    EXPECT_EQ(rb.buried, ra.buried);
    EXPECT_EQ(rb.use, ra.use);
    EXPECT_EQ(std::memcmp(rb.removed_mm3.data(), ra.removed_mm3.data(), sizeof(ra.removed_mm3)), 0);
    EXPECT_EQ(rb.steps, ra.steps);
    EXPECT_EQ(rb.registration_method, ra.registration_method);
    for (auto m : {&bb::PredictedRecording::registration_rms_mm,
                   &bb::PredictedRecording::registration_max_mm,
                   &bb::PredictedRecording::fiducial_error_mm,
                   &bb::PredictedRecording::tre_path_rms_mm, &bb::PredictedRecording::tre_path_max_mm})
      EXPECT_TRUE(rb.*m == ra.*m || (std::isnan(rb.*m) && std::isnan(ra.*m))) << rb.*m;
  }
  {  // 2.3
    const auto &ra = a.recordings[0], &rb = b.recordings[0];
    EXPECT_EQ(rb.role, "calibrate");
    EXPECT_EQ(rb.used_calibrate, ra.used_calibrate);
    EXPECT_EQ(rb.used_validate, ra.used_validate);
    EXPECT_EQ(rb.force_bias_N, ra.force_bias_N);
    EXPECT_EQ(rb.torque_bias_Nmm, ra.torque_bias_Nmm);
    EXPECT_EQ(rb.force_bias_source, "fit");
    EXPECT_EQ(rb.torque_bias_source, "tare");
    EXPECT_EQ(rb.spindle_offset_source, "fit");
    EXPECT_TRUE(same_bits(rb.spindle_offset_Nmm, ra.spindle_offset_Nmm));
    EXPECT_TRUE(same_bits(rb.band95_N, ra.band95_N));
    EXPECT_EQ(rb.lag_ms, ra.lag_ms);
    EXPECT_EQ(rb.depth_offset_mm, ra.depth_offset_mm);
    EXPECT_EQ(std::memcmp(rb.friction_energy_mJ.data(), ra.friction_energy_mJ.data(), sizeof(ra.friction_energy_mJ)), 0);
    EXPECT_EQ(rb.quadrature, "cube");  // 2.4
    EXPECT_EQ(b.recordings[1].quadrature, "lens");
    // Older or plain recordings: no role, nothing applied, the lag not recorded.
    EXPECT_EQ(b.recordings[1].role, "");
    EXPECT_EQ(b.recordings[1].force_bias_source, "none");
    EXPECT_TRUE(b.recordings[1].used_calibrate.empty());
    EXPECT_TRUE(b.recordings[1].band95_N.empty());
    EXPECT_TRUE(std::isnan(b.recordings[1].lag_ms));
    ASSERT_EQ(b.removed.size(), 1u);
    const auto &sa = a.removed[0], &sb = b.removed[0];
    EXPECT_EQ(sb.sample_id, sa.sample_id);
    EXPECT_EQ(sb.nx, 3u);
    EXPECT_EQ(sb.ny, 2u);
    EXPECT_EQ(sb.voxel_mm, sa.voxel_mm);
    EXPECT_EQ(sb.removed_depth_mm, sa.removed_depth_mm);
    EXPECT_EQ(sb.removed_class, sa.removed_class);
    EXPECT_EQ(sb.removed_volume_mm3, sa.removed_volume_mm3);
  }
  EXPECT_EQ(b.recordings[0].registration_rms_mm, 0.0057);
  EXPECT_TRUE(std::isnan(b.recordings[1].tre_path_rms_mm));  // not stored for a given transform
  EXPECT_EQ(b.recordings[0].samples(), 40u);
  EXPECT_EQ(b.recordings[2].samples(), 0u);
  EXPECT_EQ(b.provenance.software_version, a.provenance.software_version);
  EXPECT_FALSE(b.provenance.software_version.empty());
  EXPECT_EQ(b.provenance.command_line, a.provenance.command_line);
  EXPECT_EQ(b.provenance.created_utc, a.provenance.created_utc);
  ASSERT_EQ(b.provenance.inputs.size(), 1u);
  EXPECT_EQ(b.provenance.inputs[0].path, a.provenance.inputs[0].path);
  EXPECT_EQ(b.provenance.inputs[0].sha256, burrbench::sha256_file(dir / "experiment.toml"));
}

TEST(FormatsPrediction, FileUsesFixedLengthStringsAndTheChecksummedFormat) {
  TempDir dir;
  bb::write_prediction(dir / "p.h5", make_prediction({}));
  File f(dir / "p.h5", H5F_ACC_RDONLY);
  ASSERT_GE(f.id, 0);
  // Superblock version >= 2 is the 1.8 file format, whose metadata is checksummed.
  H5F_info2_t info{};
  ASSERT_GE(H5Fget_info2(f.id, &info), 0);
  EXPECT_GE(info.super.version, 2u);
  StringScan scan;
  ASSERT_GE(H5Ovisit2(f.id, H5_INDEX_NAME, H5_ITER_INC, scan_object, &scan, H5O_INFO_BASIC), 0);
  // format, format_version, 3 provenance attributes, 2 provenance string datasets and a
  // unit on each of the 10 datasets of the 3 recordings, 2 registration methods; 2.3: 3
  // offset sources per recording, one role, a unit on the first recording's 5 optional
  // datasets (spindle prediction and offset, band, 2 role flags) and on the 2 maps; 2.4:
  // the quadrature of each recording.
  EXPECT_EQ(scan.strings.size(), 2u + 3u + 2u + 3u * 10u + 2u + 3u * 3u + 1u + 5u + 2u + 3u);
  for (const auto& [name, variable] : scan.strings)
    EXPECT_FALSE(variable) << name << " is a variable-length string";
}

TEST(FormatsPrediction, ValidatorNamesFieldAndWritesNothing) {
  TempDir dir;
  const auto base = make_prediction({});
  auto check = [&](auto mutate, std::initializer_list<std::string> frags) {
    bb::Prediction p = base;
    mutate(p);
    expect_input_error([&] { bb::write_prediction(dir / "bad.h5", p); }, frags);
    EXPECT_FALSE(std::filesystem::exists(dir / "bad.h5"));
  };
  check([](bb::Prediction& p) { p.recordings[0].force_sensor_meas_N.pop_back(); },
        {"bad.h5", "/recordings/sweep/force_sensor_meas_N", "40 values"});
  check([](bb::Prediction& p) { p.recordings[1].force_burr_vol_N[3].y = NAN; },
        {"/recordings/plunge-ß/force_burr_vol_N[3][1]", "finite"});
  check([](bb::Prediction& p) { p.recordings[0].t_s[7] = p.recordings[0].t_s[6]; },
        {"/recordings/sweep/t_s[7]", "strictly increasing"});
  check([](bb::Prediction& p) { p.recordings[0].buried[2] = 2; },
        {"/recordings/sweep/buried[2]", "0 or 1"});
  check([](bb::Prediction& p) { p.recordings[0].depth_b_mm[1] = INFINITY; },
        {"/recordings/sweep/depth_b_mm[1]"});
  check([](bb::Prediction& p) { p.recordings[1].removed_mm3[2] = -1; },
        {"/recordings/plunge-ß/@removed_mm3[2]"});
  check([](bb::Prediction& p) { p.recordings[2].recording_id = "sweep"; },
        {"/recordings/sweep", "unique"});
  check([](bb::Prediction& p) { p.recordings[2].recording_id = "a/b"; }, {"without '/'"});
  // 2.3
  check([](bb::Prediction& p) { p.recordings[0].role = "train"; }, {"/recordings/sweep/@role", "calibrate or validate"});
  check([](bb::Prediction& p) { p.recordings[0].quadrature = "sphere"; }, {"/recordings/sweep/@quadrature", "lens or cube"});
  check([](bb::Prediction& p) { p.recordings[0].force_bias_source = "guess"; },
        {"/recordings/sweep/@force_bias_source", "fit, tare or none"});
  check([](bb::Prediction& p) { p.recordings[0].used_validate[3] = 2; }, {"/recordings/sweep/used_validate[3]", "0 or 1"});
  check([](bb::Prediction& p) { p.recordings[0].used_calibrate.pop_back(); },
        {"/recordings/sweep/used_calibrate", "40 values"});
  check([](bb::Prediction& p) { p.recordings[0].band95_N[5].z = NAN; }, {"/recordings/sweep/band95_N[5][2]", "finite"});
  check([](bb::Prediction& p) { p.recordings[0].torque_bias_Nmm.x = INFINITY; }, {"/recordings/sweep/@torque_bias_Nmm"});
  check([](bb::Prediction& p) { p.removed[0].removed_depth_mm[4] = -1; },
        {"/samples/femur-ß/removed_depth_mm[4]", ">= 0"});
  check([](bb::Prediction& p) { p.removed[0].removed_class.pop_back(); }, {"/samples/femur-ß", "2×3"});
  check([](bb::Prediction& p) { p.removed[0].removed_class[0] = 9; }, {"/samples/femur-ß/removed_class[0]", "0..7"});
  check([](bb::Prediction& p) { p.removed[0].voxel_mm = 0; }, {"/samples/femur-ß/@voxel_mm"});
}

TEST(FormatsPrediction, WrongFormatNameIsRejected) {
  TempDir dir;
  bb::write_prediction(dir / "p.h5", make_prediction({}));
  set_string_attr(dir / "p.h5", "/", "format", "burrbench.recording");
  const std::string p = (dir / "p.h5").string();
  expect_rejected_unchanged(
      dir / "p.h5", [&] { bb::read_prediction(p); },
      {p + ": /@format: expected \"burrbench.prediction\", got \"burrbench.recording\""});
  // A real file of another format, and the other way round.
  bb::Recording rec;
  bb::write_recording(dir / "r.h5", rec);
  expect_input_error(
      [&] { bb::read_prediction(dir / "r.h5"); },
      {"r.h5: /@format: expected \"burrbench.prediction\", got \"burrbench.recording\""});
  bb::write_prediction(dir / "q.h5", make_prediction({}));
  expect_input_error([&] { bb::read_recording(dir / "q.h5"); },
                     {"q.h5: /@format", "got \"burrbench.prediction\""});
}

TEST(FormatsPrediction, OtherMajorVersionsAreRejectedNewerMinorRead) {
  TempDir dir;
  for (const char* v : {"3.0", "1.0"}) {
    bb::write_prediction(dir / "p.h5", make_prediction({}));
    set_string_attr(dir / "p.h5", "/", "format_version", v);
    expect_rejected_unchanged(dir / "p.h5", [&] { bb::read_prediction(dir / "p.h5"); },
                              {"p.h5: /@format_version", "\"2.x\"",
                               std::string("\"") + v + "\" (unknown major version)"});
  }
  set_string_attr(dir / "p.h5", "/", "format_version", "2.9");
  EXPECT_EQ(bb::read_prediction(dir / "p.h5").recordings.size(), 3u);
}

TEST(FormatsPrediction, Version20FilesReadWithoutRegistrationAndBadDistancesAreNamed) {
  TempDir dir;
  bb::write_prediction(dir / "p.h5", make_prediction({}));
  set_string_attr(dir / "p.h5", "/", "format_version", "2.0");
  for (const char* a : {"registration_method", "registration_rms_mm", "registration_max_mm",
                        "fiducial_error_mm", "tre_path_rms_mm", "tre_path_max_mm"})
    delete_attr(dir / "p.h5", "/recordings/sweep", a);
  const auto old = bb::read_prediction(dir / "p.h5");
  EXPECT_EQ(old.recordings[0].registration_method, "");
  EXPECT_TRUE(std::isnan(old.recordings[0].registration_rms_mm));

  bb::write_prediction(dir / "q.h5", make_prediction({}));
  delete_attr(dir / "q.h5", "/recordings/sweep", "tre_path_max_mm");
  {
    File f(dir / "q.h5");
    ASSERT_GE(f.id, 0);
    const hid_t sp = H5Screate(H5S_SCALAR);
    const hid_t a = H5Acreate_by_name(f.id, "/recordings/sweep", "tre_path_max_mm", H5T_IEEE_F64LE,
                                      sp, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    ASSERT_GE(a, 0);
    const double negative = -0.5;
    EXPECT_GE(H5Awrite(a, H5T_NATIVE_DOUBLE, &negative), 0);
    H5Aclose(a);
    H5Sclose(sp);
  }
  expect_rejected_unchanged(dir / "q.h5", [&] { bb::read_prediction(dir / "q.h5"); },
                            {"q.h5: /recordings/sweep/@tre_path_max_mm", "a distance in mm", "-0.5"});
}

TEST(FormatsPrediction, MissingOrMalformedFieldsAreNamed) {
  TempDir dir;
  auto fresh = [&] {
    bb::write_prediction(dir / "p.h5", make_prediction({}));
    return dir / "p.h5";
  };
  auto rejected = [&](std::initializer_list<std::string> frags) {
    expect_rejected_unchanged(
        dir / "p.h5", [&] { bb::read_prediction(dir / "p.h5"); }, frags);
  };
  delete_link(fresh(), "/recordings/sweep/force_sensor_meas_N");
  rejected({"p.h5: /recordings/sweep/force_sensor_meas_N: expected a dataset, got missing"});
  delete_link(fresh(), "/recordings/polish/t_s");
  rejected({"p.h5: /recordings/polish/t_s: expected a dataset, got missing"});
  delete_link(fresh(), "/provenance");
  rejected({"p.h5: /provenance: expected a group, got missing"});
  delete_attr(fresh(), "/recordings/plunge-ß", "removed_mm3");
  rejected({"/recordings/plunge-ß/@removed_mm3: expected 8 numbers, got missing"});
  delete_attr(fresh(), "/recordings/sweep/depth_b_mm", "unit");
  rejected({"/recordings/sweep/depth_b_mm/@unit: expected a string attribute, got missing"});
  set_string_attr(fresh(), "/recordings/sweep/force_burr_vol_N", "unit", "kN");
  rejected({"/recordings/sweep/force_burr_vol_N/@unit: expected \"N\", got \"kN\""});
  replace_dataset(fresh(), "/recordings/sweep/centre_vol_mm", {39, 3}, "mm");
  rejected({"/recordings/sweep/centre_vol_mm: expected a float64 dataset of shape [40×3]"});
  replace_dataset(fresh(), "/recordings/sweep/buried", {40}, "1 = contact normal ill-defined");
  rejected({"/recordings/sweep/buried: expected uint8 dataset, got float64"});
  replace_dataset(fresh(), "/recordings/sweep/extra_N", {40}, "N");
  rejected({"/recordings/sweep/extra_N: expected only known members here", "got unknown member"});
  // Values are validated as on writing: a NaN force.
  fresh();
  {
    File f(dir / "p.h5");
    const hid_t d = H5Dopen2(f.id, "/recordings/plunge-ß/force_sensor_pred_N", H5P_DEFAULT);
    std::vector<double> v(75);
    H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    v[3 * 4 + 2] = NAN;
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data());
    H5Dclose(d);
  }
  rejected({"/recordings/plunge-ß/force_sensor_pred_N[4][2]: expected a finite value, got nan"});
}

TEST(FormatsPrediction, CorruptedFilesOnlyEverRaiseInputError) {
  TempDir dir;
  bb::write_prediction(dir / "p.h5", make_prediction({}));
  const std::string base = burrbench::test::file_bytes(dir / "p.h5");
  const int rejected = burrbench::test::count_rejected_corruptions(
      base, dir / "c.h5", 200, 4242, 4, false, [](const auto& p) { bb::read_prediction(p); });
  EXPECT_GT(rejected, 60);
}

TEST(FormatsPrediction, InspectRecognisesAndSummarisesIt) {
  TempDir dir;
  bb::write_prediction(dir / "p.h5", make_prediction({}));
  EXPECT_EQ(bb::detect_format(dir / "p.h5"), bb::FileFormat::kPrediction);
  EXPECT_STREQ(bb::format_name(bb::FileFormat::kPrediction), "burrbench.prediction");
  const std::string s = bb::describe_file(dir / "p.h5");
  EXPECT_NE(s.find("prediction (burrbench.prediction), 3 recordings"), std::string::npos) << s;
  EXPECT_NE(s.find("recording sweep: 40 samples"), std::string::npos) << s;
  EXPECT_NE(s.find("recording polish: 0 samples"), std::string::npos) << s;
  EXPECT_NE(s.find("removed mm³: class 1 0.0625 class 2 0.333333 class 7 7e-09"), std::string::npos)
      << s;
  // A broken one is refused by inspect with the field, as the reader does.
  set_string_attr(dir / "p.h5", "/recordings/sweep/t_s", "unit", "ms");
  expect_input_error([&] { bb::describe_file(dir / "p.h5"); },
                     {"/recordings/sweep/t_s/@unit", "\"s\""});
}
