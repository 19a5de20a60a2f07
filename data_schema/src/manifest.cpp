// Experiment manifest (TOML, format "burrbench.experiment"): parse, resolve, validate.
// Messages name the TOML key path, arrays indexed from 0 ("recordings[1].lag_ms").
#include "burrbench/data_schema/manifest.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "format_common.hpp"
#include "toml_util.hpp"

namespace burrbench::data_schema {

namespace {

constexpr int kMaxMultistart = 1000;
// A position→force lag beyond 10 s is no rig's: the bound keeps lag arithmetic finite.
constexpr double kMaxLagMs = 10000.0;
// A burr is millimetres across; 100 mm keeps the replay's geometry finite.
constexpr double kMaxBurrRadiusMm = 100.0;

// Sample and recording ids name files and folders of the outputs (staging files, study
// jobs): checked here, when the manifest is read, so `inspect` refuses what a run would
// fail on at its end (issue 59, N4): non-empty, no path separator, no control character
// (newline, NUL), not "." or "..".
void check_id(const std::string& file, const std::string& field, const std::string& id) {
  if (id.empty()) throw InputError(file, field, "a non-empty id");
  const bool bad_char = std::any_of(id.begin(), id.end(), [](char c) {
    const auto u = static_cast<unsigned char>(c);
    return c == '/' || c == '\\' || u < 0x20 || u == 0x7f;
  });
  if (bad_char || id == "." || id == "..") {
    std::string shown;
    for (const char c : id) {
      const auto u = static_cast<unsigned char>(c);
      shown += (u < 0x20 || u == 0x7f) ? fmt::format("\\x{:02x}", u) : std::string(1, c);
    }
    throw InputError(file, field, "an id without '/', '\\' or control characters (not . or ..): it names output files",
                     "\"" + shown + "\"");
  }
}

std::string vec_text(const glm::dvec3& v) { return fmt::format("[{}, {}, {}]", v.x, v.y, v.z); }

void check_rotation(const std::string& file, const std::string& field, const glm::dmat3& r) {
  const glm::dmat3 rtr = glm::transpose(r) * r;
  double err = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) err = std::max(err, std::abs(rtr[i][j] - (i == j ? 1.0 : 0.0)));
  const double det = glm::determinant(r);
  if (!(err < 1e-6) || !(std::abs(det - 1.0) < 1e-6))
    throw InputError(file, field, "a proper rotation (orthonormal, det +1)",
                     fmt::format("max |RᵀR − I| = {:.3g}, det = {:.6g}", err, det));
}

// True when the points span no plane: all within 1e-3 of the longest extent from a line.
bool collinear(const std::vector<glm::dvec3>& p) {
  std::size_t far = 0;
  double best = 0;
  for (std::size_t i = 1; i < p.size(); ++i)
    if (double d = glm::length(p[i] - p[0]); d > best) best = d, far = i;
  if (!(best > 1e-9)) return true;
  const glm::dvec3 dir = (p[far] - p[0]) / best;
  double off = 0;
  for (const auto& q : p) {
    const glm::dvec3 d = q - p[0];
    off = std::max(off, glm::length(d - glm::dot(d, dir) * dir));
  }
  return off < 1e-3 * best;
}

void check_file(const std::string& file, const std::string& field, const std::filesystem::path& p) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(p, ec))
    throw InputError(file, field, "an existing file", "\"" + p.string() + "\" not found");
}

void check_param(const std::string& file, const std::string& f, const ParamSpec& s, double min_lower,
                 bool allow_inf) {
  if (std::isnan(s.initial) || (std::isinf(s.initial) && !(allow_inf && s.fixed && s.initial > 0)))
    throw InputError(file, f + ".initial", allow_inf ? "a finite value (inf only when fixed)" : "a finite value",
                     fmt::format("{}", s.initial));
  if (s.fixed) {
    if (!(s.lower <= s.initial && s.initial <= s.upper))
      throw InputError(file, f, "lower <= initial <= upper",
                       fmt::format("{} <= {} <= {}", s.lower, s.initial, s.upper));
    return;
  }
  if (!std::isfinite(s.lower) || !std::isfinite(s.upper))
    throw InputError(file, f, "finite bounds for a fitted parameter", fmt::format("[{}, {}]", s.lower, s.upper));
  if (!(s.lower < s.initial && s.initial < s.upper))
    throw InputError(file, f, "lower < initial < upper",
                     fmt::format("lower {}, initial {}, upper {}", s.lower, s.initial, s.upper));
  if (!(s.lower >= min_lower) || (min_lower > 0 && s.lower == 0))
    throw InputError(file, f + ".lower", fmt::format("lower {} {}", min_lower > 0 ? ">" : ">=", 0),
                     fmt::format("{}", s.lower));
}

