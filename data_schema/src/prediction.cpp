// Prediction: validator, HDF5 writer and reader. Layout (docs/formats.md):
//   /@format, /@format_version, /provenance, /recordings/<id>/{t_s, force_burr_vol_N,
//   force_sensor_pred_N, force_sensor_meas_N, centre_vol_mm, normal_vol, depth_b_mm,
//   class_mask, buried, use} (each with @unit), /recordings/<id>/@removed_mm3, @steps,
//   @registration_* (2.1, optional); 2.2, optional (present when the writer had them):
//   moment_burr_vol_Nmm, torque_sensor_pred_Nmm, torque_sensor_meas_Nmm,
//   spindle_torque_pred_Nmm, spindle_torque_meas_Nmm.
#include "burrbench/data_schema/prediction.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <utility>

#include "burrbench/data_schema/error.hpp"
#include "hdf5/h5.hpp"
#include "hdf5/h5_common.hpp"

namespace burrbench::data_schema {

namespace {

using PR = PredictedRecording;

// 2.1: the registration's numbers, attributes of the recording group (absent when NaN).
constexpr std::array<std::pair<const char*, double PR::*>, 5> kRegistrationNumbers{{
    {"registration_rms_mm", &PR::registration_rms_mm},
    {"registration_max_mm", &PR::registration_max_mm},
    {"fiducial_error_mm", &PR::fiducial_error_mm},
    {"tre_path_rms_mm", &PR::tre_path_rms_mm},
    {"tre_path_max_mm", &PR::tre_path_max_mm}}};

// Per-sample datasets, in file order within their kind. Units are checked on reading:
// the unit is part of the contract, not a comment.
struct ScalarField {
  const char* name;
  const char* unit;
  std::vector<double> PR::*member;
};
struct Vec3Field {
  const char* name;
  const char* unit;
  std::vector<glm::dvec3> PR::*member;
};
struct FlagField {
  const char* name;
  const char* unit;
  std::vector<std::uint8_t> PR::*member;
  unsigned max;  // largest valid value
};
constexpr ScalarField kTime{"t_s", "s", &PR::t_s};
constexpr Vec3Field kVec3[] = {{"force_burr_vol_N", "N", &PR::force_burr_vol_N},
                               {"force_sensor_pred_N", "N", &PR::force_sensor_pred_N},
                               {"force_sensor_meas_N", "N", &PR::force_sensor_meas_N},
                               {"centre_vol_mm", "mm", &PR::centre_vol_mm},
                               {"normal_vol", "1", &PR::normal_vol}};
constexpr ScalarField kDepth{"depth_b_mm", "mm", &PR::depth_b_mm};
// 2.2: the wrench (MODEL.md "Moments"), each empty or one value per sample.
constexpr Vec3Field kWrench3[] = {{"moment_burr_vol_Nmm", "N*mm", &PR::moment_burr_vol_Nmm},
                                  {"torque_sensor_pred_Nmm", "N*mm", &PR::torque_sensor_pred_Nmm},
                                  {"torque_sensor_meas_Nmm", "N*mm", &PR::torque_sensor_meas_Nmm}};
constexpr ScalarField kWrench1[] = {{"spindle_torque_pred_Nmm", "N*mm", &PR::spindle_torque_pred_Nmm},
                                    {"spindle_torque_meas_Nmm", "N*mm", &PR::spindle_torque_meas_Nmm}};
constexpr FlagField kFlags[] = {
    {"class_mask", "bit k = class label k in contact", &PR::class_mask, 255},
    {"buried", "1 = contact normal ill-defined", &PR::buried, 1},
    {"use", "1 = inside a used segment", &PR::use, 1}};

// t_s + 5 vectors + depth (float64) + 3 flags (uint8) per sample, + the 2.2 wrench.
constexpr std::uint64_t kBytesPerSample = 8 + 5 * 24 + 8 + 3 + 3 * 24 + 2 * 8;
constexpr std::uint64_t kMaxElements = 1ull << 31;  // per dataset
constexpr std::uint64_t kMaxPredictionBytes = 4ull << 30;

std::string base(const std::string& id) { return "/recordings/" + id; }

bool valid_name(const std::string& n) {
  return !n.empty() && n != "." && n != ".." && n.find('/') == std::string::npos;
}

void validate_recording(const PR& r, const std::string& file) {
  const std::string b = base(r.recording_id);
  if (!valid_name(r.recording_id)) throw InputError(file, b, "a recording id without '/'");
  const std::size_t n = r.samples();
  auto same_len = [&](std::size_t len, const char* name) {
    if (len != n)
      throw InputError(file, b + "/" + name, fmt::format("{} values (one per t_s sample)", n),
                       std::to_string(len));
  };
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(r.t_s[k]) || (k > 0 && !(r.t_s[k] > r.t_s[k - 1])))
      throw InputError(
          file, fmt::format("{}/t_s[{}]", b, k), "finite, strictly increasing times",
          k > 0 ? fmt::format("{} after {}", r.t_s[k], r.t_s[k - 1]) : fmt::format("{}", r.t_s[k]));
  // Every vector dataset finite and one per sample; the 2.2 wrench ones may be empty.
  auto vectors = [&](const Vec3Field& f, bool optional) {
    const auto& v = r.*f.member;
    if (optional && v.empty()) return;
    same_len(v.size(), f.name);
    for (std::size_t k = 0; k < n; ++k)
      for (int c = 0; c < 3; ++c)
        if (!std::isfinite(v[k][c]))
          throw InputError(file, fmt::format("{}/{}[{}][{}]", b, f.name, k, c), "a finite value",
                           fmt::format("{}", v[k][c]));
  };
  for (const auto& f : kVec3) vectors(f, false);
  for (const auto& f : kWrench3) vectors(f, true);
  for (const auto& f : kWrench1) {
    const auto& v = r.*f.member;
    if (v.empty()) continue;
    same_len(v.size(), f.name);
    for (std::size_t k = 0; k < n; ++k)
      if (!std::isfinite(v[k]))
        throw InputError(file, fmt::format("{}/{}[{}]", b, f.name, k), "a finite value", fmt::format("{}", v[k]));
  }
  same_len(r.depth_b_mm.size(), kDepth.name);
  for (std::size_t k = 0; k < n; ++k)
    if (!std::isfinite(r.depth_b_mm[k]))
      throw InputError(file, fmt::format("{}/depth_b_mm[{}]", b, k), "a finite value",
                       fmt::format("{}", r.depth_b_mm[k]));
  for (const auto& f : kFlags) {
    const auto& v = r.*f.member;
    same_len(v.size(), f.name);
    for (std::size_t k = 0; k < n; ++k)
      if (v[k] > f.max)
        throw InputError(file, fmt::format("{}/{}[{}]", b, f.name, k), f.max == 1 ? "0 or 1" : fmt::format("0..{}", f.max),
                         std::to_string(v[k]));
  }
  for (std::size_t c = 0; c < r.removed_mm3.size(); ++c)
    if (!std::isfinite(r.removed_mm3[c]) || r.removed_mm3[c] < 0)
      throw InputError(file, fmt::format("{}/@removed_mm3[{}]", b, c), "a finite volume >= 0 mm³",
                       fmt::format("{}", r.removed_mm3[c]));
  if (r.steps < 0)
    throw InputError(file, b + "/@steps", "a step count >= 0", std::to_string(r.steps));
}

}  // namespace

