#include "burrbench/analysis/analysis_input.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "csv.hpp"

namespace burrbench::analysis {
namespace fs = std::filesystem;
using nlohmann::json;
using data_schema::JsonView;

namespace {

constexpr std::size_t kMaxRows = 50'000'000;         // refuse before allocating
constexpr std::size_t kMaxMapCells = 16'000'000;
// The CSV exports' columns (1.3): one naming scheme everywhere — the prediction file's
// dataset name (docs/formats.md), a vector's component appended as _x/_y/_z, as the
// Python module's to_pandas() names them. 1.0–1.2 directories used the older headers.
struct CsvHeaders {
  const char* predictions;
  const char* wrench;
  const char* band;
};
constexpr CsvHeaders kHeaders{
    "recording_id,t_s,force_sensor_meas_N_x,force_sensor_meas_N_y,force_sensor_meas_N_z,force_sensor_pred_N_x,"
    "force_sensor_pred_N_y,force_sensor_pred_N_z,used",
    "recording_id,t_s,torque_sensor_meas_Nmm_x,torque_sensor_meas_Nmm_y,torque_sensor_meas_Nmm_z,"
    "torque_sensor_pred_Nmm_x,torque_sensor_pred_Nmm_y,torque_sensor_pred_Nmm_z,spindle_torque_meas_Nmm,"
    "spindle_torque_pred_Nmm,spindle_offset_Nmm,spin_rad_s",
    "recording_id,t_s,band95_N_x,band95_N_y,band95_N_z"};
constexpr CsvHeaders kHeaders12{
    "recording_id,t_s,measured_x_N,measured_y_N,measured_z_N,predicted_x_N,predicted_y_N,predicted_z_N,used",
    "recording_id,t_s,torque_meas_x_Nmm,torque_meas_y_Nmm,torque_meas_z_Nmm,torque_pred_x_Nmm,"
    "torque_pred_y_Nmm,torque_pred_z_Nmm,spindle_meas_Nmm,spindle_pred_Nmm,spindle_offset_Nmm,spin_rad_s",
    "recording_id,t_s,band95_x_N,band95_y_N,band95_z_N"};

// One finite number of a CSV field, else InputError naming file, line and column.
double csv_number(const std::string& field, const std::string& file, const std::string& where, std::size_t column) {
  double v = 0;
  try {
    std::size_t used = 0;
    v = std::stod(field, &used);
    if (used != field.size()) throw std::invalid_argument("trailing");
  } catch (const std::exception&) {
    throw InputError(file, where + " column " + std::to_string(column + 1), "a number", field);
  }
  if (!std::isfinite(v)) throw InputError(file, where + " column " + std::to_string(column + 1), "a finite number", field);
  return v;
}

// Every non-empty data row of a CSV with this exact header and `width` fields, as
// (fields, "line N") — the one loop behind the predictions, wrench and band files.
template <class Row>
void for_each_csv_row(const fs::path& path, const char* header, std::size_t width, const std::string& what,
                      Row&& row) {
  const std::string cfile = path.string();
  std::ifstream cf(path);
  if (!cf) throw InputError(cfile, "file", "a readable " + what, "cannot open");
  std::string line;
  if (!std::getline(cf, line) || line != header) throw InputError(cfile, "header", std::string("\"") + header + "\"");
  std::size_t line_no = 1;
  while (std::getline(cf, line)) {
    ++line_no;
    if (line.empty()) continue;
    const auto fields = csv_split(line);
    const std::string where = fmt::format("line {}", line_no);
    if (fields.size() != width) throw InputError(cfile, where, fmt::format("{} fields", width), std::to_string(fields.size()));
    row(fields, where);
  }
}

std::string role_checked(const std::string& role, const std::string& file, const std::string& f) {
  if (role != "calibrate" && role != "validate")
    throw InputError(file, f, "\"calibrate\" or \"validate\"", role);
  return role;
}

}  // namespace

void write_analysis_input(const fs::path& dir, const AnalysisInput& in) {
  fs::create_directories(dir);
  json j;
  j["format"] = kAnalysisFormat;
  j["format_version"] = data_schema::version_string(kAnalysisVersionMajor, kAnalysisVersionMinor);
  j["mode"] = in.mode;
  j["experiment"] = {{"name", in.experiment_name}, {"description", in.experiment_description},
                     {"path", in.experiment_path}, {"sha256", in.experiment_sha256}};
  j["context_of_use"] = in.context_of_use;
  j["params"] = {{"path", in.params_path}, {"sha256", in.params_sha256}};
  j["criteria"] = {{"path", in.criteria_path}, {"sha256", in.criteria_sha256}};
  if (!in.fit_sha256.empty()) j["fit"] = {{"path", in.fit_path}, {"sha256", in.fit_sha256}};
  j["seed"] = in.seed;
  j["model"] = in.model;
  j["calibration"] = in.calibration;
  j["limitations"] = in.limitations;
  j["parameters"] = json::array();
  for (const auto& p : in.parameters)
    j["parameters"].push_back({{"class_label", p.class_label}, {"class_name", p.class_name},
                               {"alpha_N_per_mm2", p.alpha_N_per_mm2},
                               {"c1_N_per_mm2", p.c1_N_per_mm2}, {"mu", p.mu}});
  j["samples"] = json::array();
  for (const auto& s : in.samples) {
    j["samples"].push_back({{"id", s.id}, {"path", s.path}, {"sha256", s.sha256},
                            {"voxel_mm", s.voxel_mm}, {"nx", s.nx}, {"ny", s.ny},
                            {"removed_depth_mm", s.removed_depth_mm},
                            {"removed_volume_mm3", s.removed_volume_mm3}});
    if (!s.removed_class.empty()) {
      json classes = json::object();
      for (const auto& [label, name] : s.classes) classes[std::to_string(label)] = name;
      j["samples"].back()["removed_class"] = s.removed_class;
      j["samples"].back()["classes"] = classes;
    }
  }
  j["recordings"] = json::array();
  for (const auto& r : in.recordings) {
    BURRBENCH_CHECK(r.t_s.size() == r.measured_N.size() && r.t_s.size() == r.predicted_N.size() &&
                        r.t_s.size() == r.used.size(),
                    "series lengths differ for recording " + r.id);
    json segs = json::array();
    for (const auto& s : r.segments)
      segs.push_back({{"label", s.label}, {"start_s", s.start_s}, {"end_s", s.end_s}});
    j["recordings"].push_back({{"id", r.id}, {"sample", r.sample_id}, {"role", r.role},
                               {"path", r.path}, {"sha256", r.sha256}, {"notes", r.notes},
                               {"registration", r.registration},
                               {"segments", segs}, {"samples", r.t_s.size()}});
    {
      const auto& q = r.quality;
      json ev = json::array();
      for (const auto& e : q.events)
        ev.push_back({{"t_s", e.t_s}, {"kind", e.kind}, {"stream", e.stream}, {"detail", e.detail}});
      j["recordings"].back()["quality"] = {{"dropped_force_samples", q.dropped_force_samples},
                                           {"buried_samples", q.buried_samples},
                                           {"stale_rows", q.stale_rows},
                                           {"events", ev}};
    }
    if (!r.band95_N.empty()) {
      BURRBENCH_CHECK(r.band95_N.size() == r.t_s.size(), "band length differs for recording " + r.id);
      j["recordings"].back()["band"] = true;
    }
    if (r.has_torque() || r.has_spindle() || !r.energy.empty()) {
      BURRBENCH_CHECK(!r.has_torque() || (r.torque_measured_Nmm.size() == r.t_s.size() &&
                                          r.torque_predicted_Nmm.size() == r.t_s.size()),
                      "moment series lengths differ for recording " + r.id);
      BURRBENCH_CHECK(!r.has_spindle() || (r.spindle_measured_Nmm.size() == r.t_s.size() &&
                                           r.spindle_predicted_Nmm.size() == r.t_s.size() &&
                                           r.spindle_offset_Nmm.size() == r.t_s.size() &&
                                           r.spin_rad_s.size() == r.t_s.size()),
                      "spindle series lengths differ for recording " + r.id);
      json energy = json::array();
      for (const auto& e : r.energy)
        energy.push_back({{"class_label", e.class_label}, {"class_name", e.class_name},
                          {"alpha_N_per_mm2", e.alpha_N_per_mm2}, {"removed_mm3", e.removed_mm3},
                          {"friction_energy_mJ", e.friction_energy_mJ}});
      auto& jr = j["recordings"].back();
      jr["torque"] = r.has_torque();
      jr["spindle"] = r.has_spindle();
      if (r.has_spindle()) jr["spindle_offset_source"] = r.spindle_offset_source;
      jr["energy"] = energy;
    }
  }
  if (!in.verification.is_null()) j["verification"] = in.verification;
  j["provenance"] = data_schema::provenance_json(in.provenance);
  data_schema::write_file_atomic(dir / "analysis.json", j.dump(1) + "\n");
  data_schema::AtomicFile f(dir / "predictions.csv");
  f << kHeaders.predictions << "\n";
  for (const auto& r : in.recordings) {
    const std::string id = csv_quote(r.id);
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      const auto& m = r.measured_N[i];
      const auto& p = r.predicted_N[i];
      f << fmt::format("{},{},{},{},{},{},{},{},{}\n", id, r.t_s[i], m.x, m.y, m.z, p.x, p.y,
                       p.z, int(r.used[i]));
    }
  }
  f.commit();
  if (std::any_of(in.recordings.begin(), in.recordings.end(), [](const RecordingSeries& r) { return !r.band95_N.empty(); })) {
    data_schema::AtomicFile bf(dir / "band.csv");
    bf << kHeaders.band << "\n";
    for (const auto& r : in.recordings) {
      const std::string id = csv_quote(r.id);
      for (std::size_t i = 0; i < r.band95_N.size(); ++i)
        bf << fmt::format("{},{},{},{},{}\n", id, r.t_s[i], r.band95_N[i].x, r.band95_N[i].y, r.band95_N[i].z);
    }
    bf.commit();
  }
  const bool any_wrench = std::any_of(in.recordings.begin(), in.recordings.end(),
                                      [](const RecordingSeries& r) { return r.has_torque() || r.has_spindle(); });
  if (!any_wrench) return;
  data_schema::AtomicFile w(dir / "wrench.csv");
  w << kHeaders.wrench << "\n";
  auto opt = [](bool has, double v) { return has ? fmt::format("{}", v) : std::string(); };
  for (const auto& r : in.recordings) {
    if (!r.has_torque() && !r.has_spindle()) continue;
    const std::string id = csv_quote(r.id);
    const bool T = r.has_torque(), S = r.has_spindle();
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      const glm::dvec3 m = T ? r.torque_measured_Nmm[i] : glm::dvec3(0), p = T ? r.torque_predicted_Nmm[i] : glm::dvec3(0);
      w << fmt::format("{},{},{},{},{},{},{},{},{},{},{},{}\n", id, r.t_s[i], opt(T, m.x), opt(T, m.y), opt(T, m.z),
                       opt(T, p.x), opt(T, p.y), opt(T, p.z), opt(S, S ? r.spindle_measured_Nmm[i] : 0),
                       opt(S, S ? r.spindle_predicted_Nmm[i] : 0), opt(S, S ? r.spindle_offset_Nmm[i] : 0),
                       opt(S, S ? r.spin_rad_s[i] : 0));
    }
  }
  w.commit();
}