std::string display(const std::filesystem::path& p, const std::filesystem::path& base) {
  if (base.empty()) return p.string();
  const auto rel = p.lexically_relative(base);
  return rel.empty() ? p.string() : rel.generic_string();
}

}  // namespace

const char* to_string(SensorMeasures m) {
  return m == SensorMeasures::kForceOnSample ? "force_on_sample" : "force_on_burr";
}
const char* to_string(RecordingRole r) { return r == RecordingRole::kCalibrate ? "calibrate" : "validate"; }
const char* to_string(LossKind l) {
  return l == LossKind::kNone ? "none" : l == LossKind::kHuber ? "huber" : "cauchy";
}
const char* to_string(BuriedPolicy b) { return b == BuriedPolicy::kExclude ? "exclude" : "downweight"; }

const SampleRef* ExperimentManifest::sample(const std::string& id) const {
  for (const auto& s : samples)
    if (s.id == id) return &s;
  return nullptr;
}

const RecordingRef* ExperimentManifest::recording(const std::string& id) const {
  for (const auto& r : recordings)
    if (r.id == id) return &r;
  return nullptr;
}

void validate(const ExperimentManifest& m, const std::string& file) {
  if (m.samples.empty()) throw InputError(file, "samples", "at least one [[samples]] entry");
  std::set<std::string> ids;
  for (std::size_t i = 0; i < m.samples.size(); ++i) {
    const auto& s = m.samples[i];
    const std::string f = fmt::format("samples[{}]", i);
    check_id(file, f + ".id", s.id);
    if (!ids.insert(s.id).second) throw InputError(file, f + ".id", "unique sample ids", "\"" + s.id + "\" twice");
    check_file(file, f + ".path", s.path);
  }
  const auto& b = m.burr;
  // At most kMaxBurrRadiusMm: 1e308 passed and replayed to NaN (issue 59, N3).
  if (!std::isfinite(b.radius_mm) || !(b.radius_mm > 0) || b.radius_mm > kMaxBurrRadiusMm)
    throw InputError(file, "burr.radius_mm", fmt::format("a finite radius > 0 and ≤ {} mm", kMaxBurrRadiusMm),
                     fmt::format("{}", b.radius_mm));
  const double axis_len = glm::length(b.shaft_axis_rig);
  if (!std::isfinite(axis_len) || std::abs(axis_len - 1.0) > 1e-9)
    throw InputError(file, "burr.shaft_axis_rig", "a non-zero vector (normalised on read)", vec_text(b.shaft_axis_rig));
  if (b.spin_sign != 1 && b.spin_sign != -1)
    throw InputError(file, "burr.spin_sign", "+1 or -1", std::to_string(b.spin_sign));
  if (!std::isfinite(glm::length(b.tool_offset_mm)))
    throw InputError(file, "burr.tool_offset_mm", "finite values", vec_text(b.tool_offset_mm));
  check_rotation(file, "sensor.rotation_sensor_to_rig", m.sensor.rotation_sensor_to_rig);
  if (m.sensor.sigma_N && !(std::isfinite(*m.sensor.sigma_N) && *m.sensor.sigma_N > 0))
    throw InputError(file, "sensor.sigma_N", "a finite noise level > 0 N", fmt::format("{}", *m.sensor.sigma_N));
  if (!std::isfinite(glm::length(m.sensor.origin_rig_mm)))
    throw InputError(file, "sensor.origin_rig_mm", "finite values (mm, rig frame)", vec_text(m.sensor.origin_rig_mm));
  for (auto [v, field] : {std::pair{m.sensor.sigma_Nmm, "sensor.sigma_Nmm"}, {m.spindle.sigma_Nmm, "spindle.sigma_Nmm"}})
    if (v && !(std::isfinite(*v) && *v > 0))
      throw InputError(file, field, "a finite noise level > 0 N*mm", fmt::format("{}", *v));

  if (m.recordings.empty()) throw InputError(file, "recordings", "at least one [[recordings]] entry");
  const auto& nu = m.fit.nuisance;
  // The bounds first: a recording's lag is checked against them, so bounds the wrong way
  // round are the bounds' fault, not the lag's (issue 59, D14). Bounds as bounds: finite,
  // ordered and within ±kMaxLagMs (±1e308 ms passed and made Ceres fail on −inf: N5).
  for (const double b : nu.lag_bounds_ms)
    if (!(std::isfinite(b) && std::abs(b) <= kMaxLagMs))
      throw InputError(file, "fit.nuisance.lag_bounds_ms", fmt::format("[lower, upper] within ±{} ms", kMaxLagMs),
                       fmt::format("[{}, {}]", nu.lag_bounds_ms[0], nu.lag_bounds_ms[1]));
  if (!(nu.lag_bounds_ms[0] < nu.lag_bounds_ms[1]))
    throw InputError(file, "fit.nuisance.lag_bounds_ms", "[lower, upper] with lower < upper",
                     fmt::format("[{}, {}]", nu.lag_bounds_ms[0], nu.lag_bounds_ms[1]));
  std::set<std::string> rids;
  for (std::size_t i = 0; i < m.recordings.size(); ++i) {
    const auto& r = m.recordings[i];
    const std::string f = fmt::format("recordings[{}]", i);
    check_id(file, f + ".id", r.id);
    if (!rids.insert(r.id).second) throw InputError(file, f + ".id", "unique recording ids", "\"" + r.id + "\" twice");
    check_file(file, f + ".path", r.path);
    if (!m.sample(r.sample))
      throw InputError(file, f + ".sample", "the id of a [[samples]] entry", "\"" + r.sample + "\"");
    if (!std::isfinite(r.lag_ms)) throw InputError(file, f + ".lag_ms", "a finite lag", fmt::format("{}", r.lag_ms));
    if (nu.lag && !(nu.lag_bounds_ms[0] <= r.lag_ms && r.lag_ms <= nu.lag_bounds_ms[1]))
      throw InputError(file, f + ".lag_ms", fmt::format("a lag within fit.nuisance.lag_bounds_ms [{}, {}]",
                                                        nu.lag_bounds_ms[0], nu.lag_bounds_ms[1]),
                       fmt::format("{}", r.lag_ms));
    const auto& g = r.registration;
    const std::string gf = f + ".registration";
    if (g.from_fiducials() || !g.fiducials_vol_mm.empty()) {
      if (g.fiducials_rig_mm.size() != g.fiducials_vol_mm.size())
        throw InputError(file, gf + ".fiducials_vol_mm",
                         fmt::format("{} points (as many as fiducials_rig_mm)", g.fiducials_rig_mm.size()),
                         std::to_string(g.fiducials_vol_mm.size()));
      if (g.fiducials_rig_mm.size() < 3)
        throw InputError(file, gf + ".fiducials_rig_mm", "at least 3 point pairs",
                         std::to_string(g.fiducials_rig_mm.size()));
      if (collinear(g.fiducials_rig_mm))
        throw InputError(file, gf + ".fiducials_rig_mm", "at least 3 non-collinear points", "collinear");
      if (collinear(g.fiducials_vol_mm))
        throw InputError(file, gf + ".fiducials_vol_mm", "at least 3 non-collinear points", "collinear");
    } else {
      check_rotation(file, gf + ".rotation", g.rotation);
      if (!std::isfinite(glm::length(g.translation_mm)))
        throw InputError(file, gf + ".translation_mm", "finite values", vec_text(g.translation_mm));
    }
    for (std::size_t k = 0; k < r.segments.size(); ++k) {
      const auto& s = r.segments[k];
      const std::string sf = fmt::format("{}.segments[{}]", f, k);
      if (!std::isfinite(s.start_s) || s.start_s < 0)
        throw InputError(file, sf + ".start_s", "a finite time >= 0 s", fmt::format("{}", s.start_s));
      if (!std::isfinite(s.end_s) || !(s.start_s < s.end_s))
        throw InputError(file, sf, "start_s < end_s", fmt::format("start_s {}, end_s {}", s.start_s, s.end_s));
    }
  }

  const auto& fit = m.fit;
  if (!std::isfinite(fit.loss_scale) || !(fit.loss_scale > 0))
    throw InputError(file, "fit.loss_scale", "a finite scale > 0 (units of σ)", fmt::format("{}", fit.loss_scale));
  if (fit.multistart < 1 || fit.multistart > kMaxMultistart)
    throw InputError(file, "fit.multistart", fmt::format("1..{}", kMaxMultistart), std::to_string(fit.multistart));
  std::set<std::string> keys;
  for (const auto& c : fit.classes) {
    const std::string f = "fit.classes." + c.key;
    if (!keys.insert(c.key).second) throw InputError(file, f, "each class once", "duplicate");
    check_param(file, f + ".alpha", c.alpha, 0.0, true);
    if (!c.alpha.fixed && !(c.alpha.lower > 0))
      throw InputError(file, f + ".alpha.lower", "lower > 0 N/mm²", fmt::format("{}", c.alpha.lower));
    check_param(file, f + ".c1", c.c1, 0.0, false);
    if (!(c.c1.initial > 0)) throw InputError(file, f + ".c1.initial", "C1 > 0 N/mm²", fmt::format("{}", c.c1.initial));
    if (!c.c1.fixed && !(c.c1.lower > 0))
      throw InputError(file, f + ".c1.lower", "lower > 0 N/mm²", fmt::format("{}", c.c1.lower));
    check_param(file, f + ".mu", c.mu, 0.0, false);
    if (c.mu.initial < 0 || (!c.mu.fixed && c.mu.lower < 0))
      throw InputError(file, f + ".mu", "mu >= 0", fmt::format("initial {}, lower {}", c.mu.initial, c.mu.lower));
  }
}

