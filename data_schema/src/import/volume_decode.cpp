#include "import/volume_decode.hpp"

#include <fcntl.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cstdio>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema::import {

const char* to_string(VoxelType t) {
  switch (t) {
    case VoxelType::kUint8: return "uint8";
    case VoxelType::kInt16: return "int16";
    case VoxelType::kUint16: return "uint16";
    case VoxelType::kFloat32: return "float32";
  }
  BURRBENCH_UNREACHABLE();
}

std::size_t byte_size(VoxelType t) {
  switch (t) {
    case VoxelType::kUint8: return 1;
    case VoxelType::kInt16:
    case VoxelType::kUint16: return 2;
    case VoxelType::kFloat32: return 4;
  }
  BURRBENCH_UNREACHABLE();
}

bool is_cubic(const ImageVolume& v, double rel_tol) {
  const double a = v.spacing_mm.x;
  return std::abs(v.spacing_mm.y - a) <= rel_tol * a && std::abs(v.spacing_mm.z - a) <= rel_tol * a;
}

namespace detail {

std::size_t checked_voxel_count(const std::array<std::size_t, 3>& dims, VoxelType t,
                                const ImportLimits& lim, const std::string& file,
                                const std::string& field) {
  std::size_t n = 1;
  for (std::size_t d : dims) {
    if (d == 0) throw InputError(file, field, "three sizes ≥ 1", "a zero size");
    if (n > std::numeric_limits<std::size_t>::max() / d) {
      throw InputError(file, field, fmt::format("a volume within the memory budget of {} bytes", lim.max_bytes),
                       "a size that overflows");
    }
    n *= d;
  }
  // Decoded as float32, whatever the source type; the raw bytes are also held once.
  const std::size_t per_voxel = sizeof(float) + byte_size(t);
  if (n > lim.max_bytes / per_voxel) {
    throw InputError(file, field,
                     fmt::format("a volume within the memory budget of {} bytes", lim.max_bytes),
                     fmt::format("{}x{}x{} {} voxels", dims[0], dims[1], dims[2], to_string(t)));
  }
  return n;
}

std::string read_file_limited(const std::filesystem::path& p, std::size_t max_bytes) {
  const ReadingFile reading(p.string());  // names it if memory runs out
  std::error_code ec;
  if (!std::filesystem::is_regular_file(p, ec)) throw InputError(p.string(), "<file>", "an existing regular file");
  const auto size = std::filesystem::file_size(p, ec);
  if (ec) throw InputError(p.string(), "<file>", "a readable file");
  if (size > max_bytes) {
    throw InputError(p.string(), "<file>", fmt::format("at most {} bytes (memory budget)", max_bytes),
                     fmt::format("{} bytes", size));
  }
  std::ifstream in(p, std::ios::binary);
  if (!in) throw InputError(p.string(), "<file>", "a readable file");
  std::string s(static_cast<std::size_t>(size), '\0');
  in.read(s.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::size_t>(in.gcount()) != size) throw InputError(p.string(), "<file>", "a readable file", "a short read");
  return s;
}

ImageVolume read_header_and_data(const std::filesystem::path& path, const ImportLimits& lim, HeaderParser parse) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  // The attached data may reach the budget; allow header slack.
  const std::size_t max_bytes = lim.max_bytes + (1u << 20);
  const std::string bytes = read_file_limited(path, max_bytes);
  const auto dir = path.parent_path();
  std::vector<std::filesystem::path> files{path};
  const DataFileReader reader = [&](const std::string& name) {
    std::filesystem::path p(name);
    if (p.is_relative()) p = dir / p;
    files.push_back(p);
    return read_file_limited(p, max_bytes);
  };
  ImageVolume v = parse(bytes, path.string(), reader, lim);
  v.files = std::move(files);
  return v;
}

