// Reading protocols: TOML → Protocol, every defect reported with its key path.
#include "burrbench/model/protocol.hpp"

#include <fmt/format.h>
#include <toml++/toml.h>

#include <fstream>
#include <sstream>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace burrbench::model {
namespace {

using data_schema::TomlView;

glm::dvec3 unit(const TomlView& v, std::string_view key) {
  const glm::dvec3 d = v.vec3(key);
  const double n = glm::length(d);
  if (!(n > 1e-12)) v.fail(key, "a non-zero direction vector");
  return d / n;
}

ProtocolMove read_move(const TomlView& t, const glm::dvec3& approach) {
  ProtocolMove m;
  const std::string type = t.str("type");
  m.label = t.str_or("label", "");
  if (t.has("spindle_rpm")) m.spindle_rpm = t.non_negative("spindle_rpm");
  auto lateral = [&] {
    const glm::dvec3 d = t.vec3("direction");
    const glm::dvec3 perp = d - glm::dot(d, approach) * approach;  // keeps the depth constant
    if (!(glm::length(perp) > 1e-9 * std::max(1.0, glm::length(d))))
      t.fail("direction", "a direction not parallel to start.approach");
    m.direction = perp / glm::length(perp);
    m.length_mm = t.positive("length_mm");
    m.speed_mm_s = t.positive("speed_mm_s");
    m.depth_mm = t.opt_num("depth_mm");
    if (t.has("feed_mm_s")) m.feed_mm_s = t.positive("feed_mm_s");
  };
  if (type == "plunge") {
    m.kind = MoveKind::kPlunge;
    t.allow({"type", "label", "spindle_rpm", "depth_mm", "feed_mm_s"});
    if (!t.has("depth_mm")) t.fail("depth_mm", "a number (mm; required for a plunge)", "missing");
    m.depth_mm = t.num("depth_mm");
    m.speed_mm_s = t.positive("feed_mm_s");
  } else if (type == "sweep") {
    m.kind = MoveKind::kSweep;
    t.allow({"type", "label", "spindle_rpm", "depth_mm", "feed_mm_s", "direction", "length_mm", "speed_mm_s"});
    lateral();
  } else if (type == "polish") {
    m.kind = MoveKind::kPolish;
    t.allow({"type", "label", "spindle_rpm", "depth_mm", "feed_mm_s", "direction", "length_mm", "speed_mm_s",
             "strokes"});
    lateral();
    m.strokes = int(t.integer("strokes", 1, 100000));
  } else if (type == "dwell") {
    m.kind = MoveKind::kDwell;
    t.allow({"type", "label", "spindle_rpm", "duration_s"});
    m.duration_s = t.positive("duration_s");
  } else if (type == "retract") {
    m.kind = MoveKind::kRetract;
    t.allow({"type", "label", "spindle_rpm", "speed_mm_s", "distance_mm"});
    m.speed_mm_s = t.positive("speed_mm_s");
    if (t.has("distance_mm")) m.distance_mm = t.positive("distance_mm");
  } else {
    t.fail("type", "one of plunge, sweep, polish, dwell, retract", "\"" + type + "\"");
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
  BURRBENCH_UNREACHABLE();
}

Protocol parse_protocol(std::string_view text, const std::string& file) {
  const toml::table root = data_schema::parse_toml_text(text, file);
  const TomlView r(root, file, "", "docs/replay.md");
  r.allow({"format", "format_version", "name", "description", "sample_rate_hz", "spindle_rpm", "burr", "start",
           "moves"});
  data_schema::check_format(file, "format", r.str("format"), kProtocolFormat);
  data_schema::check_version(file, "format_version", r.str("format_version"), kProtocolVersionMajor);
  Protocol p;
  p.file = file;
  p.name = r.str_or("name", "");
  p.description = r.str_or("description", "");
  p.sample_rate_hz = r.positive("sample_rate_hz");
  if (p.sample_rate_hz > 1e6) r.fail("sample_rate_hz", "at most 1e6 Hz", fmt::format("{}", p.sample_rate_hz));
  p.spindle_rpm = r.non_negative("spindle_rpm");

  const TomlView burr = r.table("burr");
  burr.allow({"radius_mm", "axis", "spin_sign"});
  p.burr_radius_mm = burr.positive("radius_mm");
  p.burr_axis_vol = unit(burr, "axis");
  if (!burr.has("spin_sign")) burr.fail("spin_sign", "1 or -1", "missing");
  const auto sign = burr.integer("spin_sign");
  if (sign != 1 && sign != -1) burr.fail("spin_sign", "1 or -1", std::to_string(sign));
  p.spin_sign = int(sign);

  const TomlView start = r.table("start");
  start.allow({"point_mm", "approach"});
  p.start_vol_mm = start.vec3("point_mm");
  p.approach_vol = unit(start, "approach");

  const auto moves = r.tables("moves");
  if (moves.empty()) r.fail("moves", "at least one [[moves]] table", "none");
  if (moves.size() > 100000) r.fail("moves", "at most 100000 moves", std::to_string(moves.size()));
  for (const auto& m : moves) p.moves.push_back(read_move(m, p.approach_vol));
  return p;
}

Protocol read_protocol(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
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