namespace {

ParamSpec read_param(const TomlView& cls, const std::string& key, bool allow_inf) {
  auto t = cls.table(key);
  ParamSpec p;
  p.initial = allow_inf ? t.num_or_inf("initial") : t.num("initial");
  p.fixed = t.opt_boolean("fixed").value_or(false);
  if (p.fixed) {
    p.lower = t.opt_num("lower").value_or(p.initial);
    p.upper = t.has("upper") ? (allow_inf ? t.num_or_inf("upper") : t.num("upper")) : p.initial;
  } else {
    p.lower = t.num("lower");
    p.upper = t.num("upper");
  }
  t.done();
  return p;
}

template <class E>
E choice(const TomlView& v, const std::string& key, std::initializer_list<std::pair<const char*, E>> opts, E dflt) {
  const auto s = v.opt_str(key);
  if (!s) return dflt;
  std::string list;
  for (const auto& [name, e] : opts) {
    if (*s == name) return e;
    list += (list.empty() ? "" : " | ") + std::string(name);
  }
  throw InputError(v.file(), v.field(key), list, "\"" + *s + "\"");
}

std::filesystem::path resolve(const std::filesystem::path& base, const std::string& p) {
  return std::filesystem::absolute(base / std::filesystem::path(p)).lexically_normal();
}

std::uint8_t resolve_class(const ExperimentManifest& m, const std::string& key, const std::string& file) {
  const bool numeric = !key.empty() && key.find_first_not_of("0123456789") == std::string::npos && key.size() <= 3;
  int found = -1;
  for (const auto& s : m.samples) {
    const SampleHeader h = read_sample_header(s.path);
    int id = -1;
    for (const auto& [cid, name] : h.classes)
      if ((numeric && std::to_string(cid) == key) || (!numeric && name == key)) id = cid;
    if (id < 0)
      throw InputError(file, "fit.classes." + key,
                       fmt::format("a class name or id of sample \"{}\"'s class table", s.id), "unknown class");
    if (found >= 0 && id != found)
      throw InputError(file, "fit.classes." + key, "the same class id in every sample",
                       fmt::format("{} and {}", found, id));
    found = id;
  }
  return std::uint8_t(found);
}

}  // namespace

