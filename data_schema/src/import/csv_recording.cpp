// CSV → Recording. One stream "csv" holds every channel at the CSV's own time base.
#include "burrbench/data_schema/import/csv_recording.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numbers>

#include <fmt/format.h>
#include <toml++/toml.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "import/volume_decode.hpp"
#include "toml_util.hpp"

namespace burrbench::data_schema::import {
namespace {

// A recording's CSV has a few columns; a header of a million commas is not one, and the
// cells of such a line would cost ~40 bytes each (issue 12: memory bounded by the file).
constexpr std::size_t kMaxColumns = 1000;

// A cell or name quoted in a message: at most 80 characters of it.
std::string echo(std::string_view s) {
  return s.size() <= 80 ? std::string(s) : std::string(s.substr(0, 77)) + "...";
}

using detail::to_double;
using detail::trim;

enum class Quantity { kTime, kLength, kForce, kTorque, kSpeed, kPower };

struct CanonicalColumn {
  const char* name;
  Quantity q;
};
// Order = index used below: 0 t, 1-3 position, 4-6 force, 7-9 torque, 10 spindle speed,
// 11 spindle load torque, 12 spindle power (the drive's load: one of 11, 12).
constexpr std::array<CanonicalColumn, 13> kColumns{{{"t_s", Quantity::kTime},
                                                    {"x_mm", Quantity::kLength},
                                                    {"y_mm", Quantity::kLength},
                                                    {"z_mm", Quantity::kLength},
                                                    {"fx_N", Quantity::kForce},
                                                    {"fy_N", Quantity::kForce},
                                                    {"fz_N", Quantity::kForce},
                                                    {"tx_Nmm", Quantity::kTorque},
                                                    {"ty_Nmm", Quantity::kTorque},
                                                    {"tz_Nmm", Quantity::kTorque},
                                                    {"spindle_rpm", Quantity::kSpeed},
                                                    {"spindle_torque_Nmm", Quantity::kTorque},
                                                    {"spindle_power_W", Quantity::kPower}}};
constexpr const char* kColumnList =
    "t_s, x_mm, y_mm, z_mm, fx_N, fy_N, fz_N, tx_Nmm, ty_Nmm, tz_Nmm, spindle_rpm, spindle_torque_Nmm, spindle_power_W";

std::optional<double> unit_factor(Quantity q, const std::string& u) {
  static const std::map<std::string, double> time{{"s", 1}, {"ms", 1e-3}, {"us", 1e-6}, {"ns", 1e-9}, {"min", 60}};
  static const std::map<std::string, double> length{{"mm", 1}, {"um", 1e-3}, {"cm", 10}, {"m", 1e3}, {"in", 25.4}};
  static const std::map<std::string, double> force{{"N", 1}, {"mN", 1e-3}, {"kN", 1e3}, {"lbf", 4.4482216152605}};
  static const std::map<std::string, double> torque{{"N*mm", 1}, {"Nmm", 1}, {"mN*m", 1}, {"N*m", 1e3}, {"Nm", 1e3}};
  static const std::map<std::string, double> speed{{"rpm", 1}, {"Hz", 60}, {"rad/s", 60 / (2 * std::numbers::pi)}};
  static const std::map<std::string, double> power{{"W", 1}, {"mW", 1e-3}, {"kW", 1e3}};
  const auto& m = q == Quantity::kTime ? time : q == Quantity::kLength ? length : q == Quantity::kForce ? force
                : q == Quantity::kTorque ? torque : q == Quantity::kPower ? power : speed;
  auto it = m.find(u);
  if (it == m.end()) return std::nullopt;
  return it->second;
}

std::string unit_list(Quantity q) {
  switch (q) {
    case Quantity::kTime: return "s, ms, us, ns or min";
    case Quantity::kLength: return "mm, um, cm, m or in";
    case Quantity::kForce: return "N, mN, kN or lbf";
    case Quantity::kTorque: return "N*mm, Nmm, mN*m, N*m or Nm";
    case Quantity::kSpeed: return "rpm, Hz or rad/s";
    case Quantity::kPower: return "W, mW or kW";
  }
  BURRBENCH_UNREACHABLE();
}

int canonical_index(const std::string& name) {
  for (std::size_t i = 0; i < kColumns.size(); ++i) if (name == kColumns[i].name) return static_cast<int>(i);
  return -1;
}

// How one CSV column becomes a canonical value: factor·(scale·raw + offset).
struct ColumnMap {
  std::string csv_name;
  int canonical = -1;
  double scale = 1, offset = 0, factor = 1;
};

struct CsvLayout {
  std::optional<char> delimiter;
  char decimal = '.';
  long header_line = 1;
  std::map<std::string, ColumnMap> by_csv_name;  // empty: header must be canonical
};

CsvLayout parse_map(std::string_view text, const std::string& file) {
  const toml::table t = parse_toml_text(text, file);
  TomlView v(t, file, "");
  check_format(file, "format", echo(v.str("format")), kCsvMapFormat);
  check_version(file, "format_version", echo(v.str("format_version")), 1);
  CsvLayout L;
  if (auto d = v.opt_str("delimiter")) {
    if (*d != "," && *d != ";" && *d != "\t" && *d != " ") throw InputError(file, "delimiter", "\",\", \";\", \"\\t\" or \" \"", "\"" + echo(*d) + "\"");
    L.delimiter = (*d)[0];
  }
  if (auto d = v.opt_str("decimal")) {
    if (*d != "." && *d != ",") throw InputError(file, "decimal", "\".\" or \",\"", "\"" + echo(*d) + "\"");
    L.decimal = (*d)[0];
  }
  if (v.has("header_line")) {
    const auto h = v.integer("header_line");
    if (h < 1 || h > 1000) throw InputError(file, "header_line", "a line number 1..1000", std::to_string(h));
    L.header_line = static_cast<long>(h);
  }
  auto cols = v.table("columns");
  for (const auto& key : cols.keys()) {
    auto c = cols.table(key);
    ColumnMap m;
    m.csv_name = key;
    const std::string ch = c.str("channel");
    m.canonical = canonical_index(ch);
    if (m.canonical < 0) {
      throw InputError(file, c.field("channel"), std::string("one of ") + kColumnList, "\"" + echo(ch) + "\"");
    }
    const Quantity q = kColumns[static_cast<std::size_t>(m.canonical)].q;
    if (auto u = c.opt_str("unit")) {
      auto f = unit_factor(q, *u);
      if (!f) throw InputError(file, c.field("unit"), unit_list(q), "\"" + echo(*u) + "\"");
      m.factor = *f;
    }
    if (auto s = c.opt_num("scale")) {
      if (*s == 0) throw InputError(file, c.field("scale"), "a non-zero factor", "0");
      m.scale = *s;
    }
    if (auto o = c.opt_num("offset")) m.offset = *o;
    c.done();
    for (const auto& [k, other] : L.by_csv_name) {
      if (other.canonical == m.canonical) throw InputError(file, c.field("channel"), "each channel mapped once", "\"" + echo(ch) + "\" again");
    }
    L.by_csv_name[key] = m;
  }
  cols.done();
  v.done();
  if (L.delimiter && *L.delimiter == ',' && L.decimal == ',') throw InputError(file, "decimal", "\".\" when the delimiter is \",\"");
  return L;
}

// The cells of one line, counted without allocating (delimiters outside quotes).
std::size_t count_cells(std::string_view line, char delim) {
  std::size_t n = 1;
  bool quoted = false;
  for (const char ch : line) {
    if (ch == '"') quoted = !quoted;
    else if (ch == delim && !quoted) ++n;
  }
  return n;
}

// Splits one line; "quoted, fields" keep their delimiters ("" is a literal quote).
std::vector<std::string> split(std::string_view line, char delim) {
  std::vector<std::string> out;
  std::string cur;
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char ch = line[i];
    if (quoted) {
      if (ch == '"' && i + 1 < line.size() && line[i + 1] == '"') { cur += '"'; ++i; }
      else if (ch == '"') quoted = false;
      else cur += ch;
    } else if (ch == '"') {
      quoted = true;
    } else if (ch == delim) {
      if (delim != ' ' || !cur.empty()) out.push_back(trim(cur));  // runs of spaces are one delimiter
      cur.clear();
      if (out.size() > kMaxColumns) return out;  // too many: the caller says so, memory stays bounded
    } else {
      cur += ch;
    }
  }
  if (delim != ' ' || !cur.empty()) out.push_back(trim(cur));
  return out;
}

}  // namespace

