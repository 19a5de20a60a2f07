// NRRD reader (http://teem.sourceforge.net/nrrd/format.html), the subset labs and 3D
// Slicer produce: 3-D scalar volumes, raw or gzip, attached or detached ("data file").
#include <algorithm>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "import/volume_decode.hpp"

namespace burrbench::data_schema::import {
namespace {
using namespace detail;

// Fields that describe nothing we use; accepted and ignored.
const char* const kIgnored[] = {"content", "kinds", "centers", "centerings", "labels", "units",
                                "space units", "min", "max", "old min", "oldmin", "old max",
                                "oldmax", "thicknesses", "axis mins", "axismins", "axis maxs",
                                "axismaxs", "measurement frame", "sample units", "sampleunits",
                                "number", "space"};

VoxelType parse_type(const std::string& t, const std::string& file) {
  static const std::map<std::string, VoxelType> types = {
      {"uchar", VoxelType::kUint8},           {"unsigned char", VoxelType::kUint8},
      {"uint8", VoxelType::kUint8},           {"uint8_t", VoxelType::kUint8},
      {"short", VoxelType::kInt16},           {"short int", VoxelType::kInt16},
      {"signed short", VoxelType::kInt16},    {"signed short int", VoxelType::kInt16},
      {"int16", VoxelType::kInt16},           {"int16_t", VoxelType::kInt16},
      {"ushort", VoxelType::kUint16},         {"unsigned short", VoxelType::kUint16},
      {"unsigned short int", VoxelType::kUint16}, {"uint16", VoxelType::kUint16},
      {"uint16_t", VoxelType::kUint16},       {"float", VoxelType::kFloat32}};
  auto it = types.find(lower(t));
  if (it == types.end()) throw InputError(file, "type", "one of uint8, int16, uint16, float", "'" + t + "'");
  return it->second;
}

// "(a,b,c)" → vector
glm::dvec3 parse_vector(std::string_view tok, const std::string& file, const std::string& field) {
  std::string t = trim(tok);
  if (t.size() < 2 || t.front() != '(' || t.back() != ')') throw InputError(file, field, "a vector (a,b,c)", "'" + t + "'");
  t = t.substr(1, t.size() - 2);
  glm::dvec3 v{};
  std::size_t start = 0;
  for (int i = 0; i < 3; ++i) {
    const auto comma = t.find(',', start);
    if ((i < 2) != (comma != std::string::npos)) throw InputError(file, field, "a vector of 3 finite numbers", "'(" + t + ")'");
    auto d = to_double(std::string_view(t).substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (!d) throw InputError(file, field, "a vector of 3 finite numbers", "'(" + t + ")'");
    v[i] = *d;
    start = comma + 1;
  }
  return v;
}

std::vector<std::string> split_ws(const std::string& s) {
  std::istringstream in(s);
  std::vector<std::string> out;
  for (std::string t; in >> t;) out.push_back(t);
  return out;
}

struct NrrdGeometry {
  std::array<glm::dvec3, 3> dirs{glm::dvec3{1, 0, 0}, glm::dvec3{0, 1, 0}, glm::dvec3{0, 0, 1}};
  glm::dvec3 origin{0, 0, 0};
};

// The voxel axes (space directions, else spacings) and the origin of the header's fields.
NrrdGeometry nrrd_geometry(std::map<std::string, std::string>& f, const std::string& file) {
  NrrdGeometry g;
  auto& dirs = g.dirs;
  auto& origin = g.origin;
  if (f.count("space directions")) {
    if (f.count("space dimension") && trim(f["space dimension"]) != "3") throw InputError(file, "space dimension", "3", f["space dimension"]);
    const auto toks = split_ws(f["space directions"]);
    if (toks.size() != 3) throw InputError(file, "space directions", "three vectors (a,b,c) (no 'none' axes)", f["space directions"]);
    for (std::size_t i = 0; i < 3; ++i) dirs[i] = parse_vector(toks[i], file, "space directions");
    if (f.count("space origin")) origin = parse_vector(f["space origin"], file, "space origin");
  } else if (f.count("spacings")) {
    const auto toks = split_ws(f["spacings"]);
    if (toks.size() != 3) throw InputError(file, "spacings", "3 spacings", f["spacings"]);
    for (std::size_t i = 0; i < 3; ++i) {
      auto s = to_double(toks[i]);
      if (!s || *s <= 0) throw InputError(file, "spacings", "3 positive finite spacings", f["spacings"]);
      dirs[i] = glm::dvec3(0);
      dirs[i][static_cast<int>(i)] = *s;
    }
    if (f.count("space origin")) origin = parse_vector(f["space origin"], file, "space origin");
  } else {
    throw InputError(file, "space directions", "voxel spacing (space directions or spacings)", "none");
  }
  return g;
}

}  // namespace

ImageVolume parse_nrrd(std::string_view bytes, const std::string& file, const DataFileReader& data_file,
                       const ImportLimits& lim) {
  // --- header: magic line, then "field: value" lines up to a blank line (or EOF) ---
  std::size_t pos = 0;
  auto next_line = [&](std::string& line) {
    if (pos >= bytes.size()) return false;
    auto nl = bytes.find('\n', pos);
    if (nl == std::string_view::npos) nl = bytes.size();
    line.assign(bytes.substr(pos, nl - pos));
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = std::min(nl + 1, bytes.size());
    return true;
  };
  std::string line;
  if (!next_line(line) || line.size() != 8 || line.rfind("NRRD000", 0) != 0 || line[7] < '1' || line[7] > '5') {
    throw InputError(file, "magic", "a NRRD file starting with NRRD0001..NRRD0005");
  }
  std::map<std::string, std::string> f;
  bool blank = false;
  while (next_line(line)) {
    if (line.empty()) { blank = true; break; }
    if (line[0] == '#') continue;
    if (line.find(":=") != std::string::npos) continue;  // key/value pairs: metadata only
    const auto colon = line.find(": ");
    if (colon == std::string::npos) throw InputError(file, fmt::format("header line '{}'", line.substr(0, 60)), "'field: value'");
    std::string key = lower(trim(line.substr(0, colon)));
    if (key == "datafile") key = "data file";
    if (key == "spacedirections") key = "space directions";
    if (key == "spaceorigin") key = "space origin";
    if (key == "byteskip") key = "byte skip";
    if (key == "lineskip") key = "line skip";
    if (f.count(key)) throw InputError(file, key, "the field only once");
    f[key] = trim(line.substr(colon + 2));
  }
  auto need = [&](const char* k) -> const std::string& {
    auto it = f.find(k);
    if (it == f.end()) throw InputError(file, k, "this field in the header", "none");
    return it->second;
  };
  for (const auto& [k, v] : f) {
    static const char* const used[] = {"type", "dimension", "sizes", "encoding", "endian", "space dimension",
                                       "space directions", "space origin", "spacings", "data file",
                                       "byte skip", "line skip"};
    if (std::find(std::begin(used), std::end(used), k) != std::end(used)) continue;
    if (std::find(std::begin(kIgnored), std::end(kIgnored), k) != std::end(kIgnored)) continue;
    if (k == "block size") throw InputError(file, k, "a scalar type (block types unsupported)");
    throw InputError(file, k, "a known NRRD field");
  }

  const VoxelType type = parse_type(need("type"), file);
  if (trim(need("dimension")) != "3") throw InputError(file, "dimension", "3", need("dimension"));
  const auto size_tokens = split_ws(need("sizes"));
  if (size_tokens.size() != 3) throw InputError(file, "sizes", "3 sizes", need("sizes"));
  ImageVolume v;
  for (std::size_t i = 0; i < 3; ++i) {
    auto n = to_int(size_tokens[i]);
    if (!n || *n < 1) throw InputError(file, "sizes", "positive integers", need("sizes"));
    v.dims[i] = static_cast<std::size_t>(*n);
  }
  v.source_type = type;
  const std::size_t count = checked_voxel_count(v.dims, type, lim, file, "sizes");
  const std::size_t nbytes = count * byte_size(type);

  const std::string enc = lower(need("encoding"));
  bool gz = false;
  if (enc == "gzip" || enc == "gz") gz = true;
  else if (enc != "raw") throw InputError(file, "encoding", "raw or gzip", "'" + enc + "'");
  bool big = false;
  if (byte_size(type) > 1) {
    const std::string e = lower(need("endian"));
    if (e != "little" && e != "big") throw InputError(file, "endian", "little or big", "'" + e + "'");
    big = e == "big";
  }

  const NrrdGeometry geometry = nrrd_geometry(f, file);

  // --- data ---
  std::string detached;
  std::string_view data;
  std::string data_name = file;
  if (f.count("data file")) {
    const std::string& name = f["data file"];
    if (name == "LIST" || name.find('%') != std::string::npos || split_ws(name).size() != 1) {
      throw InputError(file, "data file", "a single file name (lists and patterns unsupported)", "'" + name + "'");
    }
    detached = data_file(name);
    data = detached;
    data_name = fmt::format("{} (data file {})", file, name);
  } else {
    if (!blank) throw InputError(file, "header", "a blank line before the attached data", "end of file");
    data = bytes.substr(pos);
  }
  long long line_skip = 0, byte_skip = 0;
  if (f.count("line skip")) {
    auto n = to_int(f["line skip"]);
    if (!n || *n < 0) throw InputError(file, "line skip", "an integer ≥ 0", f["line skip"]);
    line_skip = *n;
  }
  if (f.count("byte skip")) {
    auto n = to_int(f["byte skip"]);
    if (!n || *n < -1) throw InputError(file, "byte skip", "an integer ≥ -1", f["byte skip"]);
    byte_skip = *n;
  }
  for (long long i = 0; i < line_skip; ++i) {
    const auto nl = data.find('\n');
    if (nl == std::string_view::npos) throw InputError(data_name, "line skip", fmt::format("{} lines before the data", line_skip));
    data.remove_prefix(nl + 1);
  }
  std::string inflated;
  if (gz) {
    if (byte_skip < 0) throw InputError(file, "byte skip", "≥ 0 with gzip encoding", "-1");
    const std::size_t skip = static_cast<std::size_t>(byte_skip);
    if (skip > lim.max_bytes) throw InputError(file, "byte skip", "a skip within the memory budget");
    inflated = inflate_exact(data, nbytes + skip, data_name);
    data = std::string_view(inflated).substr(skip);
  } else {
    if (byte_skip == -1) {
      if (data.size() < nbytes) throw InputError(data_name, "data", fmt::format("{} bytes of voxel data", nbytes), fmt::format("{} bytes", data.size()));
      data = data.substr(data.size() - nbytes);
    } else {
      const auto skip = static_cast<std::size_t>(byte_skip);
      if (data.size() < skip || data.size() - skip < nbytes) {
        throw InputError(data_name, "data", fmt::format("{} bytes of voxel data", nbytes),
                         fmt::format("{} bytes (file truncated?)", data.size() < skip ? 0 : data.size() - skip));
      }
      data = data.substr(skip);
    }
  }
  v.values = decode_samples(data, count, type, big, data_name);
  apply_axis_aligned(v, geometry.dirs, geometry.origin, file, "space directions");
  return v;
}

ImageVolume read_nrrd(const std::filesystem::path& path, const ImportLimits& lim) {
  return detail::read_header_and_data(path, lim, parse_nrrd);
}

}  // namespace burrbench::data_schema::import
