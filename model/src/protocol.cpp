// Reading protocols: TOML → Protocol, every defect reported with its key path.
#include "burrbench/model/protocol.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <cmath>
#include <fstream>
#include <initializer_list>
#include <sstream>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/toml_input.hpp"

namespace burrbench::model {
namespace {

struct Reader {
  const std::string& file;

  std::string key(const std::string& prefix, std::string_view k) const {
    return prefix.empty() ? std::string(k) : prefix + "." + std::string(k);
  }

  void only(const toml::table& t, const std::string& prefix,
            std::initializer_list<std::string_view> allowed) const {
    for (const auto& [k, v] : t) {
      bool ok = false;
      for (auto a : allowed) ok = ok || k.str() == a;
      if (!ok) throw InputError(file, key(prefix, k.str()), "no such key (unknown key)");
    }
  }

  std::optional<double> number(const toml::table& t, const std::string& prefix,
                               std::string_view k) const {
    const toml::node* n = t.get(k);
    if (!n) return std::nullopt;
    if (!n->is_number()) throw InputError(file, key(prefix, k), "a number");
    const double v = n->value<double>().value();
    if (!std::isfinite(v)) throw InputError(file, key(prefix, k), "a finite number");
    return v;
  }

  double positive(const toml::table& t, const std::string& prefix, std::string_view k) const {
    const auto v = number(t, prefix, k);
    if (!v) throw InputError(file, key(prefix, k), "a number > 0 (required)");
    if (!(*v > 0)) throw InputError(file, key(prefix, k), "a number > 0", fmt::format("{}", *v));
    return *v;
  }

  std::optional<double> non_negative(const toml::table& t, const std::string& prefix,
                                     std::string_view k) const {
    const auto v = number(t, prefix, k);
    if (v && *v < 0) throw InputError(file, key(prefix, k), "a number ≥ 0", fmt::format("{}", *v));
    return v;
  }

  std::string text(const toml::table& t, const std::string& prefix, std::string_view k,
                   bool required) const {
    const toml::node* n = t.get(k);
    if (!n) {
      if (required) throw InputError(file, key(prefix, k), "a string (required)");
      return {};
    }
    if (!n->is_string()) throw InputError(file, key(prefix, k), "a string");
    return n->value<std::string>().value();
  }

  glm::dvec3 unit(const toml::table& t, const std::string& prefix, std::string_view k) const {
    const glm::dvec3 v = vec3(t, prefix, k);
    const double n = glm::length(v);
    if (!(n > 1e-12)) throw InputError(file, key(prefix, k), "a non-zero direction vector");
    return v / n;
  }

  glm::dvec3 vec3(const toml::table& t, const std::string& prefix, std::string_view k) const {
    const toml::array* a = t.get_as<toml::array>(k);
    if (!a || a->size() != 3)
      throw InputError(file, key(prefix, k), "an array of 3 numbers (required)");
    glm::dvec3 v;
    for (std::size_t i = 0; i < 3; ++i) {
      const toml::node* e = a->get(i);
      if (!e->is_number() || !std::isfinite(e->value<double>().value()))
        throw InputError(file, key(prefix, k), "an array of 3 finite numbers");
      v[int(i)] = e->value<double>().value();
    }
    return v;
  }

