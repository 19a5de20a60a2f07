// MetaImage reader (ITK's .mha / .mhd): "Key = Value" lines, ElementDataFile last.
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "import/volume_decode.hpp"

namespace burrbench::data_schema::import {
namespace {
using namespace detail;

std::vector<double> numbers(const std::map<std::string, std::string>& f, const std::string& key,
                            std::size_t n, const std::string& file) {
  std::istringstream in(f.at(key));
  std::vector<double> out;
  for (std::string t; in >> t;) {
    auto d = to_double(t);
    if (!d) throw InputError(file, key, fmt::format("{} finite numbers", n), "'" + f.at(key) + "'");
    out.push_back(*d);
  }
  if (out.size() != n) throw InputError(file, key, fmt::format("{} numbers", n), "'" + f.at(key) + "'");
  return out;
}

bool boolean(const std::string& v, const std::string& key, const std::string& file) {
  const std::string l = lower(v);
  if (l == "true" || l == "1") return true;
  if (l == "false" || l == "0") return false;
  throw InputError(file, key, "True or False", "'" + v + "'");
}

}  // namespace

ImageVolume parse_metaimage(std::string_view bytes, const std::string& file, const DataFileReader& data_file,
                            const ImportLimits& lim) {
  std::map<std::string, std::string> f;  // keys lower-cased
  std::size_t pos = 0;
  bool have_data_key = false;
  while (pos < bytes.size()) {
    auto nl = bytes.find('\n', pos);
    if (nl == std::string_view::npos) nl = bytes.size();
    std::string line(bytes.substr(pos, nl - pos));
    pos = std::min(nl + 1, bytes.size());
    if (trim(line).empty()) continue;
    const auto eq = line.find('=');
    if (eq == std::string::npos) throw InputError(file, fmt::format("header line '{}'", trim(line).substr(0, 60)), "'Key = Value'");
    std::string key = lower(trim(line.substr(0, eq)));
    if (f.count(key)) throw InputError(file, key, "the key only once");
    f[key] = trim(line.substr(eq + 1));
    if (key == "elementdatafile") { have_data_key = true; break; }  // data follows this line
  }
  if (!have_data_key) throw InputError(file, "ElementDataFile", "this key (last in the header)", "none");
  auto need = [&](const char* k, const char* display) -> const std::string& {
    auto it = f.find(k);
    if (it == f.end()) throw InputError(file, display, "this key in the header", "none");
    return it->second;
  };
  static const char* const known[] = {
      "objecttype", "objectsubtype", "ndims", "dimsize", "elementtype", "elementspacing", "elementsize",
      "offset", "origin", "position", "transformmatrix", "rotation", "orientation", "centerofrotation",
      "anatomicalorientation", "elementbyteordermsb", "binarydatabyteordermsb", "binarydata",
      "compresseddata", "compresseddatasize", "elementnumberofchannels", "headersize", "elementdatafile",
      "comment", "name", "id", "parentid", "modality", "elementmin", "elementmax", "color", "acquisitiondate"};
  for (const auto& [k, v] : f) {
    if (std::find(std::begin(known), std::end(known), k) == std::end(known)) throw InputError(file, k, "a known MetaImage key");
  }
  if (f.count("objecttype") && lower(f["objecttype"]) != "image") throw InputError(file, "ObjectType", "Image", f["objecttype"]);
  if (trim(need("ndims", "NDims")) != "3") throw InputError(file, "NDims", "3", f["ndims"]);
  if (f.count("elementnumberofchannels") && trim(f["elementnumberofchannels"]) != "1") {
    throw InputError(file, "ElementNumberOfChannels", "1 (scalar image)", f["elementnumberofchannels"]);
  }
  if (f.count("binarydata") && !boolean(f["binarydata"], "BinaryData", file)) throw InputError(file, "BinaryData", "True (ASCII data unsupported)");

  static const std::map<std::string, VoxelType> types = {{"met_uchar", VoxelType::kUint8}, {"met_short", VoxelType::kInt16},
                                                         {"met_ushort", VoxelType::kUint16}, {"met_float", VoxelType::kFloat32}};
  const auto tt = types.find(lower(need("elementtype", "ElementType")));
  if (tt == types.end()) throw InputError(file, "ElementType", "MET_UCHAR, MET_SHORT, MET_USHORT or MET_FLOAT", f["elementtype"]);
  ImageVolume v;
  v.source_type = tt->second;
  need("dimsize", "DimSize");
  const auto ds = numbers(f, "dimsize", 3, file);
  for (std::size_t i = 0; i < 3; ++i) {
    // Range first: converting an out-of-range double to an integer is undefined.
    if (!(ds[i] >= 1 && ds[i] <= 1e15) || ds[i] != std::floor(ds[i])) {
      throw InputError(file, "DimSize", "3 positive integers", f["dimsize"]);
    }
    v.dims[i] = static_cast<std::size_t>(ds[i]);
  }
  const std::size_t count = checked_voxel_count(v.dims, v.source_type, lim, file, "DimSize");
  const std::size_t nbytes = count * byte_size(v.source_type);

  glm::dvec3 spacing{1, 1, 1};
  if (f.count("elementspacing")) {
    auto s = numbers(f, "elementspacing", 3, file);
    spacing = {s[0], s[1], s[2]};
  } else if (f.count("elementsize")) {
    auto s = numbers(f, "elementsize", 3, file);
    spacing = {s[0], s[1], s[2]};
  } else {
    throw InputError(file, "ElementSpacing", "voxel spacing in the header", "none");
  }
  for (int i = 0; i < 3; ++i) if (!(spacing[i] > 0)) throw InputError(file, "ElementSpacing", "positive spacings");
  glm::dvec3 origin{0, 0, 0};
  for (const char* k : {"offset", "origin", "position"}) {
    if (f.count(k)) {
      auto o = numbers(f, k, 3, file);
      origin = {o[0], o[1], o[2]};
      break;
    }
  }
  std::array<glm::dvec3, 3> dirs{glm::dvec3{spacing.x, 0, 0}, glm::dvec3{0, spacing.y, 0}, glm::dvec3{0, 0, spacing.z}};
  for (const char* k : {"transformmatrix", "rotation", "orientation"}) {
    if (f.count(k)) {
      // ITK writes the direction cosines of index axis i as the i-th triplet.
      auto m = numbers(f, k, 9, file);
      for (std::size_t i = 0; i < 3; ++i) dirs[i] = glm::dvec3(m[3 * i], m[3 * i + 1], m[3 * i + 2]) * spacing[static_cast<int>(i)];
      break;
    }
  }
  bool big = false;
  for (const char* k : {"elementbyteordermsb", "binarydatabyteordermsb"}) {
    if (f.count(k)) big = boolean(f[k], k == std::string("elementbyteordermsb") ? "ElementByteOrderMSB" : "BinaryDataByteOrderMSB", file);
  }
  const bool compressed = f.count("compresseddata") && boolean(f["compresseddata"], "CompressedData", file);

  std::string detached;
  std::string_view data;
  std::string data_name = file;
  const std::string& df = f["elementdatafile"];
  if (lower(df) == "local") {
    data = bytes.substr(pos);
  } else {
    if (df.empty() || lower(df) == "list" || df.find('%') != std::string::npos) {
      throw InputError(file, "ElementDataFile", "LOCAL or one file name (lists and patterns unsupported)", "'" + df + "'");
    }
    detached = data_file(df);
    data = detached;
    data_name = fmt::format("{} (data file {})", file, df);
  }
  if (f.count("headersize")) {
    auto hs = to_int(f["headersize"]);
    if (!hs || *hs < -1) throw InputError(file, "HeaderSize", "an integer ≥ -1", f["headersize"]);
    if (*hs == -1) {
      if (compressed) throw InputError(file, "HeaderSize", "≥ 0 with compressed data", "-1");
      if (data.size() < nbytes) throw InputError(data_name, "data", fmt::format("{} bytes of voxel data", nbytes), fmt::format("{} bytes", data.size()));
      data = data.substr(data.size() - nbytes);
    } else {
      if (static_cast<std::size_t>(*hs) > data.size()) throw InputError(data_name, "HeaderSize", "a header shorter than the data file");
      data.remove_prefix(static_cast<std::size_t>(*hs));
    }
  }
  std::string inflated;
  if (compressed) {
    if (f.count("compresseddatasize")) {
      auto cs = to_int(f["compresseddatasize"]);
      if (!cs || *cs < 0) throw InputError(file, "CompressedDataSize", "an integer ≥ 0", f["compresseddatasize"]);
      if (static_cast<std::size_t>(*cs) < data.size()) data = data.substr(0, static_cast<std::size_t>(*cs));
    }
    inflated = inflate_exact(data, nbytes, data_name);
    data = inflated;
  } else if (data.size() < nbytes) {
    throw InputError(data_name, "data", fmt::format("{} bytes of voxel data", nbytes), fmt::format("{} bytes (file truncated?)", data.size()));
  }
  v.values = decode_samples(data, count, v.source_type, big, data_name);
  apply_axis_aligned(v, dirs, origin, file, "TransformMatrix");
  return v;
}

ImageVolume read_metaimage(const std::filesystem::path& path, const ImportLimits& lim) {
  return detail::read_header_and_data(path, lim, parse_metaimage);
}

}  // namespace burrbench::data_schema::import
