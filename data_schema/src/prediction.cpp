// Prediction: validator, HDF5 writer and reader. Layout (docs/formats.md):
//   /@format, /@format_version, /provenance, /recordings/<id>/{t_s, force_burr_vol_N,
//   force_sensor_pred_N, force_sensor_meas_N, centre_vol_mm, normal_vol, depth_b_mm,
//   class_mask, buried, use} (each with @unit), /recordings/<id>/@removed_mm3, @steps,
//   @registration_* (2.1, optional); 2.2, optional (present when the writer had them):
//   moment_burr_vol_Nmm, torque_sensor_pred_Nmm, torque_sensor_meas_Nmm,
//   spindle_torque_pred_Nmm, spindle_torque_meas_Nmm; 2.3, optional: used_calibrate,
//   used_validate, spindle_offset_Nmm, band95_N, @role, @force_bias_N, @force_bias_source,
//   @torque_bias_Nmm, @torque_bias_source, @spindle_offset_source, @lag_ms,
//   @depth_offset_mm, @friction_energy_mJ; /samples/<id>/{removed_depth_mm,
//   removed_class} [ny, nx] with @voxel_mm, @removed_volume_mm3; 2.4: @quadrature per
//   recording and, optional, spin_rad_s and /context (the run's context, JSON as UTF-8 bytes).
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
                                    {"spindle_torque_meas_Nmm", "N*mm", &PR::spindle_torque_meas_Nmm},
                                    {"spindle_offset_Nmm", "N*mm", &PR::spindle_offset_Nmm},  // 2.3
                                    {"spin_rad_s", "rad/s", &PR::spin_rad_s}};                // 2.4
// 2.3: optional per-sample datasets.
constexpr Vec3Field kBand{"band95_N", "N", &PR::band95_N};
constexpr FlagField kRoleFlags[] = {
    {"used_calibrate", "1 = counts in the fit's residuals", &PR::used_calibrate, 1},
    {"used_validate", "1 = counts in the release gate's residuals", &PR::used_validate, 1}};
// 2.3: what was added to a predicted channel, by its source.
constexpr std::array<std::pair<const char*, std::string PR::*>, 3> kSources{{
    {"force_bias_source", &PR::force_bias_source},
    {"torque_bias_source", &PR::torque_bias_source},
    {"spindle_offset_source", &PR::spindle_offset_source}}};
constexpr std::array<std::pair<const char*, glm::dvec3 PR::*>, 2> kOffsets{{
    {"force_bias_N", &PR::force_bias_N}, {"torque_bias_Nmm", &PR::torque_bias_Nmm}}};
constexpr FlagField kFlags[] = {
    {"class_mask", "bit k = class label k in contact", &PR::class_mask, 255},
    {"buried", "1 = contact normal ill-defined", &PR::buried, 1},
    {"use", "1 = inside a used segment", &PR::use, 1}};

// t_s + 5 vectors + depth (float64) + 3 flags (uint8) per sample, + the 2.2 wrench.
// 2.3: two flags, the band and the spindle offset; 2.4: the spin speed.
constexpr std::uint64_t kBytesPerSample = 8 + 5 * 24 + 8 + 3 + 3 * 24 + 2 * 8 + 2 + 24 + 8 + 8;
constexpr std::uint64_t kMaxContextBytes = 64ull << 20;  // the /context document
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
  vectors(kBand, true);
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
  for (const auto& f : kRoleFlags)
    if (!(r.*f.member).empty()) same_len((r.*f.member).size(), f.name);
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
  for (const auto& f : kRoleFlags)
    for (std::size_t k = 0; k < (r.*f.member).size(); ++k)
      if ((r.*f.member)[k] > 1)
        throw InputError(file, fmt::format("{}/{}[{}]", b, f.name, k), "0 or 1", std::to_string((r.*f.member)[k]));
  if (!r.role.empty() && r.role != "calibrate" && r.role != "validate")
    throw InputError(file, b + "/@role", "calibrate or validate", r.role);
  if (r.quadrature != "lens" && r.quadrature != "cube")
    throw InputError(file, b + "/@quadrature", "lens or cube", r.quadrature);
  for (const auto& [name, m] : kSources)
    if (r.*m != "fit" && r.*m != "tare" && r.*m != "none")
      throw InputError(file, b + "/@" + name, "fit, tare or none", r.*m);
  for (const auto& [name, m] : kOffsets)
    if (!std::isfinite((r.*m).x) || !std::isfinite((r.*m).y) || !std::isfinite((r.*m).z))
      throw InputError(file, b + "/@" + name, "3 finite values", "a non-finite value");
  if (!(std::isnan(r.lag_ms) || std::abs(r.lag_ms) < 1e6))
    throw InputError(file, b + "/@lag_ms", "a lag in ms, |lag| < 1e6", fmt::format("{}", r.lag_ms));
  if (!std::isfinite(r.depth_offset_mm))
    throw InputError(file, b + "/@depth_offset_mm", "a finite offset in mm", fmt::format("{}", r.depth_offset_mm));
  for (std::size_t c = 0; c < r.friction_energy_mJ.size(); ++c)
    if (!std::isfinite(r.friction_energy_mJ[c]))
      throw InputError(file, fmt::format("{}/@friction_energy_mJ[{}]", b, c), "a finite energy in mJ",
                       fmt::format("{}", r.friction_energy_mJ[c]));
}