  const toml::table& table(const toml::table& t, std::string_view k) const {
    const toml::table* s = t.get_as<toml::table>(k);
    if (!s) throw InputError(file, std::string(k), "a table [" + std::string(k) + "] (required)");
    return *s;
  }
};

ProtocolMove read_move(const Reader& r, const toml::table& t, const std::string& at,
                       const glm::dvec3& approach) {
  ProtocolMove m;
  const std::string type = r.text(t, at, "type", true);
  m.label = r.text(t, at, "label", false);
  m.spindle_rpm = r.non_negative(t, at, "spindle_rpm");
  auto lateral = [&] {
    const glm::dvec3 d = r.vec3(t, at, "direction");
    const glm::dvec3 perp = d - glm::dot(d, approach) * approach;  // keeps the depth constant
    if (!(glm::length(perp) > 1e-9 * std::max(1.0, glm::length(d))))
      throw InputError(r.file, at + ".direction", "a direction not parallel to start.approach");
    m.direction = perp / glm::length(perp);
    m.length_mm = r.positive(t, at, "length_mm");
    m.speed_mm_s = r.positive(t, at, "speed_mm_s");
    m.depth_mm = r.number(t, at, "depth_mm");
    if (t.contains("feed_mm_s")) m.feed_mm_s = r.positive(t, at, "feed_mm_s");
  };
  if (type == "plunge") {
    m.kind = MoveKind::kPlunge;
    r.only(t, at, {"type", "label", "spindle_rpm", "depth_mm", "feed_mm_s"});
    m.depth_mm = r.number(t, at, "depth_mm");
    if (!m.depth_mm)
      throw InputError(r.file, at + ".depth_mm", "a number (mm; required for a plunge)");
    m.speed_mm_s = r.positive(t, at, "feed_mm_s");
  } else if (type == "sweep") {
    m.kind = MoveKind::kSweep;
    r.only(t, at,
           {"type", "label", "spindle_rpm", "depth_mm", "feed_mm_s", "direction", "length_mm",
            "speed_mm_s"});
    lateral();
  } else if (type == "polish") {
    m.kind = MoveKind::kPolish;
    r.only(t, at,
           {"type", "label", "spindle_rpm", "depth_mm", "feed_mm_s", "direction", "length_mm",
            "speed_mm_s", "strokes"});
    lateral();
    const toml::node* s = t.get("strokes");
    if (!s || !s->is_integer() || s->value<std::int64_t>().value() < 1 ||
        s->value<std::int64_t>().value() > 100000)
      throw InputError(r.file, at + ".strokes", "an integer in [1, 100000] (required)");
    m.strokes = int(s->value<std::int64_t>().value());
  } else if (type == "dwell") {
    m.kind = MoveKind::kDwell;
    r.only(t, at, {"type", "label", "spindle_rpm", "duration_s"});
    m.duration_s = r.positive(t, at, "duration_s");
  } else if (type == "retract") {
    m.kind = MoveKind::kRetract;
    r.only(t, at, {"type", "label", "spindle_rpm", "speed_mm_s", "distance_mm"});
    m.speed_mm_s = r.positive(t, at, "speed_mm_s");
    if (t.contains("distance_mm")) m.distance_mm = r.positive(t, at, "distance_mm");
  } else {
    throw InputError(r.file, at + ".type", "one of plunge, sweep, polish, dwell, retract",
                     "\"" + type + "\"");
  }
  return m;
}

}  // namespace

const char* to_string(MoveKind k) {
  switch (k) {
    case MoveKind::kPlunge:
      return "plunge";
    case MoveKind::kSweep:
      return "sweep";
    case MoveKind::kPolish:
      return "polish";
    case MoveKind::kDwell:
      return "dwell";
    case MoveKind::kRetract:
      return "retract";
  }
  return "?";
}

Protocol parse_protocol(std::string_view text, const std::string& file) {
  const toml::table root = data_schema::parse_toml_text(text, file);
  const Reader r{file};
  r.only(root, "",
         {"format", "format_version", "name", "description", "sample_rate_hz", "spindle_rpm",
          "burr", "start", "moves"});
  if (r.text(root, "", "format", true) != kProtocolFormat)
    throw InputError(file, "format", fmt::format("\"{}\"", kProtocolFormat),
                     "\"" + r.text(root, "", "format", true) + "\"");
  const std::string version = r.text(root, "", "format_version", true);
  if (version.rfind(fmt::format("{}.", kProtocolVersionMajor), 0) != 0)
    throw InputError(
        file, "format_version",
        fmt::format("major version {} (\"{}.x\")", kProtocolVersionMajor, kProtocolVersionMajor),
        "\"" + version + "\"");
  Protocol p;
  p.file = file;
  p.name = r.text(root, "", "name", false);
  p.description = r.text(root, "", "description", false);
  p.sample_rate_hz = r.positive(root, "", "sample_rate_hz");
  if (p.sample_rate_hz > 1e6) throw InputError(file, "sample_rate_hz", "at most 1e6 Hz");
  const auto rpm = r.non_negative(root, "", "spindle_rpm");
  if (!rpm) throw InputError(file, "spindle_rpm", "a number ≥ 0 (required)");
  p.spindle_rpm = *rpm;

  const toml::table& burr = r.table(root, "burr");
  r.only(burr, "burr", {"radius_mm", "axis", "spin_sign"});
  p.burr_radius_mm = r.positive(burr, "burr", "radius_mm");
  p.burr_axis_vol = r.unit(burr, "burr", "axis");
  const toml::node* sign = burr.get("spin_sign");
  if (!sign || !sign->is_integer() || std::abs(sign->value<std::int64_t>().value()) != 1)
    throw InputError(file, "burr.spin_sign", "1 or -1 (required)");
  p.spin_sign = int(sign->value<std::int64_t>().value());

  const toml::table& start = r.table(root, "start");
  r.only(start, "start", {"point_mm", "approach"});
  p.start_vol_mm = r.vec3(start, "start", "point_mm");
  p.approach_vol = r.unit(start, "start", "approach");

  const toml::array* moves = root.get_as<toml::array>("moves");
  if (!moves || moves->empty()) throw InputError(file, "moves", "at least one [[moves]] table");
  if (moves->size() > 100000) throw InputError(file, "moves", "at most 100000 moves");
  for (std::size_t i = 0; i < moves->size(); ++i) {
    const std::string at = fmt::format("moves[{}]", i);
    const toml::table* t = moves->get(i)->as_table();
    if (!t) throw InputError(file, at, "a table");
    p.moves.push_back(read_move(r, *t, at, p.approach_vol));
  }
  return p;
}

Protocol read_protocol(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "<file>", "a readable protocol file");
  std::ostringstream ss;
  ss << in.rdbuf();
  const std::string text = ss.str();
  if (text.size() > (16u << 20))
    throw InputError(path.string(), "<file>", "a protocol below 16 MiB");
  return parse_protocol(text, path.string());
}

}  // namespace burrbench::model
