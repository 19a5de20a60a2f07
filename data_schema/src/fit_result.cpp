// Fit result (JSON, format "burrbench.fit"): writer, reader, validator.
// Non-finite numbers: NaN ↔ null, ±inf ↔ "inf"/"-inf" (JSON has neither).
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/sample_volume.hpp"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/json_input.hpp"
#include "burrbench/data_schema/nesting.hpp"
#include "format_common.hpp"

namespace burrbench::data_schema {

using nlohmann::json;

namespace {


json matrix_json(const NamedMatrix& m) {
  json values = json::array();
  for (double x : m.matrix) values.push_back(json_number(x));
  return json{{"names", m.names}, {"matrix", values}};
}

NamedMatrix read_matrix(JsonView v) {
  NamedMatrix m;
  const json& names = v.array("names");
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (!names[i].is_string()) throw InputError(v.file(), v.field(fmt::format("names[{}]", i)), "a string");
    m.names.push_back(names[i].get<std::string>());
  }
  const json& values = v.array("matrix");
  for (std::size_t i = 0; i < values.size(); ++i) {
    const json& x = values[i];
    if (x.is_null()) m.matrix.push_back(kNaN);
    else if (x.is_number()) m.matrix.push_back(x.get<double>());
    else throw InputError(v.file(), v.field(fmt::format("matrix[{}]", i)), "a number or null", x.type_name());
  }
  v.done();
  return m;
}

const std::set<std::string> kParamNames{"alpha", "c1", "mu"};
const std::set<std::string> kNuisanceNames{"bias_x",  "bias_y",  "bias_z",  "lag",     "depth_offset",
                                            "pose_rx", "pose_ry", "pose_rz", "pose_tx", "pose_ty",
                                            "pose_tz", "torque_bias_x", "torque_bias_y", "torque_bias_z",
                                            "spindle_idle", "spindle_viscous", "spindle_lag"};

}  // namespace

const FitParameter* FitResult::parameter(std::uint8_t class_id, const std::string& name) const {
  for (const auto& p : parameters)
    if (p.class_id == class_id && p.name == name) return &p;
  return nullptr;
}

std::string unit_suffix(std::string_view unit) { return unit == "1" ? std::string() : " " + std::string(unit); }

namespace {

std::string describe_discretization(const FitParameter& p, const std::string& head, double coarse_voxel_mm) {
  if (!p.limited_by_discretization) return {};
  auto num = [](double x) { return std::isnan(x) ? std::string("—") : fmt::format("{:.6g}", x); };
  const std::string at = std::isfinite(coarse_voxel_mm) ? fmt::format("voxel {:.4g} mm", coarse_voxel_mm)
                                                        : std::string("twice the voxel");
  return std::isfinite(p.ci95_with_discretization_low)
             ? fmt::format("{}   LIMITED by discretization error: {} at {}; with that error [{}, {}]\n", head,
                           num(p.coarse_estimate), at, num(p.ci95_with_discretization_low),
                           num(p.ci95_with_discretization_high))
             : fmt::format("{}   LIMITED by discretization error: the refit at {} ran into its bound; verify on a "
                           "finer sample\n", head, at);
}

}  // namespace

std::string describe_fit_parameter(const FitParameter& p, double coarse_voxel_mm) {
  auto num = [](double x) { return std::isnan(x) ? std::string("—") : fmt::format("{:.6g}", x); };
  auto interval = [&](double lo, double hi) { return fmt::format("[{}, {}]", num(lo), num(hi)); };
  auto profile = [](double lo, double hi) {
    auto side = [](double v) { return std::isfinite(v) ? fmt::format("{:.6g}", v) : std::string("open"); };
    return fmt::format("profile 95 % [{}, {}]", side(lo), side(hi));
  };
  const std::string head = fmt::format("  {:<12} {:<5}", p.class_name, p.name), u = unit_suffix(p.unit);
  const bool profiled = !p.profile.empty();
  if (p.fixed) return fmt::format("{} = {}{} (fixed)\n", head, num(p.estimate), u);
  if (!p.identifiable) {
    const std::string v = p.verdict == "at_bound"                       ? "AT BOUND"
                          : p.verdict == "conditional_on_bound"         ? "CONDITIONAL on a bound"
                          : p.verdict == "unconfirmed"                  ? "UNCONFIRMED optimum"
                          : p.verdict == "practically_non_identifiable" ? "NOT identifiable (practically)"
                                                                        : "NOT identifiable";
    std::string s = fmt::format("{}   {} (held {}{}): {}\n", head, v, num(p.held), u, p.reason);
    if (profiled) s += fmt::format("{}   {}\n", head, profile(p.profile_ci95_low, p.profile_ci95_high));
    return s + describe_discretization(p, head, coarse_voxel_mm);
  }
  std::string s = fmt::format("{} = {}{}", head, num(p.estimate), u);
  if (profiled) s += " " + profile(p.profile_ci95_low, p.profile_ci95_high) + ";";
  s += fmt::format(" covariance {} (SE {})", interval(p.ci95_low, p.ci95_high), num(p.std_error));
  if (std::isfinite(p.bootstrap_ci95_low)) s += "; bootstrap " + interval(p.bootstrap_ci95_low, p.bootstrap_ci95_high);
  s += "\n";
  if (p.verdict == "imprecise") s += fmt::format("{}   IMPRECISE: {}\n", head, p.reason);
  return s + describe_discretization(p, head, coarse_voxel_mm);
}

