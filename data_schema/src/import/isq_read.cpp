// Scanco ISQ (µCT 40/50/80, XtremeCT): the 512-byte "CTDATA-HEADER_V1" header and the 16-bit
// data. Field offsets as in Scanco's header description, which ITK's ScancoImageIO and
// BoneJ's ISQReader follow (docs/importers.md, "Scanco ISQ").
#include <cmath>
#include <cstring>
#include <fstream>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "import/volume_decode.hpp"

namespace burrbench::data_schema::import {
namespace {

constexpr char kMagic[] = "CTDATA-HEADER_V1";

std::int32_t le32(const unsigned char* p) {
  return static_cast<std::int32_t>(std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 |
                                   std::uint32_t(p[3]) << 24);
}

}  // namespace

bool is_isq(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char magic[16] = {};
  return in.read(magic, 16) && std::memcmp(magic, kMagic, 16) == 0;
}

ImageVolume read_isq(const std::filesystem::path& path, const ImportLimits& lim) {
  const std::string f = path.string();
  const ReadingFile reading(f);
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(f, "<file>", "a readable Scanco ISQ file");
  unsigned char h[512];
  if (!in.read(reinterpret_cast<char*>(h), 512)) throw InputError(f, "header", "a 512-byte ISQ header", "a shorter file");
  if (std::memcmp(h, kMagic, 16) != 0)
    throw InputError(f, "header", "the ISQ signature CTDATA-HEADER_V1", fmt::format("'{}'", std::string(reinterpret_cast<const char*>(h), 16)));
  const auto at = [&](std::size_t off) { return le32(h + off); };
  const int data_type = at(16);
  if (data_type != 3) throw InputError(f, "data_type (byte 16)", "3 (16-bit signed voxels of an ISQ)", std::to_string(data_type));
  const std::int32_t dim_p[3] = {at(44), at(48), at(52)}, dim_um[3] = {at(56), at(60), at(64)};
  const char* axis = "xyz";
  std::array<std::size_t, 3> dims{};
  glm::dvec3 spacing{};
  for (int i = 0; i < 3; ++i) {
    if (dim_p[i] < 1) throw InputError(f, fmt::format("dim{}_p (byte {})", axis[i], 44 + 4 * i), "a size ≥ 1 (pixels)", std::to_string(dim_p[i]));
    if (dim_um[i] < 1) throw InputError(f, fmt::format("dim{}_um (byte {})", axis[i], 56 + 4 * i), "a positive physical size (µm)", std::to_string(dim_um[i]));
    dims[static_cast<std::size_t>(i)] = static_cast<std::size_t>(dim_p[i]);
    spacing[i] = double(dim_um[i]) / 1000.0 / double(dim_p[i]);
  }
  // The slice increment (µm, an integer, so truncated) must agree with dimz_um / dimz_p.
  const std::int32_t increment_um = at(72), thickness_um = at(68);
  if (increment_um != 0 && std::abs(double(increment_um) / 1000.0 - spacing.z) > 1.1e-3)
    throw InputError(f, "slice_increment_um (byte 72)", fmt::format("dimz_um / dimz_p = {:.6g} µm (within 1.1 µm)", spacing.z * 1000),
                     fmt::format("{} µm (contradictory)", increment_um));
  const std::int32_t offset_blocks = at(508);
  if (offset_blocks < 0 || offset_blocks > (1 << 20))
    throw InputError(f, "data_offset (byte 508)", "0..2^20 blocks of 512 bytes", std::to_string(offset_blocks));
  const std::size_t header_bytes = (std::size_t(offset_blocks) + 1) * 512;
  const std::size_t count = detail::checked_voxel_count(dims, VoxelType::kInt16, lim, f, "dimx_p/dimy_p/dimz_p");
  std::error_code ec;
  const std::size_t file_size = std::filesystem::file_size(path, ec);
  if (ec || file_size < header_bytes + 2 * count)
    throw InputError(f, "data", fmt::format("{} bytes of 16-bit voxels after the {}-byte header ({}x{}x{})", 2 * count, header_bytes,
                                            dims[0], dims[1], dims[2]),
                     fmt::format("a file of {} bytes", file_size));
  std::string raw(2 * count, '\0');
  in.seekg(static_cast<std::streamoff>(header_bytes));
  if (!in.read(raw.data(), static_cast<std::streamsize>(raw.size())))
    throw InputError(f, "data", "the whole data block", "a read error");
  ImageVolume v;
  v.dims = dims;
  v.spacing_mm = spacing;
  v.origin_mm = {0, 0, 0};
  v.source_type = VoxelType::kInt16;
  v.values = detail::decode_samples(raw, count, VoxelType::kInt16, false, f);
  v.files.push_back(path);
  const std::int32_t mu_scaling = at(88);
  char name[41] = {};
  std::memcpy(name, h + 128, 40);
  std::string sample_name(name);
  while (!sample_name.empty() && (sample_name.back() == ' ' || sample_name.back() == '\0')) sample_name.pop_back();
  v.source_info = {{"format", "Scanco ISQ"},
                   {"dim_p", {dim_p[0], dim_p[1], dim_p[2]}},
                   {"dim_um", {dim_um[0], dim_um[1], dim_um[2]}},
                   {"slice_thickness_um", thickness_um},
                   {"slice_increment_um", increment_um},
                   {"slice_1_pos_um", at(76)},
                   {"mu_scaling", mu_scaling},
                   {"data_range", {at(80), at(84)}},
                   {"measurement_index", at(112)},
                   {"name", sample_name},
                   {"header_bytes", header_bytes},
                   {"frame", "x, y as stored, z along the slices; origin 0"}};
  if (mu_scaling > 0) v.source_info["attenuation_per_grey_1_per_cm"] = 1.0 / mu_scaling;
  return v;
}

}  // namespace burrbench::data_schema::import