namespace {
ExperimentManifest parse_manifest_table(const toml::table& t, const std::filesystem::path& path);
}  // namespace

ExperimentManifest read_manifest(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  return parse_manifest_table(parse_toml_file(path), path);
}

ExperimentManifest parse_manifest(std::string_view toml_text, const std::filesystem::path& as_path) {
  return parse_manifest_table(parse_toml_text(toml_text, as_path.string()), as_path);
}

namespace {
BurrConfig read_burr(TomlView& root, const std::string& file) {
  BurrConfig b;
  auto burr = root.table("burr");
  b.radius_mm = burr.num("radius_mm");
  if (burr.has("shaft_axis_rig")) {
    const glm::dvec3 a = burr.vec3("shaft_axis_rig");
    const double len = glm::length(a);
    if (!(len > 1e-12)) throw InputError(file, "burr.shaft_axis_rig", "a non-zero vector", vec_text(a));
    b.shaft_axis_rig = a / len;
  }
  if (burr.has("spin_sign")) b.spin_sign = int(burr.integer("spin_sign"));
  if (burr.has("tool_offset_mm")) b.tool_offset_mm = burr.vec3("tool_offset_mm");
  burr.done();
  return b;
}

// [sensor] and the optional [spindle].
void read_sensor_and_spindle(TomlView& root, ExperimentManifest& m) {
  auto sensor = root.table("sensor");
  m.sensor.rotation_sensor_to_rig = sensor.mat3_rows("rotation_sensor_to_rig");
  m.sensor.measures = choice(sensor, "measures",
                             {{"force_on_sample", SensorMeasures::kForceOnSample},
                              {"force_on_burr", SensorMeasures::kForceOnBurr}},
                             SensorMeasures::kForceOnSample);
  m.sensor.sigma_N = sensor.opt_num("sigma_N");
  if (sensor.has("origin_rig_mm")) m.sensor.origin_rig_mm = sensor.vec3("origin_rig_mm");
  m.sensor.sigma_Nmm = sensor.opt_num("sigma_Nmm");
  sensor.done();
  if (auto sp = root.opt_table("spindle")) {
    m.spindle.sigma_Nmm = sp->opt_num("sigma_Nmm");
    sp->done();
  }
}

// A recording's [registration]: fiducials, or one transform in either direction.
Registration read_registration(TomlView& r, const std::string& file) {
  Registration reg;
  auto g = r.table("registration");
  const bool fid = g.has("fiducials_rig_mm") || g.has("fiducials_vol_mm");
  const int given = int(g.has("rotation") || g.has("translation_mm")) + int(g.has("vol_from_rig")) +
                    int(g.has("rig_from_vol"));
  if (fid && given)
    throw InputError(file, g.field("fiducials_rig_mm"), "either a transform or fiducials, not both");
  if (given > 1)
    throw InputError(file, g.field("vol_from_rig"),
                     "one transform: rotation/translation_mm, vol_from_rig or rig_from_vol");
  if (fid) {
    reg.fiducials_rig_mm = g.points("fiducials_rig_mm");
    reg.fiducials_vol_mm = g.points("fiducials_vol_mm");
    if (g.has("fiducial_error_mm")) reg.fiducial_error_mm = g.positive("fiducial_error_mm");
  } else if (g.has("vol_from_rig") || g.has("rig_from_vol")) {
    const bool inv = g.has("rig_from_vol");
    auto t = g.table(inv ? "rig_from_vol" : "vol_from_rig");
    const glm::dmat3 R = t.mat3_rows("rotation");
    const glm::dvec3 tr = t.vec3("translation_mm");
    t.done();
    reg.given_as = inv ? "rig_from_vol" : "vol_from_rig";
    // x_rig = R·x_vol + t  ⇔  x_vol = Rᵀ·x_rig − Rᵀ·t (R is checked to be a rotation later;
    // a non-rotation stays non-orthonormal under transposition, so the check still fires).
    reg.rotation = inv ? glm::transpose(R) : R;
    reg.translation_mm = inv ? -(glm::transpose(R) * tr) : tr;
  } else {
    reg.rotation = g.mat3_rows("rotation");
    reg.translation_mm = g.vec3("translation_mm");
  }
  g.done();
  return reg;
}

std::vector<Segment> read_segments(TomlView& r) {
  std::vector<Segment> segments;
  for (auto& s : r.tables("segments")) {
    Segment seg;
    seg.start_s = s.num("start_s");
    seg.end_s = s.num("end_s");
    seg.use = s.opt_boolean("use").value_or(true);
    seg.label = s.opt_str("label").value_or("");
    if (s.has("role"))
      seg.role = choice(s, "role", {{"calibrate", RecordingRole::kCalibrate}, {"validate", RecordingRole::kValidate}},
                        RecordingRole::kCalibrate);
    s.done();
    segments.push_back(seg);
  }
  return segments;
}

RecordingRef read_recording(TomlView& r, const std::filesystem::path& base, const std::string& file) {
  RecordingRef rr;
  rr.id = r.str("id");
  rr.path = resolve(base, r.str("path"));
  rr.sample = r.str("sample");
  rr.role = choice(r, "role", {{"calibrate", RecordingRole::kCalibrate}, {"validate", RecordingRole::kValidate}},
                   RecordingRole::kCalibrate);
  rr.lag_ms = r.opt_num("lag_ms").value_or(0.0);
  rr.spindle_rpm = r.opt_num("spindle_rpm");
  if (rr.spindle_rpm && !(std::abs(*rr.spindle_rpm) > 0 && std::abs(*rr.spindle_rpm) <= 1e6))
    throw InputError(file, r.field("spindle_rpm"), "a constant spindle speed, 0 < |rpm| ≤ 1e6 (sign = spin)",
                     fmt::format("{}", *rr.spindle_rpm));
  if (r.has("waive")) {
    rr.waive = r.strings("waive");
    for (const auto& w : rr.waive)
      if (w != "burr_radius_mm" && w != "burr_axis_rig" && w != "spin_sign")
        throw InputError(file, r.field("waive"),
                         "names of recording metadata the manifest overrides: \"burr_radius_mm\", "
                         "\"burr_axis_rig\", \"spin_sign\"",
                         "\"" + w.substr(0, 80) + "\"");
  }
  rr.registration = read_registration(r, file);
  rr.segments = read_segments(r);
  r.done();
  return rr;
}

// [fit]: the loss, the search, the channels, the precision asked for, the classes, the nuisances.
void read_fit(TomlView& fit, const toml::table& t, const std::string& file, FitSpec& f) {
  f.loss = choice(fit, "loss", {{"none", LossKind::kNone}, {"huber", LossKind::kHuber}, {"cauchy", LossKind::kCauchy}},
                  LossKind::kHuber);
  f.loss_scale = fit.opt_num("loss_scale").value_or(3.0);
  f.buried = choice(fit, "buried", {{"exclude", BuriedPolicy::kExclude}, {"downweight", BuriedPolicy::kDownweight}},
                    BuriedPolicy::kExclude);
  if (fit.has("seed")) {
    const auto seed = fit.integer("seed");
    if (seed < 0) throw InputError(file, "fit.seed", "an integer >= 0", std::to_string(seed));
    f.seed = std::uint64_t(seed);
  }
  if (fit.has("multistart")) {
    const auto ms = fit.integer("multistart");
    if (ms < 1 || ms > kMaxMultistart)
      throw InputError(file, "fit.multistart", fmt::format("1..{}", kMaxMultistart), std::to_string(ms));
    f.multistart = int(ms);
  }
  if (fit.has("channels")) {
    bool force = false;
    for (const auto& c : fit.strings("channels")) {
      if (c == "force") force = true;
      else if (c == "torque") f.fit_torque = true;
      else if (c == "spindle") f.fit_spindle = true;
      else throw InputError(file, "fit.channels", "\"force\", \"torque\" or \"spindle\"", "\"" + c + "\"");
    }
    if (!force) throw InputError(file, "fit.channels", "a list holding \"force\" (always fitted)", "none");
  }
  if (auto pr = fit.opt_table("precision")) {
    auto read = [&](const char* key) -> std::optional<double> {
      const auto v = pr->opt_num(key);
      if (v && !(*v > 0 && *v <= 10))
        throw InputError(file, std::string("fit.precision.") + key,
                         "a relative half-width of the 95 % interval, 0 < x <= 10 (0.05 = ±5 %)", fmt::format("{}", *v));
      return v;
    };
    f.precision_alpha = read("alpha");
    f.precision_c1 = read("c1");
    f.precision_mu = read("mu");
    pr->done();
  }
  if (auto classes = fit.opt_table("classes")) {
    for (const auto& key : classes->keys()) {
      auto c = classes->table(key);
      ClassFitSpec spec;
      spec.key = key;
      spec.alpha = read_param(c, "alpha", true);
      spec.c1 = read_param(c, "c1", false);
      spec.mu = read_param(c, "mu", false);
      c.done();
      f.classes.push_back(spec);
    }
    classes->done();
  }
  if (auto nu = fit.opt_table("nuisance")) {
    f.nuisance.bias = nu->opt_boolean("bias").value_or(true);
    f.nuisance.lag = nu->opt_boolean("lag").value_or(true);
    if (nu->has("lag_bounds_ms")) {
      const toml::node* n = t.at_path("fit.nuisance.lag_bounds_ms").node();
      const toml::array* a = n ? n->as_array() : nullptr;
      if (!a || a->size() != 2 || !a->get(0)->is_number() || !a->get(1)->is_number())
        throw InputError(file, "fit.nuisance.lag_bounds_ms", "[lower, upper] in ms");
      f.nuisance.lag_bounds_ms = {a->get(0)->value<double>().value(), a->get(1)->value<double>().value()};
      nu->use("lag_bounds_ms");
    }
    f.nuisance.depth_offset = nu->opt_boolean("depth_offset").value_or(false);
    f.nuisance.pose = nu->opt_boolean("pose").value_or(true);
    nu->done();
  }
  fit.done();
}

ExperimentManifest parse_manifest_table(const toml::table& t, const std::filesystem::path& path) {
  const std::string file = path.string();
  TomlView root(t, file, "");
  check_format(file, "format", root.str("format"), kManifestFormat);
  check_version(file, "format_version", root.str("format_version"), kManifestVersionMajor);
  ExperimentManifest m;
  m.file = std::filesystem::absolute(path).lexically_normal();
  const std::filesystem::path base = m.file.parent_path();
  m.name = root.str("name");
  m.description = root.opt_str("description").value_or("");

  for (auto& s : root.tables("samples")) {
    m.samples.push_back({s.str("id"), resolve(base, s.str("path"))});
    s.done();
  }
  m.burr = read_burr(root, file);
  read_sensor_and_spindle(root, m);
  for (auto& r : root.tables("recordings")) m.recordings.push_back(read_recording(r, base, file));
  if (auto fit = root.opt_table("fit")) read_fit(*fit, t, file, m.fit);
  root.done();

  validate(m, file);
  for (auto& c : m.fit.classes) c.label = resolve_class(m, c.key, file);
  return m;
}
}  // namespace