void validate(const FitResult& f, const std::string& file) {
  std::set<std::pair<int, std::string>> seen;
  for (std::size_t i = 0; i < f.parameters.size(); ++i) {
    const auto& p = f.parameters[i];
    const std::string fld = fmt::format("parameters[{}]", i);
    if (!kParamNames.count(p.name)) throw InputError(file, fld + ".name", "alpha | c1 | mu", "\"" + p.name + "\"");
    if (p.class_id == 0) throw InputError(file, fld + ".class_id", "a class id 1..255", "0");
    if (!seen.insert({p.class_id, p.name}).second)
      throw InputError(file, fld, "each (class_id, name) once", "duplicate");
    if (p.identifiable && std::isnan(p.estimate))
      throw InputError(file, fld + ".estimate", "a number for an identifiable parameter", "null");
    if (!p.identifiable && p.reason.empty())
      throw InputError(file, fld + ".reason", "why the parameter is not identifiable", "empty");
    if (!std::isnan(p.ci95_low) && !std::isnan(p.ci95_high) && p.ci95_low > p.ci95_high)
      throw InputError(file, fld, "ci95_low <= ci95_high", fmt::format("{} > {}", p.ci95_low, p.ci95_high));
    if (!std::isnan(p.std_error) && p.std_error < 0)
      throw InputError(file, fld + ".std_error", "a standard error >= 0", fmt::format("{}", p.std_error));
  }
  for (std::size_t i = 0; i < f.nuisance.size(); ++i) {
    const auto& n = f.nuisance[i];
    if (!kNuisanceNames.count(n.name))
      throw InputError(file, fmt::format("nuisance[{}].name", i), "bias_x | bias_y | bias_z | lag | depth_offset | pose_rx..pose_tz | torque_bias_x..z | spindle_idle | spindle_viscous",
                       "\"" + n.name + "\"");
  }
  for (const auto* m : {&f.covariance, &f.correlation}) {
    const char* which = m == &f.covariance ? "covariance" : "correlation";
    if (m->matrix.size() != m->names.size() * m->names.size())
      throw InputError(file, std::string(which) + ".matrix",
                       fmt::format("{}×{} values (row-major)", m->names.size(), m->names.size()),
                       std::to_string(m->matrix.size()));
  }
  if (f.correlation.size() && f.correlation.names != f.covariance.names)
    throw InputError(file, "correlation.names", "the covariance's names");
  if (!f.metrics.is_object()) throw InputError(file, "metrics", "a JSON object");
  if (!f.settings.is_object()) throw InputError(file, "settings", "a JSON object");
  for (std::size_t i = 0; i < f.cross_validation.size(); ++i)
    if (!f.cross_validation[i].metrics.is_object())
      throw InputError(file, fmt::format("cross_validation[{}].metrics", i), "a JSON object");
}

