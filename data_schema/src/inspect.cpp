// `burrbench inspect`: which format a file is, and a short human summary of it.
#include "burrbench/data_schema/inspect.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/nesting.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/prediction.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "hdf5/h5.hpp"
#include "toml_util.hpp"

namespace burrbench::data_schema {

namespace {

FileFormat from_name(const std::string& file, const std::string& field, const std::string& name) {
  for (FileFormat f : {FileFormat::kRecording, FileFormat::kSample, FileFormat::kParams, FileFormat::kManifest,
                       FileFormat::kFit, FileFormat::kPrediction})
    if (name == format_name(f)) return f;
  throw InputError(file, field,
                   "a burrbench format (burrbench.recording | sample | params | experiment | fit | prediction | "
                   "criteria | metrics | analysis)",
                   "\"" + name + "\"");
}

std::string prov_lines(const Provenance& p) {
  std::string s = fmt::format("provenance: {} · {} · {}\n", p.software_version, p.created_utc,
                              p.command_line.empty() ? "(no command line)" : p.command_line);
  for (const auto& f : p.inputs) s += fmt::format("  input {} sha256 {}\n", f.path, f.sha256);
  return s;
}

std::string num(double x) { return std::isnan(x) ? "—" : fmt::format("{:.6g}", x); }

std::string describe_recording(const std::filesystem::path& path) {
  const Recording r = read_recording(path);
  const auto& m = r.meta;
  std::string s = fmt::format("recording (burrbench.recording)\n");
  s += fmt::format("sample {} · rig {} · operator {}\n", m.sample_id, m.rig_id, m.operator_name);
  s += fmt::format("burr radius {}, axis_rig {}, spin {}\n",
                   m.burr_radius_mm > 0 ? fmt::format("{} mm", m.burr_radius_mm) : "not stated",
                   m.axis_stated() ? fmt::format("[{}, {}, {}]", m.burr_axis_rig.x, m.burr_axis_rig.y, m.burr_axis_rig.z)
                                   : "not stated",
                   m.spin_sign ? fmt::format("{:+d}", m.spin_sign) : "not stated");
  s += fmt::format("sensor {} serial {} calibration {} ({}), bias {}\n", m.sensor_model, m.sensor_serial,
                   m.sensor_calibration.empty() ? "none" : "6×6", m.sensor_calibration_date,
                   m.bias.empty() ? "none" : "6 values");
  for (const auto& st : r.streams) {
    const std::size_t n = st.samples();
    const double dur = n > 1 ? double(st.t_ns.back() - st.t_ns.front()) * 1e-9 : 0.0;
    const double rate = dur > 0 ? double(n - 1) / dur : 0.0;
    std::size_t stale = 0;
    for (auto v : st.stale) stale += v;
    s += fmt::format("stream {}: {} samples, {:.6g} s, {:.6g} Hz, {} stale, {} registers/sample\n", st.name, n,
                     dur, rate, stale, st.registers_per_sample);
    for (const auto& c : st.channels) s += fmt::format("  channel {} [{}] width {}\n", c.name, c.unit, c.width);
  }
  std::map<std::string, int> kinds;
  for (const auto& e : r.events) ++kinds[e.kind];
  s += fmt::format("events: {}", r.events.size());
  for (const auto& [k, c] : kinds) s += fmt::format(" · {} {}", k, c);
  s += "\n" + prov_lines(r.provenance);
  return s;
}

std::string describe_sample(const std::filesystem::path& path) {
  const SampleHeader h = read_sample_header(path);
  const SampleVolume v = read_sample(path);
  std::string s = "sample volume (burrbench.sample)\n";
  s += fmt::format("dims {}×{}×{} voxels, voxel {} mm, origin_mm [{}, {}, {}], extent {:.6g}×{:.6g}×{:.6g} mm\n",
                   v.dims[0], v.dims[1], v.dims[2], v.voxel_mm, v.origin_mm.x, v.origin_mm.y, v.origin_mm.z,
                   v.dims[0] * v.voxel_mm, v.dims[1] * v.voxel_mm, v.dims[2] * v.voxel_mm);
  s += fmt::format("fraction encoding {}\n", h.encoding == FractionEncoding::kFloat32 ? "float32" : "counter255");
  std::array<std::size_t, 256> count{};
  std::array<double, 256> chi{};
  for (std::size_t i = 0; i < v.labels.size(); ++i) {
    ++count[v.labels[i]];
    chi[v.labels[i]] += v.fraction[i];
  }
  s += fmt::format("  class 0 empty: {} voxels\n", count[0]);
  for (const auto& [id, name] : v.classes)
    s += fmt::format("  class {} {}: {} voxels, mean χ {:.4f}, bone volume {:.6g} mm³\n", int(id), name, count[id],
                     count[id] ? chi[id] / double(count[id]) : 0.0, chi[id] * std::pow(v.voxel_mm, 3));
  for (const auto& f : v.sources) s += fmt::format("source {} sha256 {}\n", f.path, f.sha256);
  s += "segmentation " + v.segmentation_json + "\n";
  return s + prov_lines(v.provenance);
}

std::string describe_params(const std::filesystem::path& path) {
  const ParameterSet p = read_params(path);
  std::string s = "parameter set (burrbench.params)\n";
  s += fmt::format("  {:>3} {:<12} {:>14} {:>14} {:>8}\n", "id", "class", "alpha N/mm²", "C1 N/mm²", "mu");
  for (const auto& [id, c] : p.classes)
    s += fmt::format("  {:>3} {:<12} {:>14.6g} {:>14.6g} {:>8.4g}\n", int(id), c.name, c.alpha_N_per_mm2,
                     c.c1_N_per_mm2, c.mu);
  if (!p.notes.empty()) s += "notes: " + p.notes + "\n";
  return s;
}

std::string describe_manifest(const std::filesystem::path& path) {
  const ExperimentManifest m = read_manifest(path);
  std::string s = fmt::format("experiment manifest (burrbench.experiment) \"{}\"\n", m.name);
  for (const auto& smp : m.samples) s += fmt::format("sample {}: {}\n", smp.id, smp.path.string());
  s += fmt::format("burr radius {} mm, spin {:+d}; sensor measures {}\n", m.burr.radius_mm, m.burr.spin_sign,
                   to_string(m.sensor.measures));
  for (const auto& r : m.recordings)
    s += fmt::format("recording {} ({}) on {}: {}, lag {} ms, {} segments, registration by {}\n", r.id,
                     to_string(r.role), r.sample, r.path.string(), r.lag_ms, r.segments.size(),
                     r.registration.from_fiducials() ? "fiducials" : "transform");
  s += fmt::format("fit: loss {} (scale {}σ), buried {}, seed {}, multistart {}\n", to_string(m.fit.loss),
                   m.fit.loss_scale, to_string(m.fit.buried), m.fit.seed, m.fit.multistart);
  for (const auto& c : m.fit.classes) {
    auto ps = [](const char* n, const ParamSpec& p) {
      return p.fixed ? fmt::format("{} fixed {}", n, p.initial)
                     : fmt::format("{} {} in [{}, {}]", n, p.initial, p.lower, p.upper);
    };
    s += fmt::format("  class {} (id {}): {}; {}; {}\n", c.key, int(c.label), ps("alpha", c.alpha), ps("c1", c.c1),
                     ps("mu", c.mu));
  }
  return s;
}

std::string describe_fit(const std::filesystem::path& path) {
  const FitResult f = read_fit(path);
  std::string s = "fit result (burrbench.fit)\n";
  for (const auto& p : f.parameters) s += describe_fit_parameter(p);
  for (const auto& n : f.nuisance)
    s += n.fixed ? fmt::format("  {:<12} {:<12} = {}{} (fixed)\n", n.recording_id, n.name, num(n.estimate),
                               unit_suffix(n.unit))
                 : fmt::format("  {:<12} {:<12} = {} ± {}{} (SE)\n", n.recording_id, n.name, num(n.estimate),
                               num(n.std_error), unit_suffix(n.unit));
  const auto& r = f.residuals_summary;
  s += fmt::format("residuals: {} used, {} buried, {} excluded, σ {} N, rms/σ {}\n", r.samples_used,
                   r.samples_buried, r.samples_excluded, num(r.sigma_N), num(r.rms_normalised));
  s += fmt::format("solver: {} iterations, cost {} → {}, {} replays, {} s, {}\n", f.solver.iterations,
                   num(f.solver.initial_cost), num(f.solver.final_cost), f.solver.replays, num(f.solver.wall_s),
                   f.solver.termination);
  // The calibration's own tally (a file from before the global search has none).
  const auto gs = f.settings.value("global_search", nlohmann::json::object());
  if (gs.contains("reached_best") && gs.contains("starts"))
    s += fmt::format("global search: best optimum reached by {} of {} starts\n", gs["reached_best"].dump(),
                     gs["starts"].dump());
  for (const auto& cv : f.cross_validation) {
    const auto h = cv.metrics.value("held_out", nlohmann::json::object());
    auto fig = [&](const char* key) { return h.contains(key) && h[key].is_number() ? num(h[key].get<double>()) : num(kNaN); };
    s += fmt::format("cross-validation without {}: held-out RMSE {} N, R² {} (x, y, z together)\n", cv.held_out,
                     fig("rmse_xyz_N"), fig("r2_xyz"));
  }
  s += fmt::format("experiment {} sha256 {}\n", f.experiment_path, f.experiment_sha256);
  return s + prov_lines(f.provenance);
}

std::string describe_prediction(const std::filesystem::path& path) {
  const Prediction p = read_prediction(path);
  std::string s = fmt::format("prediction (burrbench.prediction), {} recordings\n", p.recordings.size());
  for (const auto& r : p.recordings) {
    const std::size_t n = r.samples();
    std::size_t used = 0, buried = 0;
    double max_pred = 0, sq = 0;
    for (std::size_t k = 0; k < n; ++k) {
      used += r.use[k];
      buried += r.buried[k];
      max_pred = std::max(max_pred, glm::length(r.force_sensor_pred_N[k]));
      const glm::dvec3 d = r.force_sensor_meas_N[k] - r.force_sensor_pred_N[k];
      sq += glm::dot(d, d);
    }
    s += fmt::format("recording {}: {} samples, {} s, {} used, {} buried, {} replay steps\n", r.recording_id, n,
                     n ? num(r.t_s.back() - r.t_s.front()) : "0", used, buried, r.steps);
    s += fmt::format("  max |F_sensor_pred| {} N, rms |F_meas − F_pred| {} N (bias not removed)\n", num(max_pred),
                     n ? num(std::sqrt(sq / double(n))) : "—");
    std::string removed;
    for (std::size_t c = 0; c < r.removed_mm3.size(); ++c)
      if (r.removed_mm3[c] > 0) removed += fmt::format(" class {} {}", c, num(r.removed_mm3[c]));
    s += "  removed mm³:" + (removed.empty() ? std::string(" none") : removed) + "\n";
  }
  return s + prov_lines(p.provenance);
}

}  // namespace

const char* format_name(FileFormat f) {
  switch (f) {
    case FileFormat::kRecording: return kRecordingFormat;
    case FileFormat::kSample: return kSampleFormat;
    case FileFormat::kParams: return kParamsFormat;
    case FileFormat::kManifest: return kManifestFormat;
    case FileFormat::kFit: return kFitFormat;
    case FileFormat::kPrediction: return kPredictionFormat;
  }
  BURRBENCH_UNREACHABLE();
}

FileFormat detect_format(const std::filesystem::path& path) {
  const std::string file = path.string();
  return from_name(file, "format", declared_format(path));
}

std::string declared_format(const std::filesystem::path& path) {
  const std::string file = path.string();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(file, "<file>", "an existing regular file");
  if (h5::is_hdf5(path)) {
    const h5::Reader r(path);
    return r.attr_string("/", "format");
  }
  std::ifstream in(path, std::ios::binary);
  char c = 0;
  while (in.get(c) && std::isspace(static_cast<unsigned char>(c))) {
  }
  if (c == '{') {
    // Bounded before it is read, as every JSON input is (read_json_file; issue 59, D11).
    const auto size = std::filesystem::file_size(path, ec);
    if (ec || size > kMaxJsonBytes)
      throw InputError(file, "<file>", fmt::format("a JSON file of at most {} MiB", kMaxJsonBytes >> 20),
                       fmt::format("{} bytes", size));
    std::ifstream all(path, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(all)), std::istreambuf_iterator<char>());
    check_json_nesting(text, file);  // before nlohmann::json recurses
    nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
    if (j.is_discarded() || !j.is_object())
      throw InputError(file, "<file>", "an HDF5, TOML or JSON burrbench file", "unparsable JSON");
    if (!j.contains("format") || !j["format"].is_string())
      throw InputError(file, "format", "a format name string", "missing");
    return j["format"].get<std::string>();
  }
  toml::table t;
  try {
    t = parse_toml_file(path);
  } catch (const InputError& e) {
    throw InputError(file, "<file>", "an HDF5, TOML or JSON burrbench file", e.what());
  }
  const auto fmt_name = t["format"].value<std::string>();
  if (!fmt_name) throw InputError(file, "format", "a format name string", "missing");
  return *fmt_name;
}

std::string describe_file(const std::filesystem::path& path) {
  switch (detect_format(path)) {
    case FileFormat::kRecording: return describe_recording(path);
    case FileFormat::kSample: return describe_sample(path);
    case FileFormat::kParams: return describe_params(path);
    case FileFormat::kManifest: return describe_manifest(path);
    case FileFormat::kFit: return describe_fit(path);
    case FileFormat::kPrediction: return describe_prediction(path);
  }
  return {};
}

}  // namespace burrbench::data_schema