std::string inflate_exact(std::string_view compressed, std::size_t expected, const std::string& file) {
  std::string out(expected, '\0');
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 32) != Z_OK) throw InputError(file, "data", "a gzip/zlib stream", "zlib init failure");
  std::size_t in_pos = 0, out_pos = 0;
  int rc = Z_OK;
  // zlib counts in uInt: feed and drain in chunks so > 4 GiB streams work too.
  constexpr std::size_t kChunk = 1u << 30;
  while (out_pos < expected) {
    if (zs.avail_in == 0) {
      const std::size_t n = std::min(kChunk, compressed.size() - in_pos);
      zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data() + in_pos));
      zs.avail_in = static_cast<uInt>(n);
      in_pos += n;
    }
    const std::size_t want = std::min(kChunk, expected - out_pos);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + out_pos);
    zs.avail_out = static_cast<uInt>(want);
    rc = inflate(&zs, Z_NO_FLUSH);
    out_pos += want - zs.avail_out;
    if (rc == Z_STREAM_END) break;
    if (rc == Z_BUF_ERROR && zs.avail_in == 0 && in_pos >= compressed.size()) break;  // input exhausted
    if (rc != Z_OK && rc != Z_BUF_ERROR) {
      const std::string msg = zs.msg ? zs.msg : fmt::format("zlib error {}", rc);
      inflateEnd(&zs);
      throw InputError(file, "data", "a valid gzip/zlib stream", msg);
    }
  }
  if (out_pos < expected) {
    inflateEnd(&zs);
    throw InputError(file, "data", fmt::format("{} bytes after decompression", expected),
                     fmt::format("{} bytes (truncated or corrupt stream)", out_pos));
  }
  // All voxels are in; the stream must still end cleanly (trailer and checksum present)
  // and hold nothing more.
  while (rc != Z_STREAM_END) {
    char extra = 0;
    if (zs.avail_in == 0 && in_pos < compressed.size()) {
      const std::size_t n = std::min(kChunk, compressed.size() - in_pos);
      zs.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(compressed.data() + in_pos));
      zs.avail_in = static_cast<uInt>(n);
      in_pos += n;
    }
    zs.next_out = reinterpret_cast<Bytef*>(&extra);
    zs.avail_out = 1;
    rc = inflate(&zs, Z_NO_FLUSH);
    if (zs.avail_out == 0) {
      inflateEnd(&zs);
      throw InputError(file, "data", fmt::format("{} bytes after decompression", expected), "more (sizes too small?)");
    }
    if (rc == Z_STREAM_END) break;
    if (rc != Z_OK) {
      const std::string msg = zs.msg ? zs.msg : (zs.avail_in == 0 ? "stream truncated before its end" : fmt::format("zlib error {}", rc));
      inflateEnd(&zs);
      throw InputError(file, "data", "a complete gzip/zlib stream", msg);
    }
  }
  inflateEnd(&zs);
  return out;
}

namespace {
template <typename T>
T load(const char* p, bool swap) {
  std::array<char, sizeof(T)> b{};
  std::memcpy(b.data(), p, sizeof(T));
  if (swap) std::reverse(b.begin(), b.end());
  T v;
  std::memcpy(&v, b.data(), sizeof(T));
  return v;
}
}  // namespace

std::vector<float> decode_samples(std::string_view raw, std::size_t count, VoxelType t,
                                  bool big_endian, const std::string& file) {
  const std::size_t bs = byte_size(t);
  BURRBENCH_CHECK(raw.size() >= count * bs, "caller checks the data length");
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  std::vector<float> out(count);
  const char* p = raw.data();
  for (std::size_t i = 0; i < count; ++i, p += bs) {
    switch (t) {
      case VoxelType::kUint8: out[i] = static_cast<unsigned char>(*p); break;
      case VoxelType::kInt16: out[i] = load<std::int16_t>(p, swap); break;
      case VoxelType::kUint16: out[i] = load<std::uint16_t>(p, swap); break;
      case VoxelType::kFloat32: {
        const float f = load<float>(p, swap);
        if (!std::isfinite(f)) throw InputError(file, fmt::format("data (voxel {})", i), "a finite value", fmt::format("{}", f));
        out[i] = f;
        break;
      }
    }
  }
  return out;
}