nlohmann::json fit_to_json(const FitResult& f) {
  json params = json::array();
  for (const auto& p : f.parameters) {
    json j{{"class_id", p.class_id}, {"class_name", p.class_name}, {"name", p.name},
           {"unit", p.unit},         {"estimate", json_number(p.estimate)}, {"std_error", json_number(p.std_error)},
           {"ci95_low", json_number(p.ci95_low)}, {"ci95_high", json_number(p.ci95_high)}, {"fixed", p.fixed},
           {"identifiable", p.identifiable}, {"reason", p.reason}};
    if (!std::isnan(p.bootstrap_ci95_low)) j["bootstrap_ci95_low"] = json_number(p.bootstrap_ci95_low);
    if (!std::isnan(p.bootstrap_ci95_high)) j["bootstrap_ci95_high"] = json_number(p.bootstrap_ci95_high);
    j["held"] = json_number(p.held);
    j["verdict"] = p.verdict;
    j["profile_ci95_low"] = json_number(p.profile_ci95_low);
    j["profile_ci95_high"] = json_number(p.profile_ci95_high);
    j["profile"] = p.profile;
    if (std::isfinite(p.coarse_estimate))
      j["discretization"] = {{"coarse_estimate", p.coarse_estimate},
                             {"error_log", json_number(p.discretization_error_log)},
                             {"limited", p.limited_by_discretization},
                             {"ci95_low", json_number(p.ci95_with_discretization_low)},
                             {"ci95_high", json_number(p.ci95_with_discretization_high)}};
    params.push_back(j);
  }
  json nuisance = json::array();
  for (const auto& n : f.nuisance)
    nuisance.push_back({{"recording_id", n.recording_id}, {"name", n.name}, {"unit", n.unit},
                        {"estimate", json_number(n.estimate)}, {"std_error", json_number(n.std_error)},
                        {"ci95_low", json_number(n.ci95_low)}, {"ci95_high", json_number(n.ci95_high)}, {"fixed", n.fixed}});
  json cv = json::array();
  for (const auto& c : f.cross_validation) cv.push_back({{"held_out", c.held_out}, {"metrics", c.metrics}});
  const auto& r = f.residuals_summary;
  const auto& s = f.solver;
  const json root{
      {"format", kFitFormat},
      {"format_version", version_string(kFitVersionMajor, kFitVersionMinor)},
      {"parameters", params},
      {"nuisance", nuisance},
      {"covariance", matrix_json(f.covariance)},
      {"correlation", matrix_json(f.correlation)},
      {"residuals_summary", {{"samples_used", r.samples_used}, {"samples_buried", r.samples_buried},
                             {"samples_excluded", r.samples_excluded}, {"sigma_N", json_number(r.sigma_N)},
                             {"rms_normalised", json_number(r.rms_normalised)}}},
      {"solver", {{"iterations", s.iterations}, {"initial_cost", json_number(s.initial_cost)},
                  {"final_cost", json_number(s.final_cost)}, {"wall_s", json_number(s.wall_s)}, {"replays", s.replays},
                  {"termination", s.termination}, {"multistart", s.multistart}, {"stages", s.stages}}},
      {"cross_validation", cv},
      {"multistart", f.multistart},
      {"channel_information", f.channel_information},
      {"metrics", f.metrics},
      {"settings", f.settings},
      {"provenance", provenance_json(detail::stamped(f.provenance))},
      {"experiment", {{"path", f.experiment_path}, {"sha256", f.experiment_sha256}}}};
  return root;
}

void write_fit(const std::filesystem::path& path, const FitResult& f) {
  validate(f, path.string());
  // max_digits10 round trip: nlohmann prints doubles with 17 significant digits.
  write_file_atomic(path, fit_to_json(f).dump(2, ' ', false, json::error_handler_t::replace) + "\n");
}