namespace {

// DIR/wrench.csv (1.2) into the recordings that analysis.json says carry moments or a
// spindle load; each such recording needs exactly its force rows, at the same times.
void read_wrench_csv(const fs::path& path, const char* header, std::vector<RecordingSeries>& recs,
                     const std::vector<std::pair<bool, bool>>& channels) {
  const std::string cfile = path.string();
  std::map<std::string, std::size_t> by_id;
  bool any = false;
  for (std::size_t r = 0; r < recs.size(); ++r)
    if (channels[r].first || channels[r].second) {
      by_id.emplace(recs[r].id, r);
      any = true;
    }
  if (!any) return;
  std::vector<std::size_t> rows(recs.size(), 0);
  for_each_csv_row(path, header, 12, "wrench CSV (analysis.json lists moments or a spindle load)",
                   [&](const std::vector<std::string>& fields, const std::string& where) {
    const auto it = by_id.find(fields[0]);
    if (it == by_id.end())
      throw InputError(cfile, where + " recording_id", "an id analysis.json lists with moments or a spindle load", fields[0]);
    auto& rs = recs[it->second];
    const auto [T, S] = channels[it->second];
    const std::size_t k = rows[it->second]++;
    if (k >= rs.t_s.size()) throw InputError(cfile, where, fmt::format("{} rows for recording {}", rs.t_s.size(), rs.id));
    if (csv_number(fields[1], cfile, where, 1) != rs.t_s[k])
      throw InputError(cfile, where + " t_s", "the time of the same row in predictions.csv", fields[1]);
    auto num = [&](std::size_t c, bool has) {
      if (!has) {
        if (!fields[c].empty()) throw InputError(cfile, where + " column " + std::to_string(c + 1), "empty (channel not logged)", fields[c]);
        return 0.0;
      }
      return csv_number(fields[c], cfile, where, c);
    };
    if (T) {
      rs.torque_measured_Nmm.emplace_back(num(2, T), num(3, T), num(4, T));
      rs.torque_predicted_Nmm.emplace_back(num(5, T), num(6, T), num(7, T));
    } else {
      for (std::size_t c = 2; c < 8; ++c) num(c, false);
    }
    if (S) {
      rs.spindle_measured_Nmm.push_back(num(8, S));
      rs.spindle_predicted_Nmm.push_back(num(9, S));
      rs.spindle_offset_Nmm.push_back(num(10, S));
      rs.spin_rad_s.push_back(num(11, S));
    } else {
      for (std::size_t c = 8; c < 12; ++c) num(c, false);
    }
  });
  for (const auto& [id, r] : by_id)
    if (rows[r] != recs[r].t_s.size())
      throw InputError(cfile, "recording " + id, fmt::format("{} rows", recs[r].t_s.size()), std::to_string(rows[r]));
}

// DIR/band.csv (1.2) into the recordings analysis.json marks with a band.
void read_band_csv(const fs::path& path, const char* header, std::vector<RecordingSeries>& recs,
                   const std::vector<bool>& has_band) {
  const std::string cfile = path.string();
  std::map<std::string, std::size_t> by_id;
  for (std::size_t r = 0; r < recs.size(); ++r)
    if (has_band[r]) by_id.emplace(recs[r].id, r);
  if (by_id.empty()) return;
  for_each_csv_row(path, header, 5, "band CSV (analysis.json marks recordings with a band)",
                   [&](const std::vector<std::string>& fields, const std::string& where) {
    const auto it = by_id.find(fields[0]);
    if (it == by_id.end()) throw InputError(cfile, where + " recording_id", "an id analysis.json marks with a band", fields[0]);
    auto& rs = recs[it->second];
    const std::size_t k = rs.band95_N.size();
    if (k >= rs.t_s.size()) throw InputError(cfile, where, fmt::format("{} rows for recording {}", rs.t_s.size(), rs.id));
    if (csv_number(fields[1], cfile, where, 1) != rs.t_s[k])
      throw InputError(cfile, where + " t_s", "the time of the same row in predictions.csv", fields[1]);
    glm::dvec3 b(csv_number(fields[2], cfile, where, 2), csv_number(fields[3], cfile, where, 3),
                 csv_number(fields[4], cfile, where, 4));
    if (b.x < 0 || b.y < 0 || b.z < 0) throw InputError(cfile, where, "half-widths ≥ 0");
    rs.band95_N.push_back(b);
  });
  for (const auto& [id, r] : by_id)
    if (recs[r].band95_N.size() != recs[r].t_s.size())
      throw InputError(cfile, "recording " + id, fmt::format("{} rows", recs[r].t_s.size()), std::to_string(recs[r].band95_N.size()));
}

}  // namespace