void validate_removed(const RemovedBone& s, const std::string& file) {
  const std::string b = "/samples/" + s.sample_id;
  if (!valid_name(s.sample_id)) throw InputError(file, b, "a sample id without '/'");
  if (!(s.voxel_mm > 0 && s.voxel_mm < 1e3))
    throw InputError(file, b + "/@voxel_mm", "a voxel edge in mm, 0 < l < 1000", fmt::format("{}", s.voxel_mm));
  const std::size_t n = s.nx * s.ny;
  if (s.removed_depth_mm.size() != n || s.removed_class.size() != n)
    throw InputError(file, b, fmt::format("{}×{} removed-depth and class maps", s.ny, s.nx),
                     fmt::format("{} and {} values", s.removed_depth_mm.size(), s.removed_class.size()));
  for (std::size_t i = 0; i < n; ++i) {
    if (!(s.removed_depth_mm[i] >= 0 && std::isfinite(s.removed_depth_mm[i])))
      throw InputError(file, fmt::format("{}/removed_depth_mm[{}]", b, i), "a finite depth >= 0 mm",
                       fmt::format("{}", s.removed_depth_mm[i]));
    if (s.removed_class[i] >= kPredictionClasses)
      throw InputError(file, fmt::format("{}/removed_class[{}]", b, i), fmt::format("a class label 0..{}", kPredictionClasses - 1),
                       std::to_string(s.removed_class[i]));
  }
  if (!(s.removed_volume_mm3 >= 0 && std::isfinite(s.removed_volume_mm3)))
    throw InputError(file, b + "/@removed_volume_mm3", "a finite volume >= 0 mm³", fmt::format("{}", s.removed_volume_mm3));
}

}  // namespace

void validate(const Prediction& p, const std::string& file) {
  if (!p.context.is_null() && !p.context.is_object()) throw InputError(file, "/context", "a JSON object");
  std::set<std::string> ids;
  for (const auto& r : p.recordings) {
    if (!ids.insert(r.recording_id).second)
      throw InputError(file, base(r.recording_id), "unique recording ids", "duplicate");
    validate_recording(r, file);
  }
  std::set<std::string> samples;
  for (const auto& s : p.removed) {
    if (!samples.insert(s.sample_id).second)
      throw InputError(file, "/samples/" + s.sample_id, "unique sample ids", "duplicate");
    validate_removed(s, file);
  }
}