FitResult read_fit(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  const std::string file = path.string();
  const json j = read_json_file(path);
  JsonView root(j, file, "");
  check_format(file, "format", root.str("format"), kFitFormat);
  check_version(file, "format_version", root.str("format_version"), kFitVersionMajor);
  FitResult f;
  const json& params = root.array("parameters");
  for (std::size_t i = 0; i < params.size(); ++i) {
    JsonView p(params[i], file, fmt::format("parameters[{}]", i));
    FitParameter fp;
    const auto id = p.count("class_id");
    if (id < 1 || id > kMaxClassId)
      throw InputError(file, p.field("class_id"), fmt::format("a class id 1..{}", kMaxClassId), std::to_string(id));
    fp.class_id = std::uint8_t(id);
    fp.class_name = p.str("class_name");
    fp.name = p.str("name");
    fp.unit = p.str("unit");
    fp.estimate = p.number("estimate");
    fp.std_error = p.number("std_error");
    fp.ci95_low = p.number("ci95_low");
    fp.ci95_high = p.number("ci95_high");
    fp.bootstrap_ci95_low = p.opt_number("bootstrap_ci95_low");
    fp.bootstrap_ci95_high = p.opt_number("bootstrap_ci95_high");
    fp.fixed = p.boolean("fixed");
    fp.identifiable = p.boolean("identifiable");
    fp.reason = p.str("reason");
    fp.held = p.opt_number("held");
    if (p.has("verdict")) fp.verdict = p.str("verdict");
    fp.profile_ci95_low = p.opt_number("profile_ci95_low");
    fp.profile_ci95_high = p.opt_number("profile_ci95_high");
    if (p.has("profile")) fp.profile = p.array("profile");
    if (p.has("discretization")) {
      JsonView d = p.sub("discretization");
      fp.coarse_estimate = d.number("coarse_estimate");
      fp.discretization_error_log = d.opt_number("error_log");
      fp.limited_by_discretization = d.boolean("limited");
      fp.ci95_with_discretization_low = d.opt_number("ci95_low");
      fp.ci95_with_discretization_high = d.opt_number("ci95_high");
      d.done();
    }
    p.done();
    f.parameters.push_back(fp);
  }
  const json& nuisance = root.array("nuisance");
  for (std::size_t i = 0; i < nuisance.size(); ++i) {
    JsonView n(nuisance[i], file, fmt::format("nuisance[{}]", i));
    FitNuisance fn;
    fn.recording_id = n.str("recording_id");
    fn.name = n.str("name");
    fn.unit = n.str("unit");
    fn.estimate = n.number("estimate");
    fn.std_error = n.number("std_error");
    fn.ci95_low = n.number("ci95_low");
    fn.ci95_high = n.number("ci95_high");
    fn.fixed = n.boolean("fixed");
    n.done();
    f.nuisance.push_back(fn);
  }
  f.covariance = read_matrix(root.sub("covariance"));
  f.correlation = read_matrix(root.sub("correlation"));
  {
    JsonView r = root.sub("residuals_summary");
    auto& rs = f.residuals_summary;
    rs.samples_used = r.count("samples_used");
    rs.samples_buried = r.count("samples_buried");
    rs.samples_excluded = r.count("samples_excluded");
    rs.sigma_N = r.number("sigma_N");
    rs.rms_normalised = r.number("rms_normalised");
    r.done();
  }
  {
    JsonView s = root.sub("solver");
    auto& ss2 = f.solver;
    ss2.iterations = s.count("iterations");
    ss2.initial_cost = s.number("initial_cost");
    ss2.final_cost = s.number("final_cost");
    ss2.wall_s = s.number("wall_s");
    ss2.replays = s.count("replays");
    ss2.termination = s.str("termination");
    ss2.multistart = s.count("multistart");
    if (s.has("stages")) ss2.stages = s.array("stages");
    s.done();
  }
  const json& cv = root.array("cross_validation");
  for (std::size_t i = 0; i < cv.size(); ++i) {
    JsonView c(cv[i], file, fmt::format("cross_validation[{}]", i));
    f.cross_validation.push_back({c.str("held_out"), c.object("metrics")});
    c.done();
  }
  if (root.has("multistart")) f.multistart = root.array("multistart");
  if (root.has("channel_information") && !root.get("channel_information").is_null())  // 1.3
    f.channel_information = root.object("channel_information");
  f.metrics = root.object("metrics");
  f.settings = root.object("settings");
  f.provenance = read_provenance(root.sub("provenance"));
  {
    JsonView e = root.sub("experiment");
    f.experiment_path = e.str("path");
    f.experiment_sha256 = e.str("sha256");
    e.done();
  }
  root.done();
  validate(f, file);
  return f;
}

ParameterSet parameter_set_from(const FitResult& f, const std::string& file) {
  ParameterSet p;
  for (const auto& fp : f.parameters) {
    auto& c = p.classes[fp.class_id];
    c.name = fp.class_name;
    const double v = std::isnan(fp.estimate) ? fp.held : fp.estimate;
    if (!fp.fixed && !fp.identifiable) p.not_identifiable[fp.class_id].push_back(fp.name);
    if (fp.name == "alpha") c.alpha_N_per_mm2 = v;
    if (fp.name == "c1") c.c1_N_per_mm2 = v;
    if (fp.name == "mu") c.mu = v;
  }
  for (const auto& [id, c] : p.classes) {
    if (!f.parameter(id, "c1") || !f.parameter(id, "mu"))
      throw InputError(file, fmt::format("parameters (class {})", int(id)), "estimates of c1 and mu");
  }
  p.provenance = make_provenance({});
  validate(p, file);
  return p;
}

}  // namespace burrbench::data_schema