void apply_axis_aligned(ImageVolume& v, const std::array<glm::dvec3, 3>& directions,
                        glm::dvec3 origin, const std::string& file, const std::string& field) {
  std::array<int, 3> world_axis{};   // index axis i runs along world axis world_axis[i]
  std::array<int, 3> sign{};
  std::array<bool, 3> used{false, false, false};
  glm::dvec3 spacing{};
  for (int i = 0; i < 3; ++i) {
    const glm::dvec3& d = directions[static_cast<std::size_t>(i)];
    const double norm = glm::length(d);
    if (!(norm > 0) || !std::isfinite(norm)) throw InputError(file, field, "three non-zero finite direction vectors");
    int k = 0;
    for (int j = 1; j < 3; ++j) if (std::abs(d[j]) > std::abs(d[k])) k = j;
    for (int j = 0; j < 3; ++j) {
      if (j != k && std::abs(d[j]) > 1e-6 * norm) {
        throw InputError(file, field, "axis-aligned directions (rotated volumes are not supported; resample them in 3D Slicer first)",
                         fmt::format("({},{},{})", d.x, d.y, d.z));
      }
    }
    if (used[static_cast<std::size_t>(k)]) throw InputError(file, field, "directions along three different axes");
    used[static_cast<std::size_t>(k)] = true;
    world_axis[static_cast<std::size_t>(i)] = k;
    sign[static_cast<std::size_t>(i)] = d[k] > 0 ? 1 : -1;
    spacing[k] = std::abs(d[k]);
  }
  for (int j = 0; j < 3; ++j) {
    if (!std::isfinite(origin[j])) throw InputError(file, field, "a finite origin");
  }
  const auto in_dims = v.dims;
  std::array<std::size_t, 3> out_dims{};
  for (std::size_t i = 0; i < 3; ++i) out_dims[static_cast<std::size_t>(world_axis[i])] = in_dims[i];
  // Origin of the reordered grid: the voxel whose world coordinates are smallest.
  glm::dvec3 new_origin = origin;
  for (std::size_t i = 0; i < 3; ++i) {
    if (sign[i] < 0) {
      const int k = world_axis[i];
      new_origin[k] -= spacing[k] * double(in_dims[i] - 1);
    }
  }
  const bool identity = world_axis == std::array<int, 3>{0, 1, 2} && sign == std::array<int, 3>{1, 1, 1};
  if (!identity) {
    std::vector<float> out(v.values.size());
    std::array<std::size_t, 3> stride{1, out_dims[0], out_dims[0] * out_dims[1]};
    std::size_t src = 0;
    for (std::size_t c = 0; c < in_dims[2]; ++c)
      for (std::size_t b = 0; b < in_dims[1]; ++b)
        for (std::size_t a = 0; a < in_dims[0]; ++a, ++src) {
          const std::array<std::size_t, 3> idx{a, b, c};
          std::size_t dst = 0;
          for (std::size_t i = 0; i < 3; ++i) {
            const std::size_t o = sign[i] > 0 ? idx[i] : in_dims[i] - 1 - idx[i];
            dst += o * stride[static_cast<std::size_t>(world_axis[i])];
          }
          out[dst] = v.values[src];
        }
    v.values = std::move(out);
  }
  v.dims = out_dims;
  v.spacing_mm = spacing;
  v.origin_mm = new_origin;
}

std::string trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return std::string(s.substr(b, e - b + 1));
}

std::string lower(std::string_view s) {
  std::string o(s);
  for (char& c : o) c = static_cast<char>((c >= 'A' && c <= 'Z') ? c - 'A' + 'a' : c);
  return o;
}

std::optional<double> to_double(std::string_view s) {
  std::string t = trim(s);
  if (t.empty()) return std::nullopt;
  const char* b = t.data();
  if (*b == '+') ++b;
  double v = 0;
  auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (ec != std::errc() || p != t.data() + t.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::optional<long long> to_int(std::string_view s) {
  std::string t = trim(s);
  if (t.empty()) return std::nullopt;
  const char* b = t.data();
  if (*b == '+') ++b;
  long long v = 0;
  auto [p, ec] = std::from_chars(b, t.data() + t.size(), v);
  if (ec != std::errc() || p != t.data() + t.size()) return std::nullopt;
  return v;
}

QuietStderr::QuietStderr() {
  // The fuzz build (bench/CMakeLists.txt) keeps stderr: a decoder that aborted under
  // QuietStderr left an empty crash report (fuzz_slices' GDCM assert, issue 59).
#ifndef BURRBENCH_FUZZING
  std::fflush(stderr);
  saved_ = ::dup(2);
  const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
  if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
  if (null >= 0) ::close(null);
#endif
}

QuietStderr::~QuietStderr() {
  if (saved_ < 0) return;
  std::fflush(stderr);
  ::dup2(saved_, 2);
  ::close(saved_);
}

bool natural_less(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])), db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
      nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return a.size() - i < b.size() - j;
}

}  // namespace detail
}  // namespace burrbench::data_schema::import