AnalysisInput read_analysis_input(const fs::path& dir) {
  const fs::path meta_path = dir / "analysis.json";
  const std::string file = meta_path.string();
  const json j = data_schema::read_json_file(meta_path);
  JsonView o(j, file, "",
        {"format", "format_version", "mode", "experiment", "context_of_use", "params",
         "criteria", "seed", "model", "calibration", "limitations", "parameters", "samples",
         "recordings", "provenance", "verification", "fit"});
  data_schema::check_format(file, "format", o.str("format"), kAnalysisFormat);
  data_schema::check_version(file, "format_version", o.str("format_version"), kAnalysisVersionMajor);
  // check_version has accepted "1.m": the minor picks the CSV headers.
  const std::string version = o.str("format_version");
  const CsvHeaders& headers = std::stoi(version.substr(version.find('.') + 1)) >= 3 ? kHeaders : kHeaders12;

  AnalysisInput in;
  in.mode = role_checked(o.str("mode"), file, "mode");
  {
    JsonView e(o.get("experiment"), file, "experiment", {"name", "description", "path", "sha256"});
    in.experiment_name = e.str("name");
    in.experiment_description = e.str("description");
    in.experiment_path = e.str("path");
    in.experiment_sha256 = e.str("sha256");
  }
  in.context_of_use = o.str("context_of_use");
  {
    JsonView p(o.get("params"), file, "params", {"path", "sha256"});
    in.params_path = p.str("path");
    in.params_sha256 = p.str("sha256");
    JsonView c(o.get("criteria"), file, "criteria", {"path", "sha256"});
    in.criteria_path = c.str("path");
    in.criteria_sha256 = c.str("sha256");
  }
  if (o.has("fit")) {  // 1.2
    JsonView fj(o.get("fit"), file, "fit", {"path", "sha256"});
    in.fit_path = fj.str("path");
    in.fit_sha256 = fj.str("sha256");
  }
  if (!o.get("seed").is_number_unsigned()) throw InputError(file, "seed", "an unsigned integer");
  in.seed = o.get("seed").get<std::uint64_t>();
  if (!o.get("model").is_object()) throw InputError(file, "model", "a JSON object");
  if (!o.get("calibration").is_object()) throw InputError(file, "calibration", "a JSON object");
  in.model = o.get("model");
  in.calibration = o.get("calibration");
  for (const auto& l : o.array("limitations")) {
    if (!l.is_string()) throw InputError(file, "limitations", "strings");
    in.limitations.push_back(l.get<std::string>());
  }
  std::size_t i = 0;
  for (const auto& pj : o.array("parameters")) {
    JsonView p(pj, file, fmt::format("parameters[{}]", i++),
          {"class_label", "class_name", "alpha_N_per_mm2", "c1_N_per_mm2", "mu"});
    in.parameters.push_back({int(p.finite("class_label")), p.str("class_name"),
                             p.finite("alpha_N_per_mm2"), p.finite("c1_N_per_mm2"), p.finite("mu")});
  }
  i = 0;
  for (const auto& sj : o.array("samples")) {
    JsonView s(sj, file, fmt::format("samples[{}]", i++),
          {"id", "path", "sha256", "voxel_mm", "nx", "ny", "removed_depth_mm",
           "removed_volume_mm3", "removed_class", "classes"});
    SampleInfo si{s.str("id"), s.str("path"), s.str("sha256"), s.finite("voxel_mm"), 0, 0, {}, 0, {}, {}};
    const double nx = s.finite("nx"), ny = s.finite("ny");
    if (nx < 0 || ny < 0 || nx * ny > double(kMaxMapCells) || nx != std::floor(nx) ||
        ny != std::floor(ny))
      throw InputError(file, s.field("nx"), fmt::format("integers with nx·ny ≤ {}", kMaxMapCells));
    si.nx = std::size_t(nx);
    si.ny = std::size_t(ny);
    const auto& depth = s.array("removed_depth_mm");
    if (depth.size() != si.nx * si.ny)
      throw InputError(file, s.field("removed_depth_mm"), fmt::format("nx·ny = {} values", si.nx * si.ny),
                       std::to_string(depth.size()));
    si.removed_depth_mm.reserve(depth.size());
    for (const auto& v : depth) {
      if (!v.is_number() || !std::isfinite(v.get<double>()))
        throw InputError(file, s.field("removed_depth_mm"), "finite numbers");
      si.removed_depth_mm.push_back(v.get<float>());
    }
    si.removed_volume_mm3 = s.finite("removed_volume_mm3");
    if (s.has("removed_class")) {  // 1.2
      const auto& rc = s.array("removed_class");
      if (rc.size() != si.nx * si.ny)
        throw InputError(file, s.field("removed_class"), fmt::format("nx·ny = {} labels", si.nx * si.ny),
                         std::to_string(rc.size()));
      for (const auto& v : rc) {
        if (!v.is_number_unsigned() || v.get<unsigned>() > 255) throw InputError(file, s.field("removed_class"), "labels 0..255");
        si.removed_class.push_back(std::uint8_t(v.get<unsigned>()));
      }
      const auto& cl = s.get("classes");
      if (!cl.is_object()) throw InputError(file, s.field("classes"), "an object: label → class name");
      for (const auto& [k, v] : cl.items()) {
        if (!v.is_string()) throw InputError(file, s.field("classes." + k), "a class name");
        try {
          si.classes[std::stoi(k)] = v.get<std::string>();
        } catch (const std::exception&) {
          throw InputError(file, s.field("classes"), "labels as keys", k);
        }
      }
    }
    in.samples.push_back(std::move(si));
  }
  std::map<std::string, std::size_t> by_id;
  std::vector<std::size_t> expected_rows;
  std::vector<std::pair<bool, bool>> channels;  // per recording: moments, spindle load (1.2)
  std::vector<bool> has_band;                   // per recording: band.csv rows (1.2)
  i = 0;
  for (const auto& rj : o.array("recordings")) {
    JsonView r(rj, file, fmt::format("recordings[{}]", i++),
          {"id", "sample", "role", "path", "sha256", "notes", "registration", "segments", "samples",
           "torque", "spindle", "spindle_offset_source", "energy", "quality", "band"});
    RecordingSeries rs;
    rs.id = r.str("id");
    rs.sample_id = r.str("sample");
    rs.role = role_checked(r.str("role"), file, r.field("role"));
    rs.path = r.str("path");
    rs.sha256 = r.str("sha256");
    rs.notes = r.str("notes");
    rs.registration = r.str_or("registration", "");
    std::size_t k = 0;
    for (const auto& sj : r.array("segments")) {
      JsonView s(sj, file, r.field(fmt::format("segments[{}]", k++)), {"label", "start_s", "end_s"});
      SegmentSpan span{s.str("label"), s.finite("start_s"), s.finite("end_s")};
      if (!(span.start_s < span.end_s))
        throw InputError(file, s.field("end_s"), "end_s > start_s");
      rs.segments.push_back(span);
    }
    const double rows = r.finite("samples");
    if (rows < 0 || rows > double(kMaxRows) || rows != std::floor(rows))
      throw InputError(file, r.field("samples"), fmt::format("an integer in [0, {}]", kMaxRows));
    if (!by_id.emplace(rs.id, in.recordings.size()).second)
      throw InputError(file, r.field("id"), "a unique recording id", rs.id);
    expected_rows.push_back(std::size_t(rows));
    auto flag = [&](const char* k) {
      if (!r.has(k)) return false;
      if (!r.get(k).is_boolean()) throw InputError(file, r.field(k), "true or false");
      return r.get(k).get<bool>();
    };
    channels.emplace_back(flag("torque"), flag("spindle"));
    has_band.push_back(flag("band"));
    if (channels.back().second) {
      rs.spindle_offset_source = r.str("spindle_offset_source");
      if (rs.spindle_offset_source != "fit" && rs.spindle_offset_source != "tare" && rs.spindle_offset_source != "none")
        throw InputError(file, r.field("spindle_offset_source"), "\"fit\", \"tare\" or \"none\"", rs.spindle_offset_source);
    }
    if (r.has("quality")) {  // 1.2
      JsonView q(r.get("quality"), file, r.field("quality"), {"dropped_force_samples", "buried_samples", "stale_rows", "events"});
      auto count = [&](JsonView& v, const std::string& k) {
        const double x = v.finite(k);
        if (x < 0 || x != std::floor(x) || x > 1e15) throw InputError(file, v.field(k), "a count (integer ≥ 0)");
        return std::size_t(x);
      };
      rs.quality.dropped_force_samples = count(q, "dropped_force_samples");
      rs.quality.buried_samples = count(q, "buried_samples");
      const auto& st = q.get("stale_rows");
      if (!st.is_object()) throw InputError(file, q.field("stale_rows"), "an object: stream → count");
      for (const auto& [name, v] : st.items()) {
        if (!v.is_number_unsigned()) throw InputError(file, q.field("stale_rows." + name), "a count (integer ≥ 0)");
        rs.quality.stale_rows[name] = v.get<std::size_t>();
      }
      std::size_t e = 0;
      for (const auto& ej : q.array("events")) {
        JsonView ev(ej, file, q.field(fmt::format("events[{}]", e++)), {"t_s", "kind", "stream", "detail"});
        rs.quality.events.push_back({ev.finite("t_s"), ev.str("kind"), ev.str("stream"), ev.str("detail")});
      }
    }
    if (r.has("energy")) {  // 1.2
      std::size_t e = 0;
      for (const auto& ej : r.array("energy")) {
        JsonView ev(ej, file, r.field(fmt::format("energy[{}]", e++)),
                    {"class_label", "class_name", "alpha_N_per_mm2", "removed_mm3", "friction_energy_mJ"});
        rs.energy.push_back({int(ev.finite("class_label")), ev.str("class_name"), ev.finite("alpha_N_per_mm2"),
                             ev.finite("removed_mm3"), ev.finite("friction_energy_mJ")});
      }
    }
    rs.t_s.reserve(std::size_t(rows));
    rs.measured_N.reserve(std::size_t(rows));
    rs.predicted_N.reserve(std::size_t(rows));
    rs.used.reserve(std::size_t(rows));
    in.recordings.push_back(std::move(rs));
  }
  if (o.has("verification")) {  // 1.1
    if (!o.get("verification").is_object()) throw InputError(file, "verification", "a JSON object (burrbench verify's study)");
    in.verification = o.get("verification");
  }
  in.provenance = data_schema::read_provenance(o.sub("provenance", {"software_version", "command_line", "created_utc", "inputs"}));

  const fs::path csv_path = dir / "predictions.csv";
  const std::string cfile = csv_path.string();
  for_each_csv_row(csv_path, headers.predictions, 9, "predictions CSV",
                   [&](const std::vector<std::string>& fields, const std::string& where) {
    const auto it = by_id.find(fields[0]);
    if (it == by_id.end())
      throw InputError(cfile, where + " recording_id", "an id listed in analysis.json", fields[0]);
    auto& rs = in.recordings[it->second];
    if (rs.t_s.size() >= expected_rows[it->second])
      throw InputError(cfile, where, fmt::format("at most {} rows for recording", expected_rows[it->second]));
    double v[8];
    for (std::size_t c = 0; c < 8; ++c) v[c] = csv_number(fields[c + 1], cfile, where, c + 1);
    if (fields[8] != "0" && fields[8] != "1") throw InputError(cfile, where + " used", "0 or 1", fields[8]);
    if (!rs.t_s.empty() && !(v[0] > rs.t_s.back()))
      throw InputError(cfile, where + " t_s", "strictly increasing times per recording");
    rs.t_s.push_back(v[0]);
    rs.measured_N.emplace_back(v[1], v[2], v[3]);
    rs.predicted_N.emplace_back(v[4], v[5], v[6]);
    rs.used.push_back(fields[8] == "1");
  });
  for (std::size_t r = 0; r < in.recordings.size(); ++r)
    if (in.recordings[r].t_s.size() != expected_rows[r])
      throw InputError(cfile, "recording " + in.recordings[r].id,
                       fmt::format("{} rows", expected_rows[r]),
                       std::to_string(in.recordings[r].t_s.size()));
  read_wrench_csv(dir / "wrench.csv", headers.wrench, in.recordings, channels);
  read_band_csv(dir / "band.csv", headers.band, in.recordings, has_band);
  return in;
}

void write_residuals_csv(const fs::path& path, const AnalysisInput& in) {
  data_schema::AtomicFile f(path);
  f << "recording_id,role,t_s,used,residual_N_x,residual_N_y,residual_N_z\n";
  for (const auto& r : in.recordings) {
    const std::string id = csv_quote(r.id);
    for (std::size_t i = 0; i < r.t_s.size(); ++i) {
      const glm::dvec3 e = r.measured_N[i] - r.predicted_N[i];
      f << fmt::format("{},{},{},{},{},{},{}\n", id, r.role, r.t_s[i], int(r.used[i]), e.x, e.y, e.z);
    }
  }
  f.commit();
}

}  // namespace burrbench::analysis