void validate(const Prediction& p, const std::string& file) {
  std::set<std::string> ids;
  for (const auto& r : p.recordings) {
    if (!ids.insert(r.recording_id).second)
      throw InputError(file, base(r.recording_id), "unique recording ids", "duplicate");
    validate_recording(r, file);
  }
}

void write_prediction(const std::filesystem::path& path, const Prediction& p) {
  validate(p, path.string());
  h5::Writer w(path);
  h5::write_header(w, kPredictionFormat, kPredictionVersionMajor, kPredictionVersionMinor,
                   p.provenance);
  w.group("/recordings");
  for (const auto& r : p.recordings) {
    const std::string b = base(r.recording_id);
    const hsize_t n = r.samples();
    w.group(b);
    auto scalars = [&](const ScalarField& f) {
      w.dataset(b + "/" + f.name, {n}, (r.*f.member).data(), true);
      w.attr(b + "/" + f.name, "unit", std::string(f.unit));
    };
    auto vectors = [&](const Vec3Field& f) {
      std::vector<double> flat;
      flat.reserve(3 * n);
      for (const auto& x : r.*f.member) flat.insert(flat.end(), {x.x, x.y, x.z});
      w.dataset(b + "/" + f.name, {n, 3}, flat.data(), true);
      w.attr(b + "/" + f.name, "unit", std::string(f.unit));
    };
    scalars(kTime);
    for (const auto& f : kVec3) vectors(f);
    scalars(kDepth);
    for (const auto& f : kWrench3)
      if (!(r.*f.member).empty()) vectors(f);
    for (const auto& f : kWrench1)
      if (!(r.*f.member).empty()) scalars(f);
    for (const auto& f : kFlags) {
      w.dataset(b + "/" + f.name, {n}, (r.*f.member).data(), true);
      w.attr(b + "/" + f.name, "unit", std::string(f.unit));
    }
    w.attr(b, "removed_mm3", std::vector<double>(r.removed_mm3.begin(), r.removed_mm3.end()));
    w.attr(b, "steps", r.steps);
    if (!r.registration_method.empty()) w.attr(b, "registration_method", r.registration_method);
    for (const auto& [name, m] : kRegistrationNumbers)
      if (std::isfinite(r.*m)) w.attr(b, name, r.*m);
  }
  w.commit();
}

