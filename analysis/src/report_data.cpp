// The report's view of its inputs: the prediction's series and its context (what the
// command that made it knew: files, segments, session log, constants, findings), per role.
#include "burrbench/analysis/report_data.hpp"

#include <algorithm>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "csv.hpp"

namespace burrbench::analysis {
using nlohmann::json;
using data_schema::JsonView;
namespace ds = data_schema;

namespace {

// The context's field path as messages name it.
std::string at(const std::string& path) { return "/context " + path; }

std::vector<std::string> strings(JsonView& v, const std::string& k) {
  std::vector<std::string> out;
  for (const auto& s : v.array_or_empty(k)) {
    if (!s.is_string()) throw InputError(v.file(), at(v.field(k)), "strings");
    out.push_back(s.get<std::string>());
  }
  return out;
}

DataQuality quality_of(JsonView q) {
  DataQuality out;
  out.dropped_force_samples = q.count("dropped_force_samples");
  for (const auto& [stream, n] : q.object("stale_rows").items()) {
    if (!n.is_number_unsigned()) throw InputError(q.file(), at(q.field("stale_rows." + stream)), "a row count");
    out.stale_rows[stream] = n.get<std::size_t>();
  }
  std::size_t i = 0;
  for (const auto& ej : q.array("events")) {
    JsonView e(ej, q.file(), q.field(fmt::format("events[{}]", i++)), {"t_s", "kind", "stream", "detail"});
    out.events.push_back({e.finite("t_s"), e.str("kind"), e.str("stream"), e.str("detail")});
  }
  return out;
}

struct Segment {
  SegmentSpan span;
  std::string role;
};

// One recording's series as the prediction holds them; `used` is the union of the roles'.
RecordingSeries series_of(const ds::PredictedRecording& p, JsonView meta, std::vector<Segment>& segments,
                          const std::vector<ParameterRow>& parameters) {
  RecordingSeries rs;
  rs.id = p.recording_id;
  rs.role = p.role;
  rs.sample_id = meta.str("sample");
  rs.path = meta.str("path");
  rs.sha256 = meta.str("sha256");
  rs.notes = meta.str("notes");
  rs.registration = meta.str("registration");
  rs.quality = quality_of(meta.sub("quality", {"dropped_force_samples", "stale_rows", "events"}));
  std::size_t i = 0;
  for (const auto& sj : meta.array("segments")) {
    JsonView s(sj, meta.file(), meta.field(fmt::format("segments[{}]", i++)), {"label", "start_s", "end_s", "role"});
    segments.push_back({{s.str("label"), s.finite("start_s"), s.finite("end_s")}, s.str("role")});
    rs.segments.push_back(segments.back().span);
  }
  const std::size_t n = p.samples();
  rs.t_s = p.t_s;
  rs.measured_N = p.force_sensor_meas_N;
  rs.predicted_N = p.force_sensor_pred_N;
  rs.band95_N = p.band95_N;
  rs.lag_ms = p.lag_ms;
  rs.depth_offset_mm = p.depth_offset_mm;
  rs.force_bias_N = p.force_bias_N;
  rs.force_bias_source = p.force_bias_source;
  rs.used.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    rs.used[k] = (k < p.used_calibrate.size() && p.used_calibrate[k]) || (k < p.used_validate.size() && p.used_validate[k]);
    rs.quality.buried_samples += p.buried[k] != 0;
  }
  if (p.torque_sensor_meas_Nmm.size() == n && n > 0) {
    rs.torque_measured_Nmm = p.torque_sensor_meas_Nmm;
    rs.torque_predicted_Nmm = p.torque_sensor_pred_Nmm;
  }
  if (!p.spindle_torque_meas_Nmm.empty()) {
    rs.spindle_measured_Nmm = p.spindle_torque_meas_Nmm;
    rs.spindle_predicted_Nmm = p.spindle_torque_pred_Nmm;
    rs.spindle_offset_Nmm = p.spindle_offset_Nmm.empty() ? std::vector<double>(n, 0.0) : p.spindle_offset_Nmm;
    rs.spindle_offset_source = p.spindle_offset_source;
    rs.spin_rad_s = p.spin_rad_s.empty() ? std::vector<double>(n, 0.0) : p.spin_rad_s;
  }
  for (const auto& c : parameters) {
    const auto label = std::size_t(c.class_label);
    if (label < ds::kPredictionClasses && (p.removed_mm3[label] > 0 || p.friction_energy_mJ[label] > 0))
      rs.energy.push_back({c.class_label, c.class_name, c.alpha_N_per_mm2, p.removed_mm3[label],
                           p.friction_energy_mJ[label]});
  }
  return rs;
}

// A recording whose segments carry both roles appears once per role, each with its own
// used samples and segments (its nuisances are the recording's, whichever the role).
void add_recording(ReportData& out, const ds::PredictedRecording& p, JsonView meta,
                   const std::vector<ParameterRow>& parameters) {
  std::vector<Segment> segments;
  RecordingSeries rs = series_of(p, meta, segments, parameters);
  const auto any = [](const std::vector<std::uint8_t>& v) { return std::any_of(v.begin(), v.end(), [](auto u) { return u != 0; }); };
  if (!(any(p.used_calibrate) && any(p.used_validate))) {
    out.recordings.push_back(std::move(rs));
    return;
  }
  RecordingSeries v = rs;
  rs.role = "calibrate";
  v.role = "validate";
  v.id = p.recording_id + "@validate";
  rs.used.assign(p.used_calibrate.begin(), p.used_calibrate.end());
  v.used.assign(p.used_validate.begin(), p.used_validate.end());
  rs.segments.clear();
  v.segments.clear();
  for (const auto& s : segments) (s.role == "calibrate" ? rs : v).segments.push_back(s.span);
  out.recordings.push_back(std::move(rs));
  out.recordings.push_back(std::move(v));
}

SampleInfo sample_of(const ds::RemovedBone& rb, JsonView meta) {
  SampleInfo si;
  si.id = rb.sample_id;
  si.path = meta.str("path");
  si.sha256 = meta.str("sha256");
  si.voxel_mm = rb.voxel_mm;
  si.nx = rb.nx;
  si.ny = rb.ny;
  si.removed_depth_mm = rb.removed_depth_mm;
  si.removed_class = rb.removed_class;
  si.removed_volume_mm3 = rb.removed_volume_mm3;
  for (const auto& [label, name] : meta.object("classes").items()) {
    if (!name.is_string()) throw InputError(meta.file(), at(meta.field("classes." + label)), "a class name");
    try {
      si.classes[std::stoi(label)] = name.get<std::string>();
    } catch (const std::exception&) {
      throw InputError(meta.file(), at(meta.field("classes")), "class labels as keys", label);
    }
  }
  return si;
}

}  // namespace