std::vector<std::pair<std::string, std::string>> prediction_units() {
  std::vector<std::pair<std::string, std::string>> out{{kTime.name, kTime.unit}};
  for (const auto& f : kVec3) out.emplace_back(f.name, f.unit);
  out.emplace_back(kDepth.name, kDepth.unit);
  for (const auto& f : kWrench3) out.emplace_back(f.name, f.unit);
  for (const auto& f : kWrench1) out.emplace_back(f.name, f.unit);
  out.emplace_back(kBand.name, kBand.unit);
  for (const auto& f : kRoleFlags) out.emplace_back(f.name, f.unit);
  for (const auto& f : kFlags) out.emplace_back(f.name, f.unit);
  // The recording's numeric attributes (docs/formats.md).
  out.insert(out.end(), {{"force_bias_N", "N"}, {"torque_bias_Nmm", "N*mm"}, {"removed_mm3", "mm^3"},
                         {"friction_energy_mJ", "mJ"}, {"lag_ms", "ms"}, {"depth_offset_mm", "mm"}});
  return out;
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
    if (!r.band95_N.empty()) vectors(kBand);
    auto flags = [&](const FlagField& f) {
      w.dataset(b + "/" + f.name, {n}, (r.*f.member).data(), true);
      w.attr(b + "/" + f.name, "unit", std::string(f.unit));
    };
    for (const auto& f : kFlags) flags(f);
    for (const auto& f : kRoleFlags)
      if (!(r.*f.member).empty()) flags(f);
    if (!r.role.empty()) w.attr(b, "role", r.role);
    w.attr(b, "quadrature", r.quadrature);
    for (const auto& [name, m] : kSources) w.attr(b, name, r.*m);
    for (const auto& [name, m] : kOffsets) w.attr(b, name, std::vector<double>{(r.*m).x, (r.*m).y, (r.*m).z});
    if (std::isfinite(r.lag_ms)) w.attr(b, "lag_ms", r.lag_ms);
    w.attr(b, "depth_offset_mm", r.depth_offset_mm);
    w.attr(b, "friction_energy_mJ", std::vector<double>(r.friction_energy_mJ.begin(), r.friction_energy_mJ.end()));
    w.attr(b, "removed_mm3", std::vector<double>(r.removed_mm3.begin(), r.removed_mm3.end()));
    w.attr(b, "steps", r.steps);
    if (!r.registration_method.empty()) w.attr(b, "registration_method", r.registration_method);
    for (const auto& [name, m] : kRegistrationNumbers)
      if (std::isfinite(r.*m)) w.attr(b, name, r.*m);
  }
  if (!p.removed.empty()) w.group("/samples");
  for (const auto& s : p.removed) {
    const std::string b = "/samples/" + s.sample_id;
    w.group(b);
    w.dataset(b + "/removed_depth_mm", {s.ny, s.nx}, s.removed_depth_mm.data(), true);
    w.attr(b + "/removed_depth_mm", "unit", std::string("mm"));
    w.dataset(b + "/removed_class", {s.ny, s.nx}, s.removed_class.data(), true);
    w.attr(b + "/removed_class", "unit", std::string("class label"));
    w.attr(b, "voxel_mm", s.voxel_mm);
    w.attr(b, "removed_volume_mm3", s.removed_volume_mm3);
  }
  if (p.context.is_object()) {
    const std::string text = p.context.dump();
    w.dataset("/context", {hsize_t(text.size())}, reinterpret_cast<const std::uint8_t*>(text.data()), true);
    w.attr("/context", "unit", std::string("JSON, UTF-8"));
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
  names.push_back(kBand.name);
  for (const auto& f : kRoleFlags) names.push_back(f.name);
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
  if (r.exists(b + "/" + kBand.name)) vectors(kBand);
  for (const auto& f : kRoleFlags)
    if (r.exists(b + "/" + f.name))
      out.*f.member = read_column<std::uint8_t>(r, b + "/" + f.name, h5::Elem::kUInt8, n, 1, f.unit);
  out.role = r.attr_string_opt(b, "role").value_or("");
  out.quadrature = r.attr_string_opt(b, "quadrature").value_or("lens");
  for (const auto& [name, m] : kSources) out.*m = r.attr_string_opt(b, name).value_or("none");
  for (const auto& [name, m] : kOffsets)
    if (r.has_attr(b, name)) {
      const auto v = r.attr_doubles(b, name, 3);
      out.*m = {v[0], v[1], v[2]};
    }
  if (r.has_attr(b, "lag_ms")) out.lag_ms = r.attr_double(b, "lag_ms");
  if (r.has_attr(b, "depth_offset_mm")) out.depth_offset_mm = r.attr_double(b, "depth_offset_mm");
  if (r.has_attr(b, "friction_energy_mJ")) {
    const auto e = r.attr_doubles(b, "friction_energy_mJ", kPredictionClasses);
    std::copy(e.begin(), e.end(), out.friction_energy_mJ.begin());
  }
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

RemovedBone read_removed(const h5::Reader& r, const std::string& id) {
  RemovedBone s;
  s.sample_id = id;
  const std::string b = "/samples/" + id;
  r.expect_only(b, {"removed_depth_mm", "removed_class"});
  const auto shape = r.shape(b + "/removed_depth_mm", h5::Elem::kFloat32);
  if (shape.size() != 2 || shape[0] > (1u << 16) || shape[1] > (1u << 16))
    throw InputError(r.file(), b + "/removed_depth_mm", "a 2-D float32 map of at most 65536×65536",
                     fmt::format("rank {}", shape.size()));
  s.ny = shape[0];
  s.nx = shape[1];
  s.removed_depth_mm = read_column<float>(r, b + "/removed_depth_mm", h5::Elem::kFloat32, s.ny, s.nx, "mm");
  s.removed_class = read_column<std::uint8_t>(r, b + "/removed_class", h5::Elem::kUInt8, s.ny, s.nx, "class label");
  s.voxel_mm = r.attr_double(b, "voxel_mm");
  s.removed_volume_mm3 = r.attr_double(b, "removed_volume_mm3");
  return s;
}

}  // namespace

namespace {
Prediction read_prediction_from(const h5::Reader& r);
}  // namespace

Prediction read_prediction(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  return read_prediction_from(h5::Reader(path));
}

Prediction read_prediction_image(std::string_view image, const std::string& name) {
  const ReadingFile reading(name);
  return read_prediction_from(h5::Reader(image, name));
}

namespace {
Prediction read_prediction_from(const h5::Reader& r) {
  const std::string file = r.file();
  h5::check_header(r, kPredictionFormat, kPredictionVersionMajor);
  r.expect_only("/", {"provenance", "recordings", "samples", "context"});
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
  if (r.exists("/samples"))
    for (const auto& id : r.members("/samples")) p.removed.push_back(read_removed(r, id));
  if (r.exists("/context")) {  // 2.4
    std::vector<hsize_t> shape;
    const auto bytes = r.read<std::uint8_t>("/context", h5::Elem::kUInt8, &shape, kMaxContextBytes);
    if (shape.size() != 1) throw InputError(file, "/context", "a 1-D uint8 dataset (JSON text)");
    check_unit(r, "/context", "JSON, UTF-8");
    p.context = nlohmann::json::parse(bytes.begin(), bytes.end(), nullptr, false);
    if (!p.context.is_object()) throw InputError(file, "/context", "a JSON object");
  }
  validate(p, file);
  return p;
}
}  // namespace

}  // namespace burrbench::data_schema
