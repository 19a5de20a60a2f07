#pragma once
// A CT-derived sample: per-voxel class label and bone fraction χ on a cubic grid.
// Stored as HDF5 (format "burrbench.sample"). Index order: x fastest, then y, then z
// (HDF5 dataset shape [nz][ny][nx], as NRRD stores it).
#include <array>
#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema {

inline constexpr const char* kSampleFormat = "burrbench.sample";
inline constexpr int kSampleVersionMajor = 1;
inline constexpr int kSampleVersionMinor = 0;

inline constexpr std::uint8_t kEmpty = 0;
inline constexpr std::uint8_t kCompact = 1;
inline constexpr std::uint8_t kTrabecular = 2;
// Class ids are labels of a uint8 volume: 1..255 in every format (0 is empty space). The
// model replays fewer (model::kMaxClasses) and says so when a sample holds more.
inline constexpr int kMaxClassId = 255;
// How many class labels the model works with: 0..7 (0 empty), the one definition of that
// count. model::kMaxClasses (its per-label arrays), calibration's kLabels and the prediction
// file's per-class records (kPredictionClasses) all name this; it sits here, in the lowest
// folder, because the prediction format needs it and data_schema uses nothing of ours.
inline constexpr int kModelClassLabels = 8;

// How χ is stored on disk: float32, or the paper's 8-bit counter χ = n/255
// (written as round(255·χ); read back as float(n)/255.0f).
enum class FractionEncoding { kFloat32, kCounter8 };

struct SampleVolume {
  std::array<std::size_t, 3> dims{0, 0, 0};  // nx, ny, nz
  double voxel_mm = 0;                        // cubic voxel side l
  glm::dvec3 origin_mm{0, 0, 0};              // centre of voxel (0,0,0), volume frame
  std::vector<std::uint8_t> labels;           // class id per voxel (0 = empty)
  std::vector<float> fraction;                // χ ∈ [0,1] per voxel
  std::map<std::uint8_t, std::string> classes{{1, "compact"}, {2, "trabecular"}};
  std::vector<InputFile> sources;             // files it was made from
  std::string segmentation_json;              // settings used, as JSON text ("{}" if none)
  Provenance provenance;

  std::size_t voxel_count() const { return dims[0] * dims[1] * dims[2]; }
  std::size_t index(std::size_t x, std::size_t y, std::size_t z) const {
    return x + dims[0] * (y + dims[1] * z);
  }
  glm::dvec3 centre_mm(std::size_t x, std::size_t y, std::size_t z) const {
    return origin_mm + voxel_mm * glm::dvec3(double(x), double(y), double(z));
  }
};

// Memory budget for a sample in memory (labels 1 B + χ 4 B per voxel ≤ 4 GiB): larger
// volumes are refused from the file header, before anything is allocated.
inline constexpr std::uint64_t kSampleMemoryBudgetBytes = 4ull << 30;
inline constexpr std::uint64_t kMaxSampleVoxels = kSampleMemoryBudgetBytes / 5;

// What the file header says, without reading the voxel arrays (cheap; for `inspect`,
// manifests and budget checks). Checks format, version, dims and the budget.
struct SampleHeader {
  std::array<std::size_t, 3> dims{0, 0, 0};
  double voxel_mm = 0;
  glm::dvec3 origin_mm{0, 0, 0};
  std::map<std::uint8_t, std::string> classes;
  FractionEncoding encoding = FractionEncoding::kFloat32;
  std::string format_version;
};
SampleHeader read_sample_header(const std::filesystem::path& path);

void validate(const SampleVolume& v, const std::string& file_for_messages);
void write_sample(const std::filesystem::path& path, const SampleVolume& v,
                  FractionEncoding enc = FractionEncoding::kFloat32);
SampleVolume read_sample(const std::filesystem::path& path);  // validates
// The same from an HDF5 file image in memory; `name` stands for the file in messages.
SampleVolume read_sample_image(std::string_view image, const std::string& name);

}  // namespace burrbench::data_schema
