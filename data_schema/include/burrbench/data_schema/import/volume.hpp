#pragma once
// Grey or label volumes read from the formats labs already have (NRRD, MetaImage,
// TIFF/PNG slice stacks). Geometry convention everywhere: origin_mm is the CENTRE of the
// first voxel (index 0,0,0), spacing_mm the distance between voxel centres per axis, both
// in the file's own world frame (no LPS/RAS conversion). Axis-aligned direction matrices
// (permutations and flips) are folded into the data so that index axes follow +x,+y,+z;
// rotated (non-axis-aligned) directions are refused.
#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/sample_volume.hpp"

namespace burrbench::data_schema::import {

enum class VoxelType { kUint8, kInt16, kUint16, kFloat32 };
const char* to_string(VoxelType t);
std::size_t byte_size(VoxelType t);

// Memory budget: a decoded volume (stored as float32) may not exceed max_bytes. Headers
// that claim more are refused before anything is allocated.
inline constexpr std::size_t kDefaultBudgetBytes = std::size_t{2} << 30;  // 2 GiB
struct ImportLimits {
  std::size_t max_bytes = kDefaultBudgetBytes;
};

struct ImageVolume {
  std::array<std::size_t, 3> dims{0, 0, 0};  // nx, ny, nz (x fastest in `values`)
  glm::dvec3 spacing_mm{1, 1, 1};
  glm::dvec3 origin_mm{0, 0, 0};             // centre of voxel (0,0,0)
  VoxelType source_type = VoxelType::kFloat32;
  std::vector<float> values;                 // every supported type is exact in float32
  std::vector<std::filesystem::path> files;  // every file read (header, data file, slices)
  // Files opened while reading but not part of the volume (a DICOM folder's other series):
  // not in the provenance, yet inputs all the same, which no output may replace.
  std::vector<std::filesystem::path> set_aside;
  nlohmann::json source_info = nlohmann::json::object();  // what the reader learnt (DICOM series,
                                             // rescale, SkyScan/ISQ keys): into provenance
  std::size_t voxel_count() const { return dims[0] * dims[1] * dims[2]; }
  std::size_t index(std::size_t x, std::size_t y, std::size_t z) const {
    return x + dims[0] * (y + dims[1] * z);
  }
  bool is_integer() const { return source_type != VoxelType::kFloat32; }
};

// Reads a detached data file named in a header (path relative to the header's folder).
// Must throw InputError when it cannot (the fuzzers pass one that always refuses).
using DataFileReader = std::function<std::string(const std::string& name)>;

// NRRD (.nrrd attached, .nhdr detached): raw or gzip, uint8/int16/uint16/float32.
ImageVolume read_nrrd(const std::filesystem::path& path, const ImportLimits& = {});
ImageVolume parse_nrrd(std::string_view bytes, const std::string& file_for_messages,
                       const DataFileReader& data_file, const ImportLimits& = {});

// MetaImage (.mha attached, .mhd + .raw/.zraw), same types.
ImageVolume read_metaimage(const std::filesystem::path& path, const ImportLimits& = {});
ImageVolume parse_metaimage(std::string_view bytes, const std::string& file_for_messages,
                            const DataFileReader& data_file, const ImportLimits& = {});

// A folder of 8/16-bit single-channel TIFF/PNG slices (one per z, sorted by name with
// digit runs compared as numbers), read through OpenCV, with the given spacing.
ImageVolume read_slice_stack(const std::filesystem::path& folder, glm::dvec3 spacing_mm,
                             glm::dvec3 origin_mm = {0, 0, 0}, const ImportLimits& = {});

// A DICOM series through GDCM (docs/importers.md, "DICOM"). `inputs`: one folder (its
// regular files, not recursing; DICOMDIR and dot files skipped) or a list of files. The
// series is chosen by SeriesInstanceUID (`series_uid`; needed when the files hold more
// than one, and the refusal lists them); slices are ordered by their position along the
// slice normal, whatever the file names or InstanceNumbers; spacing comes from
// PixelSpacing and the positions, which must be evenly spaced (every gap within
// `gap_tolerance` of the mean gap) and on one line along the normal (no gantry tilt:
// every slice within `lateral_tolerance` of the smallest pixel size); RescaleSlope and
// RescaleIntercept of each slice are applied. Every transfer syntax GDCM decodes is read
// (raw little/big endian, RLE, JPEG baseline/extended/lossless, JPEG-LS, JPEG 2000).
// Geometry in the patient frame (LPS) as the file states it, folded like any volume.
struct DicomOptions {
  std::string series_uid;                 // empty: the files must hold one series
  std::optional<glm::dvec3> spacing_mm;   // overrides the file's (also: a single slice's z)
  double gap_tolerance = 0.01;            // of the mean gap between slices
  double lateral_tolerance = 0.05;        // of the smallest in-plane pixel size
};
ImageVolume read_dicom(const std::vector<std::filesystem::path>& inputs, const DicomOptions& = {},
                       const ImportLimits& = {});
// True for a file that starts with the DICOM preamble ("DICM" at byte 128) or is named
// *.dcm / *.dicom / *.ima.
bool looks_like_dicom(const std::filesystem::path& file);

// A Bruker SkyScan (NRecon) reconstruction folder: one .log with a [Reconstruction]
// section and the slices PREFIX<section>.bmp/.tif/.png (8 or 16 bit). Voxel size from
// [Reconstruction] "Pixel Size (um)" (× "Section to Section Step" along z), checked against
// [Acquisition] "Image Pixel Size (um)" × "Undersampling factor"; every section between the
// first and last present; the grey→attenuation range ("Minimum/Maximum for CS to Image
// Conversion") recorded in source_info. Origin 0, z along the section number.
ImageVolume read_skyscan(const std::filesystem::path& folder, const ImportLimits& = {});
bool is_skyscan_folder(const std::filesystem::path& folder);

// A Scanco ISQ file (header "CTDATA-HEADER_V1", 512 bytes, little-endian int32 fields, as
// ITK's ScancoImageIO reads it; 16-bit signed data from (data_offset + 1)·512 bytes).
// Voxel size = dim_um / dim_p per axis; origin 0; mu_scaling recorded (value/mu_scaling =
// linear attenuation in 1/cm).
ImageVolume read_isq(const std::filesystem::path& path, const ImportLimits& = {});
bool is_isq(const std::filesystem::path& path);  // starts with "CTDATA-HEADER_V1"

// What the readers below may need beyond the path.
struct ReadOptions {
  std::optional<glm::dvec3> spacing_mm;  // overrides the file's spacing (required for a slice stack)
  std::string dicom_series;              // DICOM: the SeriesInstanceUID to read
};

// By extension: .nrrd/.nhdr → NRRD, .mha/.mhd → MetaImage, .dcm (or a file with the DICOM
// preamble) → DICOM; a folder → DICOM when it holds DICOM files, else a TIFF/PNG slice
// stack (then `spacing_mm` is required). Several paths → a DICOM series from those files.
// `spacing_mm`, when given, overrides the file's spacing.
ImageVolume read_volume(const std::vector<std::filesystem::path>& paths, const ReadOptions& opt,
                        const ImportLimits& = {});
ImageVolume read_volume(const std::filesystem::path& path,
                        std::optional<glm::dvec3> spacing_mm = std::nullopt,
                        const ImportLimits& = {});

enum class Interpolation { kTrilinear, kNearest };
// Resamples onto cubic voxels of side voxel_mm (> 0), keeping the origin (centre of the
// first voxel) and covering the same span of voxel centres.
ImageVolume resample_cubic(const ImageVolume& in, double voxel_mm, Interpolation,
                           const ImportLimits& = {});
bool is_cubic(const ImageVolume& v, double rel_tol = 1e-6);

// A sample at another voxel size, for solution verification and coarse-to-fine fits.
// split_voxels: every voxel becomes n³ voxels of side l/n with its label and χ (the same
// bone, exactly: per-class volume and every surface are kept). merge_voxels: blocks of n³
// voxels (the volume padded with empty voxels to a multiple of n) become one voxel of
// side n·l holding their mean χ, labelled with the class that has the most bone in the
// block (ties: the lower label). The total bone volume is kept exactly; where classes meet
// inside a block, bone moves to the majority class. Both keep the covered region: the
// first output voxel's corner is the input's first corner. n ≥ 1; InputError if the
// result would exceed the sample memory budget.
SampleVolume split_voxels(const SampleVolume& in, int n);
SampleVolume merge_voxels(const SampleVolume& in, int n);
// The voxels [lo, hi) per axis (x, y, z), with their labels and χ as they are and the
// origin moved to the first one's centre: the same bone where the box reaches. lo < hi ≤
// dims (InvariantError otherwise).
SampleVolume crop_voxels(const SampleVolume& in, const std::array<std::size_t, 3>& lo,
                         const std::array<std::size_t, 3>& hi);

// Writes a NRRD (attached, gzip) that 3D Slicer opens: "space: left-posterior-superior"
// is NOT claimed; the volume frame is written as "3D-right-handed".
// `key_values` become NRRD "key:=value" lines (newlines in values are escaped as \n).
void write_nrrd(const std::filesystem::path& path, const ImageVolume& v, VoxelType type,
                const std::vector<std::pair<std::string, std::string>>& key_values = {});

}  // namespace burrbench::data_schema::import