namespace {

void check_unit(const h5::Reader& r, const std::string& ds, const char* unit) {
  const std::string got = r.attr_string(ds, "unit");
  if (got != unit)
    throw InputError(r.file(), ds + "/@unit", fmt::format("\"{}\"", unit), "\"" + got + "\"");
}

template <class T>
std::vector<T> read_column(const h5::Reader& r, const std::string& ds, h5::Elem e, std::size_t n,
                           std::size_t width, const char* unit) {
  const std::vector<hsize_t> want =
      width == 1 ? std::vector<hsize_t>{n} : std::vector<hsize_t>{n, width};
  std::vector<hsize_t> shape;
  // At most what the shape allows: a dataset bigger than t_s says is refused unread.
  auto v = r.read<T>(ds, e, &shape, std::max<std::size_t>(n * width, 1));
  if (shape != want)
    throw InputError(r.file(), ds,
                     width == 1
                         ? fmt::format("a 1-D {} dataset of length {}", h5::elem_name(e), n)
                         : fmt::format("a {} dataset of shape [{}×{}]", h5::elem_name(e), n, width),
                     fmt::format("rank {}, {} elements", shape.size(), v.size()));
  check_unit(r, ds, unit);
  return v;
}

PR read_recording(const h5::Reader& r, const std::string& id) {
  PR out;
  out.recording_id = id;
  const std::string b = base(id);
  std::vector<std::string> names{kTime.name, kDepth.name};
  for (const auto& f : kVec3) names.push_back(f.name);
  for (const auto& f : kFlags) names.push_back(f.name);
  for (const auto& f : kWrench3) names.push_back(f.name);
  for (const auto& f : kWrench1) names.push_back(f.name);
  r.expect_only(b, names);
  const auto t_shape = r.shape(b + "/t_s", h5::Elem::kFloat64);
  if (t_shape.size() != 1)
    throw InputError(r.file(), b + "/t_s", "a 1-D float64 dataset",
                     fmt::format("rank {}", t_shape.size()));
  const std::size_t n = t_shape[0];
  out.t_s = read_column<double>(r, b + "/t_s", h5::Elem::kFloat64, n, 1, kTime.unit);
  auto vectors = [&](const Vec3Field& f) {
    const auto flat = read_column<double>(r, b + "/" + f.name, h5::Elem::kFloat64, n, 3, f.unit);
    auto& v = out.*f.member;
    v.resize(n);
    for (std::size_t k = 0; k < n; ++k) v[k] = {flat[3 * k], flat[3 * k + 1], flat[3 * k + 2]};
  };
  for (const auto& f : kVec3) vectors(f);
  for (const auto& f : kWrench3)
    if (r.exists(b + "/" + f.name)) vectors(f);
  for (const auto& f : kWrench1)
    if (r.exists(b + "/" + f.name))
      out.*f.member = read_column<double>(r, b + "/" + f.name, h5::Elem::kFloat64, n, 1, f.unit);
  out.depth_b_mm =
      read_column<double>(r, b + "/" + kDepth.name, h5::Elem::kFloat64, n, 1, kDepth.unit);
  for (const auto& f : kFlags)
    out.*f.member = read_column<std::uint8_t>(r, b + "/" + f.name, h5::Elem::kUInt8, n, 1, f.unit);
  const auto removed = r.attr_doubles(b, "removed_mm3", kPredictionClasses);
  std::copy(removed.begin(), removed.end(), out.removed_mm3.begin());
  out.steps = r.attr_int64(b, "steps");
  out.registration_method = r.attr_string_opt(b, "registration_method").value_or("");
  for (const auto& [name, m] : kRegistrationNumbers)
    if (r.has_attr(b, name)) {
      out.*m = r.attr_double(b, name);
      if (!(out.*m >= 0 && out.*m < 1e6))
        throw InputError(r.file(), b + "/@" + name, "a distance in mm, 0..1e6", fmt::format("{}", out.*m));
    }
  return out;
}

}  // namespace

Prediction read_prediction(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  h5::Reader r(path);
  const std::string file = r.file();
  h5::check_header(r, kPredictionFormat, kPredictionVersionMajor);
  r.expect_only("/", {"provenance", "recordings"});
  Prediction p;
  p.provenance = h5::read_provenance(r);
  const auto ids = r.members("/recordings");
  // Memory budget from the t_s headers before any data is read.
  std::uint64_t total = 0;
  for (const auto& id : ids) {
    const std::string t = base(id) + "/t_s";
    const auto shape = r.shape(t, h5::Elem::kFloat64);
    if (shape.size() != 1)
      throw InputError(file, t, "a 1-D float64 dataset", fmt::format("rank {}", shape.size()));
    total += std::min<std::uint64_t>(shape[0], kMaxElements) * kBytesPerSample;
    if (total > kMaxPredictionBytes)
      throw InputError(file, t, "a prediction within the 4 GiB memory budget",
                       fmt::format("{} samples", shape[0]));
  }
  for (const auto& id : ids) p.recordings.push_back(read_recording(r, id));
  validate(p, file);
  return p;
}

}  // namespace burrbench::data_schema