namespace {

toml::array rows(const glm::dmat3& r) {
  toml::array out;
  for (int i = 0; i < 3; ++i) out.push_back(toml::array{r[0][i], r[1][i], r[2][i]});
  return out;
}
toml::array arr(const glm::dvec3& v) { return toml::array{v.x, v.y, v.z}; }
toml::array pts(const std::vector<glm::dvec3>& p) {
  toml::array out;
  for (const auto& v : p) out.push_back(arr(v));
  return out;
}
toml::table param(const ParamSpec& p) {
  toml::table t{{"initial", p.initial}, {"fixed", p.fixed}};
  if (!p.fixed || p.lower != p.initial || p.upper != p.initial) {
    t.insert("lower", p.lower);
    t.insert("upper", p.upper);
  }
  return t;
}

}  // namespace

void write_manifest(const std::filesystem::path& path, const ExperimentManifest& m) {
  validate(m, path.string());
  const std::filesystem::path base = std::filesystem::absolute(path).lexically_normal().parent_path();
  toml::array samples;
  for (const auto& s : m.samples) samples.push_back(toml::table{{"id", s.id}, {"path", display(s.path, base)}});
  toml::array recordings;
  for (const auto& r : m.recordings) {
    toml::table reg;
    if (r.registration.from_fiducials()) {
      reg.insert("fiducials_rig_mm", pts(r.registration.fiducials_rig_mm));
      reg.insert("fiducials_vol_mm", pts(r.registration.fiducials_vol_mm));
      if (r.registration.fiducial_error_mm) reg.insert("fiducial_error_mm", *r.registration.fiducial_error_mm);
    } else {
      reg.insert("rotation", rows(r.registration.rotation));
      reg.insert("translation_mm", arr(r.registration.translation_mm));
    }
    toml::array segs;
    for (const auto& s : r.segments) {
      toml::table st{{"start_s", s.start_s}, {"end_s", s.end_s}, {"use", s.use}, {"label", s.label}};
      if (s.role) st.insert("role", to_string(*s.role));
      segs.push_back(st);
    }
    toml::table rt{{"id", r.id},          {"path", display(r.path, base)}, {"sample", r.sample},
                   {"role", to_string(r.role)}, {"lag_ms", r.lag_ms},       {"registration", reg}};
    if (!segs.empty()) rt.insert("segments", segs);
    if (r.spindle_rpm) rt.insert("spindle_rpm", *r.spindle_rpm);
    if (!r.waive.empty()) {
      toml::array w;
      for (const auto& s : r.waive) w.push_back(s);
      rt.insert("waive", w);
    }
    recordings.push_back(rt);
  }
  toml::table sensor{{"rotation_sensor_to_rig", rows(m.sensor.rotation_sensor_to_rig)},
                     {"measures", to_string(m.sensor.measures)}};
  if (m.sensor.sigma_N) sensor.insert("sigma_N", *m.sensor.sigma_N);
  if (m.sensor.sigma_Nmm) sensor.insert("sigma_Nmm", *m.sensor.sigma_Nmm);
  if (m.sensor.origin_rig_mm != glm::dvec3(0))
    sensor.insert("origin_rig_mm", toml::array{m.sensor.origin_rig_mm.x, m.sensor.origin_rig_mm.y, m.sensor.origin_rig_mm.z});
  toml::table classes;
  for (const auto& c : m.fit.classes)
    classes.insert(c.key, toml::table{{"alpha", param(c.alpha)}, {"c1", param(c.c1)}, {"mu", param(c.mu)}});
  const auto& nu = m.fit.nuisance;
  toml::table fit{{"loss", to_string(m.fit.loss)},
                  {"loss_scale", m.fit.loss_scale},
                  {"buried", to_string(m.fit.buried)},
                  {"seed", std::int64_t(m.fit.seed)},
                  {"multistart", m.fit.multistart},
                  {"classes", classes},
                  {"nuisance", toml::table{{"bias", nu.bias},
                                           {"lag", nu.lag},
                                           {"lag_bounds_ms", toml::array{nu.lag_bounds_ms[0], nu.lag_bounds_ms[1]}},
                                           {"depth_offset", nu.depth_offset},
                                           {"pose", nu.pose}}}};
  toml::table precision;
  if (m.fit.precision_alpha) precision.insert("alpha", *m.fit.precision_alpha);
  if (m.fit.precision_c1) precision.insert("c1", *m.fit.precision_c1);
  if (m.fit.precision_mu) precision.insert("mu", *m.fit.precision_mu);
  if (!precision.empty()) fit.insert("precision", precision);
  toml::array channels{"force"};
  if (m.fit.fit_torque) channels.push_back("torque");
  if (m.fit.fit_spindle) channels.push_back("spindle");
  fit.insert("channels", channels);
  const toml::table root{
      {"format", kManifestFormat},
      {"format_version", version_string(kManifestVersionMajor, kManifestVersionMinor)},
      {"name", m.name},
      {"description", m.description},
      {"samples", samples},
      {"burr", toml::table{{"radius_mm", m.burr.radius_mm},
                           {"shaft_axis_rig", arr(m.burr.shaft_axis_rig)},
                           {"spin_sign", m.burr.spin_sign},
                           {"tool_offset_mm", arr(m.burr.tool_offset_mm)}}},
      {"sensor", sensor},
      {"spindle", m.spindle.sigma_Nmm ? toml::table{{"sigma_Nmm", *m.spindle.sigma_Nmm}} : toml::table{}},
      {"recordings", recordings},
      {"fit", fit}};
  std::ostringstream text;
  text << "# burrbench experiment manifest (docs/formats.md). Paths are relative to this file.\n" << root << "\n";
  write_file_atomic(path, text.str());
}

}  // namespace burrbench::data_schema