ReportData report_data(const ReportInputs& in) {
  const std::string& file = in.prediction_file;
  const json& ctx = in.prediction.context;
  if (!ctx.is_object())
    throw InputError(file, "/context", "the run's context (written by calibrate and validate, prediction format 2.4)",
                     "none");
  JsonView c(ctx, file, "",
             {"made_by", "experiment", "context_of_use", "seed", "params", "model", "calibration", "findings",
              "parameters", "samples", "recordings", "verification"});
  ReportData out;
  out.mode = c.str("made_by");
  if (out.mode != "calibrate" && out.mode != "validate")
    throw InputError(file, at("made_by"), "\"calibrate\" or \"validate\"", out.mode);
  {
    JsonView e = c.sub("experiment", {"name", "description", "path", "sha256"});
    out.experiment_name = e.str("name");
    out.experiment_description = e.str("description");
    out.experiment_path = e.str("path");
    out.experiment_sha256 = e.str("sha256");
    JsonView p = c.sub("params", {"path", "sha256"});
    out.params_path = p.str("path");
    out.params_sha256 = p.str("sha256");
  }
  out.context_of_use = c.str("context_of_use");
  out.seed = c.count("seed");
  out.model = c.object("model");
  out.calibration = c.object("calibration");
  out.limitations = strings(c, "findings");
  std::size_t i = 0;
  for (const auto& pj : c.array("parameters")) {
    JsonView p(pj, file, fmt::format("parameters[{}]", i++),
               {"class_label", "class_name", "alpha_N_per_mm2", "c1_N_per_mm2", "mu"});
    out.parameters.push_back({int(p.count("class_label")), p.str("class_name"), p.finite("alpha_N_per_mm2"),
                              p.finite("c1_N_per_mm2"), p.finite("mu")});
  }
  JsonView recs = c.sub("recordings"), samples = c.sub("samples");
  for (const auto& p : in.prediction.recordings) {
    if (!recs.has(p.recording_id)) throw InputError(file, at("recordings." + p.recording_id), "the recording's context");
    add_recording(out, p, recs.sub(p.recording_id, {"sample", "path", "sha256", "notes", "registration", "segments", "quality"}),
                  out.parameters);
  }
  for (const auto& rb : in.prediction.removed) {
    if (!samples.has(rb.sample_id)) throw InputError(file, at("samples." + rb.sample_id), "the sample's context");
    out.samples.push_back(sample_of(rb, samples.sub(rb.sample_id, {"path", "sha256", "classes"})));
  }
  out.provenance = in.prediction.provenance;
  out.verification = in.verification;
  out.criteria_path = in.criteria_path;
  out.criteria_sha256 = in.criteria_sha256;
  return out;
}

void write_residuals_csv(const std::filesystem::path& path, const ReportData& in) {
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
