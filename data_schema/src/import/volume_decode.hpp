#pragma once
// Internals shared by the NRRD and MetaImage readers: size budget, file reading, gzip /
// zlib inflation, sample decoding and folding of axis-aligned direction matrices.
#include <array>
#include <filesystem>
#include <string>
#include <string_view>

#include <glm/glm.hpp>

#include "burrbench/data_schema/import/volume.hpp"

namespace burrbench::data_schema::import::detail {

// dims product and byte sizes, refused (InputError on `field`) when above the budget or
// when any dimension is zero.
std::size_t checked_voxel_count(const std::array<std::size_t, 3>& dims, VoxelType t,
                                const ImportLimits& lim, const std::string& file,
                                const std::string& field);

// Whole file, refused when larger than max_bytes (InputError naming the file).
std::string read_file_limited(const std::filesystem::path& p, std::size_t max_bytes);

// Reads a header file (within the budget plus 1 MiB of header slack) and parses it with
// a reader for the detached data files it names (relative to the header's folder, same
// budget); the volume lists every file read. The NRRD and MetaImage `read_*` entry points.
using HeaderParser = ImageVolume (*)(std::string_view bytes, const std::string& file_for_messages,
                                     const DataFileReader& data_file, const ImportLimits& lim);
ImageVolume read_header_and_data(const std::filesystem::path& path, const ImportLimits& lim, HeaderParser parse);

// Inflates a gzip or zlib stream (auto-detected) into exactly `expected` bytes; a stream
// that ends early or is corrupt → InputError naming the file.
std::string inflate_exact(std::string_view compressed, std::size_t expected,
                          const std::string& file);

// Raw samples (little or big endian) → floats; NaN/Inf in float data → InputError.
std::vector<float> decode_samples(std::string_view raw, std::size_t count, VoxelType t,
                                  bool big_endian, const std::string& file);

// Given per-axis direction vectors (already scaled by spacing) and the origin of voxel 0,
// reorders/flips `v.values` so index axes run along +x,+y,+z, and sets spacing/origin.
// Non-axis-aligned directions → InputError on `field`.
void apply_axis_aligned(ImageVolume& v, const std::array<glm::dvec3, 3>& directions,
                        glm::dvec3 origin, const std::string& file, const std::string& field);

// Silences file descriptor 2 for its lifetime. Codec libraries (libpng through OpenCV,
// GDCM's JPEG/JPEG 2000 decoders) print warnings on stderr that change no pixel: they
// would add lines to our one-line messages. Real failures still come back as values or
// exceptions, which the callers turn into InputError.
class QuietStderr {
 public:
  QuietStderr();
  ~QuietStderr();
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_ = -1;
};

// Natural order of file names: "s2.tif" < "s10.tif" (digit runs compare as numbers).
bool natural_less(const std::string& a, const std::string& b);

std::string trim(std::string_view s);
std::string lower(std::string_view s);
// Strict number parsing: whole token, finite. nullopt otherwise.
std::optional<double> to_double(std::string_view s);
std::optional<long long> to_int(std::string_view s);

}  // namespace burrbench::data_schema::import::detail
