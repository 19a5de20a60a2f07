// TIFF/PNG slice stacks through OpenCV imgcodecs, and the by-extension dispatcher.
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>
#include <opencv2/core.hpp>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/imgcodecs.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "import/volume_decode.hpp"

namespace burrbench::data_schema::import {
namespace {
using namespace detail;

// "s2.tif" < "s10.tif": digit runs compare as numbers, the rest byte-wise.
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

// libpng's default warning handler prints "libpng warning: ..." on stderr, and OpenCV
// installs none: a damaged ancillary chunk (a text comment) would add lines to our one-line
// messages. Such warnings change no pixel, so stderr is silenced while a slice is decoded;
// real failures still come back as an empty image or a cv::Exception.
class QuietStderr {
 public:
  QuietStderr() {
    std::fflush(stderr);
    saved_ = ::dup(2);
    const int null = ::open("/dev/null", O_WRONLY | O_CLOEXEC);
    if (saved_ >= 0 && null >= 0) ::dup2(null, 2);
    if (null >= 0) ::close(null);
  }
  ~QuietStderr() {
    if (saved_ < 0) return;
    ::dup2(saved_, 2);
    ::close(saved_);
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  int saved_ = -1;
};

cv::Mat read_slice(const std::filesystem::path& p) {
  const ReadingFile reading(p.string());  // names it if memory runs out
  try {
    const QuietStderr quiet;
    // imread returns the first page of a multi-page TIFF: the other slices would vanish.
    if (const std::size_t pages = cv::imcount(p.string()); pages > 1)
      throw InputError(p.string(), "pages",
                       "one image per slice file (a multi-page TIFF holds a whole stack: save it as one "
                       "file per slice, or as NRRD)",
                       fmt::format("{} pages", pages));
    return cv::imread(p.string(), cv::IMREAD_UNCHANGED);
  } catch (const cv::Exception& e) {
    throw InputError(p.string(), "image", "a readable 8/16-bit TIFF or PNG", e.what());
  }
}

}  // namespace

ImageVolume read_slice_stack(const std::filesystem::path& folder, glm::dvec3 spacing_mm, glm::dvec3 origin_mm,
                             const ImportLimits& lim) {
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  std::error_code ec;
  if (!std::filesystem::is_directory(folder, ec)) throw InputError(folder.string(), "<folder>", "a folder of TIFF/PNG slices");
  for (int i = 0; i < 3; ++i) {
    if (!(spacing_mm[i] > 0) || !std::isfinite(spacing_mm[i])) throw InputError(folder.string(), "spacing", "3 positive spacings (mm)");
  }
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    const std::string ext = lower(e.path().extension().string());
    if (e.is_regular_file() && (ext == ".tif" || ext == ".tiff" || ext == ".png")) names.push_back(e.path().filename().string());
  }
  if (names.empty()) throw InputError(folder.string(), "<folder>", "at least one .tif/.tiff/.png slice", "none");
  std::sort(names.begin(), names.end(), natural_less);

  ImageVolume v;
  v.spacing_mm = spacing_mm;
  v.origin_mm = origin_mm;
  int depth = -1;
  for (std::size_t z = 0; z < names.size(); ++z) {
    const auto p = folder / names[z];
    cv::Mat m = read_slice(p);
    v.files.push_back(p);
    if (m.empty()) throw InputError(p.string(), "image", "a readable 8/16-bit TIFF or PNG", "an unreadable or corrupt file");
    if (m.channels() != 1) throw InputError(p.string(), "channels", "1 (greyscale)", std::to_string(m.channels()));
    if (m.depth() != CV_8U && m.depth() != CV_16U) throw InputError(p.string(), "bit depth", "8 or 16 bit unsigned");
    if (z == 0) {
      depth = m.depth();
      v.dims = {static_cast<std::size_t>(m.cols), static_cast<std::size_t>(m.rows), names.size()};
      v.source_type = depth == CV_8U ? VoxelType::kUint8 : VoxelType::kUint16;
      const std::size_t count = checked_voxel_count(v.dims, v.source_type, lim, folder.string(), "slices");
      v.values.resize(count);
    } else if (static_cast<std::size_t>(m.cols) != v.dims[0] || static_cast<std::size_t>(m.rows) != v.dims[1] || m.depth() != depth) {
      throw InputError(p.string(), "image size/type",
                       fmt::format("{}x{} {}-bit like {}", v.dims[0], v.dims[1], depth == CV_8U ? 8 : 16, names[0]),
                       fmt::format("{}x{} {}-bit", m.cols, m.rows, m.depth() == CV_8U ? 8 : 16));
    }
    cv::Mat f;
    m.convertTo(f, CV_32F);
    float* dst = v.values.data() + z * v.dims[0] * v.dims[1];
    for (int r = 0; r < f.rows; ++r) std::copy_n(f.ptr<float>(r), f.cols, dst + static_cast<std::size_t>(r) * v.dims[0]);
  }
  return v;
}

ImageVolume read_volume(const std::filesystem::path& path, std::optional<glm::dvec3> spacing_mm, const ImportLimits& lim) {
  std::error_code ec;
  ImageVolume v;
  if (std::filesystem::is_directory(path, ec)) {
    if (!spacing_mm) throw InputError(path.string(), "spacing", "--spacing-mm sx,sy,sz for a slice stack");
    return read_slice_stack(path, *spacing_mm, {0, 0, 0}, lim);
  }
  const std::string ext = lower(path.extension().string());
  if (ext == ".nrrd" || ext == ".nhdr") v = read_nrrd(path, lim);
  else if (ext == ".mha" || ext == ".mhd") v = read_metaimage(path, lim);
  else throw InputError(path.string(), "<file>", "a .nrrd/.nhdr/.mha/.mhd file or a folder of slices", "'" + ext + "'");
  if (spacing_mm) {
    for (int i = 0; i < 3; ++i) {
      if (!((*spacing_mm)[i] > 0) || !std::isfinite((*spacing_mm)[i])) throw InputError(path.string(), "spacing", "3 positive finite spacings (mm)");
    }
    v.spacing_mm = *spacing_mm;
  }
  return v;
}

}  // namespace burrbench::data_schema::import
