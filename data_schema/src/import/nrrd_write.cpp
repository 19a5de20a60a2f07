// NRRD writer for the 3D Slicer export (attached header, gzip data).
#include <zlib.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"

namespace burrbench::data_schema::import {

void write_nrrd(const std::filesystem::path& path, const ImageVolume& v, VoxelType type,
                const std::vector<std::pair<std::string, std::string>>& key_values) {
  BURRBENCH_CHECK(v.values.size() == v.voxel_count(), "values match dims");
  const std::size_t bs = byte_size(type);
  std::string raw(v.values.size() * bs, '\0');
  for (std::size_t i = 0; i < v.values.size(); ++i) {
    const float f = v.values[i];
    char* p = raw.data() + i * bs;
    switch (type) {  // little endian on every platform we build for (checked below)
      case VoxelType::kUint8: *reinterpret_cast<unsigned char*>(p) = static_cast<unsigned char>(std::lround(f)); break;
      case VoxelType::kInt16: { auto s = static_cast<std::int16_t>(std::lround(f)); std::memcpy(p, &s, 2); break; }
      case VoxelType::kUint16: { auto s = static_cast<std::uint16_t>(std::lround(f)); std::memcpy(p, &s, 2); break; }
      case VoxelType::kFloat32: std::memcpy(p, &f, 4); break;
    }
  }
  static_assert(std::endian::native == std::endian::little, "write_nrrd writes native little-endian data");
  uLongf clen = compressBound(static_cast<uLong>(raw.size())) + 64;
  std::string gz(clen, '\0');
  // deflateInit2 with windowBits 15+16 writes a gzip wrapper, which NRRD's "gzip" expects.
  z_stream zs{};
  if (deflateInit2(&zs, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) BURRBENCH_CHECK(false, "deflateInit2");
  zs.next_in = reinterpret_cast<Bytef*>(raw.data());
  zs.avail_in = static_cast<uInt>(raw.size());
  zs.next_out = reinterpret_cast<Bytef*>(gz.data());
  zs.avail_out = static_cast<uInt>(gz.size());
  const int rc = deflate(&zs, Z_FINISH);
  deflateEnd(&zs);
  BURRBENCH_CHECK(rc == Z_STREAM_END, "deflate into a compressBound-sized buffer");
  gz.resize(zs.total_out);

  const char* tname = type == VoxelType::kUint8 ? "uint8" : type == VoxelType::kInt16 ? "int16"
                    : type == VoxelType::kUint16 ? "uint16" : "float";
  std::string h = fmt::format(
      "NRRD0004\n# burrbench export; origin = centre of voxel (0,0,0), mm\ntype: {}\ndimension: 3\n"
      "space: 3D-right-handed\nsizes: {} {} {}\nspace directions: ({:.17g},0,0) (0,{:.17g},0) (0,0,{:.17g})\n"
      "kinds: domain domain domain\nendian: little\nencoding: gzip\nspace units: \"mm\" \"mm\" \"mm\"\n"
      "space origin: ({:.17g},{:.17g},{:.17g})\n\n",
      tname, v.dims[0], v.dims[1], v.dims[2], v.spacing_mm.x, v.spacing_mm.y, v.spacing_mm.z, v.origin_mm.x,
      v.origin_mm.y, v.origin_mm.z);
  std::string kv;
  for (const auto& [k, val] : key_values) {
    std::string e;
    for (char c : val) {
      if (c == '\\') e += "\\\\";
      else if (c == '\n') e += "\\n";
      else e += c;
    }
    kv += k + ":=" + e + "\n";
  }
  h.insert(h.size() - 1, kv);  // before the blank line that ends the header
  AtomicFile out(path);
  out << h << std::string_view(gz.data(), gz.size());
  out.commit();
}

}  // namespace burrbench::data_schema::import