Recording parse_csv_recording(std::string_view csv, const std::string& file, std::optional<std::string_view> map_toml,
                              const std::string& map_name) {
  const std::string mfile = map_name.empty() ? "<map>" : map_name;
  const CsvLayout L = map_toml ? parse_map(*map_toml, mfile) : CsvLayout{};

  // Lines (LF or CRLF); header at L.header_line; blank lines skipped.
  std::size_t pos = 0;
  long lineno = 0;
  auto next = [&](std::string_view& line) {
    if (pos >= csv.size()) return false;
    auto nl = csv.find('\n', pos);
    if (nl == std::string_view::npos) nl = csv.size();
    line = csv.substr(pos, nl - pos);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos = nl + 1;
    ++lineno;
    return true;
  };
  std::string_view line;
  do {
    if (!next(line)) throw InputError(file, fmt::format("line {}", L.header_line), "a header line", "end of file");
  } while (lineno < L.header_line);
  if (lineno == 1 && line.size() >= 3 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // UTF-8 BOM
  const char delim = L.delimiter ? *L.delimiter
                   : line.find('\t') != std::string_view::npos ? '\t'
                   : line.find(';') != std::string_view::npos ? ';' : ',';
  // Also for a detected delimiter: "0,5" would otherwise split into two cells.
  if (delim == ',' && L.decimal == ',')
    throw InputError(mfile, "decimal", "\".\" when the delimiter is \",\" (set delimiter = \";\" or \"\\t\")",
                     fmt::format("\",\" with \",\" as the delimiter of {}", file));
  if (const std::size_t n = count_cells(line, delim); delim != ' ' && n > kMaxColumns)
    throw InputError(file, fmt::format("line {} (header)", lineno), fmt::format("at most {} columns", kMaxColumns),
                     std::to_string(n));
  const auto header = split(line, delim);
  if (header.size() > kMaxColumns)
    throw InputError(file, fmt::format("line {} (header)", lineno), fmt::format("at most {} columns", kMaxColumns),
                     std::to_string(header.size()));
  const long header_lineno = lineno;

  // column index → mapping
  std::vector<std::optional<ColumnMap>> cols(header.size());
  std::array<int, kColumns.size()> where{};
  where.fill(-1);
  for (std::size_t i = 0; i < header.size(); ++i) {
    if (map_toml) {
      auto it = L.by_csv_name.find(header[i]);
      if (it == L.by_csv_name.end()) continue;  // unmapped columns are ignored
      cols[i] = it->second;
    } else {
      const int c = canonical_index(header[i]);
      if (c < 0) {
        throw InputError(file, fmt::format("line {}, column {} (\"{}\")", header_lineno, i + 1, echo(header[i])),
                         std::string("a canonical name (") + kColumnList + ") or a --map");
      }
      cols[i] = ColumnMap{header[i], c};
    }
    const auto c = static_cast<std::size_t>(cols[i]->canonical);
    if (where[c] >= 0) throw InputError(file, fmt::format("line {}, column {} (\"{}\")", header_lineno, i + 1, echo(header[i])), "each channel once");
    where[c] = static_cast<int>(i);
  }
  if (map_toml) {
    for (const auto& [name, m] : L.by_csv_name) {
      if (std::find(header.begin(), header.end(), name) == header.end()) {
        throw InputError(mfile, fmt::format("columns.\"{}\"", echo(name)), fmt::format("a column of {} line {}", file, header_lineno), "no such column");
      }
    }
  }
  for (int c = 0; c <= 6; ++c) {
    if (where[static_cast<std::size_t>(c)] < 0) {
      throw InputError(file, fmt::format("line {} (header)", header_lineno), fmt::format("a column for {}", kColumns[static_cast<std::size_t>(c)].name), "none");
    }
  }
  const int torques = (where[7] >= 0) + (where[8] >= 0) + (where[9] >= 0);
  if (torques != 0 && torques != 3) throw InputError(file, fmt::format("line {} (header)", header_lineno), "all of tx_Nmm, ty_Nmm, tz_Nmm or none");
  const bool has_torque = torques == 3, has_spindle = where[10] >= 0;
  const bool has_load = where[11] >= 0, has_power = where[12] >= 0;
  if (has_load && has_power)
    throw InputError(file, fmt::format("line {} (header)", header_lineno), "spindle_torque_Nmm or spindle_power_W, not both", "both");

  Stream s;
  s.name = "csv";
  Channel pos_c{kPosition, "mm", 3, {}}, force_c{kForce, "N", 3, {}}, torque_c{kTorque, "N*mm", 3, {}}, spin_c{kSpindle, "rpm", 1, {}},
      load_c{has_power ? kSpindlePower : kSpindleTorque, has_power ? "W" : "N*mm", 1, {}};
  double last_t = 0;
  std::array<double, kColumns.size()> row{};
  while (next(line)) {
    if (trim(line).empty()) continue;
    if (delim != ' ') {  // spaces collapse: counted after the split, bounded by the line then
      if (const std::size_t n = count_cells(line, delim); n != header.size())
        throw InputError(file, fmt::format("line {}", lineno), fmt::format("{} columns like the header", header.size()),
                         std::to_string(n));
    }
    auto cells = split(line, delim);
    if (cells.size() != header.size()) {
      throw InputError(file, fmt::format("line {}", lineno), fmt::format("{} columns like the header", header.size()), std::to_string(cells.size()));
    }
    for (std::size_t i = 0; i < cells.size(); ++i) {
      if (!cols[i]) continue;
      std::string cell = cells[i];
      if (L.decimal == ',') std::replace(cell.begin(), cell.end(), ',', '.');
      const auto d = to_double(cell);
      if (!d) {
        throw InputError(file, fmt::format("line {}, column {} (\"{}\")", lineno, i + 1, echo(header[i])), "a finite number",
                         "\"" + echo(cells[i]) + "\"");
      }
      const ColumnMap& m = *cols[i];
      const double val = m.factor * (m.scale * *d + m.offset);
      if (!std::isfinite(val)) throw InputError(file, fmt::format("line {}, column {} (\"{}\")", lineno, i + 1, echo(header[i])), "a finite value after scaling");
      row[static_cast<std::size_t>(m.canonical)] = val;
    }
    const double t = row[0];
    const std::string tcol = fmt::format("line {}, column {} (\"{}\")", lineno, where[0] + 1, echo(header[static_cast<std::size_t>(where[0])]));
    if (std::abs(t) > 9e9) throw InputError(file, tcol, "a time within ±9e9 s");
    const auto t_ns = static_cast<std::int64_t>(std::llround(t * 1e9));
    if (!s.t_ns.empty() && (t <= last_t || t_ns <= s.t_ns.back())) {
      throw InputError(file, tcol, fmt::format("time strictly increasing (previous {} s)", last_t), fmt::format("{} s", t));
    }
    last_t = t;
    s.t_ns.push_back(t_ns);
    for (int k = 0; k < 3; ++k) {
      pos_c.values.push_back(row[static_cast<std::size_t>(1 + k)]);
      force_c.values.push_back(row[static_cast<std::size_t>(4 + k)]);
      if (has_torque) torque_c.values.push_back(row[static_cast<std::size_t>(7 + k)]);
    }
    if (has_spindle) spin_c.values.push_back(row[10]);
    if (has_load || has_power) load_c.values.push_back(row[has_power ? 12 : 11]);
  }
  if (s.t_ns.empty()) throw InputError(file, fmt::format("line {}", header_lineno + 1), "at least one data row after the header", "none");
  s.channels.push_back(std::move(pos_c));
  s.channels.push_back(std::move(force_c));
  if (has_torque) s.channels.push_back(std::move(torque_c));
  if (has_spindle) s.channels.push_back(std::move(spin_c));
  if (has_load || has_power) s.channels.push_back(std::move(load_c));

  Recording rec;
  rec.events.push_back({s.t_ns.front(), "start", "", "imported from CSV"});
  rec.events.push_back({s.t_ns.back(), "stop", "", "imported from CSV"});
  rec.streams.push_back(std::move(s));
  rec.meta.notes = fmt::format("imported from CSV {}{}", file, map_toml ? " with column map " + mfile : std::string());
  return rec;
}

Recording read_csv_recording(const std::filesystem::path& csv, const std::optional<std::filesystem::path>& map) {
  const ReadingFile reading(csv.string());  // names it if memory runs out
  const std::string text = detail::read_file_limited(csv, kMaxCsvBytes);
  std::optional<std::string> map_text;
  if (map) map_text = detail::read_file_limited(*map, 1u << 20);
  Recording r = parse_csv_recording(text, csv.string(), map_text ? std::optional<std::string_view>(*map_text) : std::nullopt,
                                    map ? map->string() : std::string());
  return r;
}

}  // namespace burrbench::data_schema::import
