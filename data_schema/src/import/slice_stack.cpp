// TIFF/PNG slice stacks through OpenCV imgcodecs, and the by-extension dispatcher.
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <string_view>

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

// The decoders a slice may reach: OpenCV picks its decoder by the file's content, not its
// name, and would hand any other signature to one of a dozen more (a file with "DICM" at
// byte 128 reached GDCM, whose assert aborts the process: fuzz_slices, issue 59). BMP is
// SkyScan's own slice format.
bool slice_signature_ok(const std::filesystem::path& p, bool bmp) {
  std::ifstream in(p, std::ios::binary);
  char m[8] = {};
  in.read(m, sizeof m);
  const std::string_view s(m, static_cast<std::size_t>(in.gcount()));
  const auto starts = [&](std::string_view magic) { return s.substr(0, magic.size()) == magic; };
  using namespace std::string_view_literals;
  return starts("\x89PNG\r\n\x1a\n"sv) || starts("II*\0"sv) || starts("MM\0*"sv) || starts("II+\0"sv) ||
         starts("MM\0+"sv) || (bmp && starts("BM"sv));
}

cv::Mat read_slice(const std::filesystem::path& p, bool bmp) {
  const ReadingFile reading(p.string());  // names it if memory runs out
  if (!slice_signature_ok(p, bmp))
    throw InputError(p.string(), "image", bmp ? "a BMP, TIFF or PNG file" : "a TIFF or PNG file",
                     "a file whose first bytes are neither's signature");
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

namespace {

// Slices (already in z order) → volume; every slice like the first.
ImageVolume stack_from_files(const std::filesystem::path& folder, const std::vector<std::string>& names,
                             const ImportLimits& lim, const char* what, bool bmp) {
  cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
  ImageVolume v;
  int depth = -1;
  for (std::size_t z = 0; z < names.size(); ++z) {
    const auto p = folder / names[z];
    cv::Mat m = read_slice(p, bmp);
    v.files.push_back(p);
    if (m.empty()) throw InputError(p.string(), "image", fmt::format("a readable 8/16-bit {}", what), "an unreadable or corrupt file");
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

}  // namespace

ImageVolume read_slice_stack(const std::filesystem::path& folder, glm::dvec3 spacing_mm, glm::dvec3 origin_mm,
                             const ImportLimits& lim) {
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
  ImageVolume v = stack_from_files(folder, names, lim, "TIFF or PNG", false);
  v.spacing_mm = spacing_mm;
  v.origin_mm = origin_mm;
  return v;
}

// ----- SkyScan (Bruker NRecon) reconstruction folders -----
namespace {

using LogSections = std::map<std::string, std::map<std::string, std::string>>;

// The NRecon .log: "[Section]" lines, then "Key=Value" lines; ";" starts a comment line.
// A key given twice in one section with different values is contradictory.
LogSections parse_skyscan_log(const std::filesystem::path& log) {
  const std::string text = read_file_limited(log, 16u << 20);
  LogSections sections;
  std::string section;
  std::size_t line_no = 0, start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = trim(std::string_view(text).substr(start, end - start));
    start = end + 1;
    ++line_no;
    if (line.empty() || line[0] == ';') continue;
    if (line.front() == '[') {
      if (line.back() != ']') throw InputError(log.string(), fmt::format("line {}", line_no), "a [Section] header", "'" + line + "'");
      section = trim(std::string_view(line).substr(1, line.size() - 2));
      continue;
    }
    const std::size_t eq = line.find('=');
    if (eq == std::string::npos) continue;  // free text (some versions add notes): not a key
    const std::string key = trim(std::string_view(line).substr(0, eq)), value = trim(std::string_view(line).substr(eq + 1));
    auto& sec = sections[section];
    if (const auto it = sec.find(key); it != sec.end() && it->second != value)
      throw InputError(log.string(), fmt::format("[{}] {}", section, key), "one value", fmt::format("'{}' and '{}' (line {})", it->second, value, line_no));
    sec[key] = value;
  }
  return sections;
}

std::optional<std::string> log_value(const LogSections& s, const std::string& section, const std::string& key) {
  const auto sec = s.find(section);
  if (sec == s.end()) return std::nullopt;
  const auto it = sec->second.find(key);
  if (it == sec->second.end()) return std::nullopt;
  return it->second;
}

std::optional<double> log_number(const LogSections& s, const std::filesystem::path& log, const std::string& section,
                                 const std::string& key) {
  const auto v = log_value(s, section, key);
  if (!v) return std::nullopt;
  const auto d = to_double(*v);
  if (!d) throw InputError(log.string(), fmt::format("[{}] {}", section, key), "a number", "'" + *v + "'");
  return d;
}

std::vector<std::filesystem::path> skyscan_logs(const std::filesystem::path& folder) {
  std::vector<std::filesystem::path> logs;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    if (!e.is_regular_file(ec) || lower(e.path().extension().string()) != ".log") continue;
    std::ifstream in(e.path(), std::ios::binary);
    std::string head(1 << 16, '\0');
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    if (head.find("[Reconstruction]") != std::string::npos) logs.push_back(e.path());
  }
  std::sort(logs.begin(), logs.end());
  return logs;
}

bool is_image_ext(const std::string& ext) {
  return ext == ".bmp" || ext == ".tif" || ext == ".tiff" || ext == ".png";
}

}  // namespace

bool is_skyscan_folder(const std::filesystem::path& folder) { return !skyscan_logs(folder).empty(); }

ImageVolume read_skyscan(const std::filesystem::path& folder, const ImportLimits& lim) {
  const auto logs = skyscan_logs(folder);
  if (logs.empty()) throw InputError(folder.string(), "<folder>", "a SkyScan reconstruction .log (with a [Reconstruction] section)", "none");
  if (logs.size() > 1)
    throw InputError(folder.string(), "<folder>", "one reconstruction .log", fmt::format("{} ({} and {})", logs.size(), logs[0].filename().string(), logs[1].filename().string()));
  const auto& log = logs[0];
  const std::string lf = log.string();
  const LogSections s = parse_skyscan_log(log);
  const std::string R = "Reconstruction";

  // Voxel size: the reconstruction's pixel size; the slice spacing is that times the section step.
  const auto pixel_um = log_number(s, log, R, "Pixel Size (um)");
  if (!pixel_um) throw InputError(lf, "[Reconstruction] Pixel Size (um)", "the reconstructed pixel size in µm", "missing");
  if (!(*pixel_um > 0)) throw InputError(lf, "[Reconstruction] Pixel Size (um)", "a positive pixel size (µm)", fmt::format("{}", *pixel_um));
  const double step = log_number(s, log, R, "Section to Section Step").value_or(1.0);
  if (!(step >= 1 && step == std::floor(step))) throw InputError(lf, "[Reconstruction] Section to Section Step", "an integer ≥ 1", fmt::format("{}", step));
  const double undersampling = log_number(s, log, R, "Undersampling factor").value_or(1.0);
  if (!(undersampling >= 1)) throw InputError(lf, "[Reconstruction] Undersampling factor", "a factor ≥ 1", fmt::format("{}", undersampling));
  if (const auto image_um = log_number(s, log, "Acquisition", "Image Pixel Size (um)")) {
    // NRecon reconstructs at the projections' pixel size times the undersampling factor.
    if (std::abs(*image_um * undersampling - *pixel_um) > 0.01 * *pixel_um)
      throw InputError(lf, "[Reconstruction] Pixel Size (um)",
                       fmt::format("[Acquisition] Image Pixel Size (um) × Undersampling factor = {:.6g} µm (within 1 %)", *image_um * undersampling),
                       fmt::format("{:.6g} µm (contradictory)", *pixel_um));
  }

  // The slices: PREFIX + section number (zero-padded to the index length) + image extension.
  const std::string prefix = log_value(s, "File name convention", "Filename Prefix").value_or("");
  const auto index_len = log_number(s, log, "File name convention", "Filename Index Length");
  std::vector<std::pair<long long, std::string>> found;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    if (!e.is_regular_file(ec)) continue;
    const std::string name = e.path().filename().string(), ext = lower(e.path().extension().string());
    if (!is_image_ext(ext)) continue;
    const std::string stem = e.path().stem().string();
    std::string digits;
    if (!prefix.empty()) {
      if (stem.size() <= prefix.size() || stem.compare(0, prefix.size(), prefix) != 0) continue;
      digits = stem.substr(prefix.size());
    } else {
      const std::size_t rec = lower(stem).rfind("_rec");
      if (rec == std::string::npos) continue;
      digits = stem.substr(rec + 4);
    }
    if (digits.empty() || !std::all_of(digits.begin(), digits.end(), [](unsigned char c) { return std::isdigit(c); })) continue;
    if (index_len && digits.size() != static_cast<std::size_t>(*index_len)) continue;
    found.emplace_back(std::stoll(digits.substr(0, 18)), name);
  }
  if (found.empty())
    throw InputError(folder.string(), "slices", fmt::format("reconstructed slices named {}<section number>.bmp/.tif/.png beside {}",
                                                           prefix.empty() ? "…_rec" : prefix, log.filename().string()), "none");
  std::sort(found.begin(), found.end());
  const auto first = log_number(s, log, R, "First Section"), last = log_number(s, log, R, "Last Section");
  const long long istep = static_cast<long long>(step);
  for (std::size_t i = 1; i < found.size(); ++i) {
    if (found[i].first == found[i - 1].first)
      throw InputError((folder / found[i].second).string(), "section number", "one slice per section", "the same as " + found[i - 1].second);
    if (found[i].first != found[i - 1].first + istep)
      throw InputError(folder.string(), "slices", fmt::format("every section from {} to {} in steps of {}", found.front().first, found.back().first, istep),
                       fmt::format("section {} missing (after {})", found[i - 1].first + istep, found[i - 1].second));
  }
  if (first && last && (found.front().first != static_cast<long long>(*first) || found.back().first != static_cast<long long>(*last)))
    throw InputError(lf, "[Reconstruction] First Section/Last Section", fmt::format("slices {}..{} as the log states", *first, *last),
                     fmt::format("slices {}..{} in the folder", found.front().first, found.back().first));
  std::vector<std::string> names;
  for (const auto& f : found) names.push_back(f.second);
  ImageVolume v = stack_from_files(folder, names, lim, "BMP, TIFF or PNG slice", true);
  const auto width = log_number(s, log, R, "Result Image Width (pixels)"), height = log_number(s, log, R, "Result Image Height (pixels)");
  if ((width && *width != double(v.dims[0])) || (height && *height != double(v.dims[1])))
    throw InputError(lf, "[Reconstruction] Result Image Width/Height (pixels)", fmt::format("the slices' {}x{}", v.dims[0], v.dims[1]),
                     fmt::format("{}x{}", width.value_or(0), height.value_or(0)));
  v.files.insert(v.files.begin(), log);
  v.spacing_mm = glm::dvec3(*pixel_um / 1000, *pixel_um / 1000, *pixel_um * step / 1000);
  v.origin_mm = {0, 0, 0};
  nlohmann::json info = {{"format", "SkyScan reconstruction"},
                         {"log", lf},
                         {"pixel_size_um", *pixel_um},
                         {"section_step", step},
                         {"sections", {found.front().first, found.back().first}},
                         {"frame", "x along a slice's rows, y down its columns, z with the section number; origin 0"}};
  const auto cs_min = log_number(s, log, R, "Minimum for CS to Image Conversion"), cs_max = log_number(s, log, R, "Maximum for CS to Image Conversion");
  if (cs_min && cs_max) {
    if (!(*cs_max > *cs_min))
      throw InputError(lf, "[Reconstruction] Maximum for CS to Image Conversion", fmt::format("a value above the minimum {}", *cs_min), fmt::format("{}", *cs_max));
    const double full = v.source_type == VoxelType::kUint8 ? 255.0 : 65535.0;
    info["attenuation_range"] = {*cs_min, *cs_max};
    info["attenuation_per_grey"] = (*cs_max - *cs_min) / full;
    info["attenuation_note"] = "attenuation = min + grey/(2^bits - 1)·(max - min), NRecon's units";
  }
  if (const auto scanner = log_value(s, "System", "Scanner")) info["scanner"] = *scanner;
  v.source_info = info;
  return v;
}

namespace {

bool folder_holds_dicom(const std::filesystem::path& folder) {
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(folder, ec)) {
    if (e.is_regular_file(ec) && looks_like_dicom(e.path())) return true;
  }
  return false;
}

void check_spacing(const std::string& where, const glm::dvec3& s) {
  for (int i = 0; i < 3; ++i) {
    if (!(s[i] > 0) || !std::isfinite(s[i])) throw InputError(where, "spacing", "3 positive finite spacings (mm)");
  }
}

}  // namespace

ImageVolume read_volume(const std::vector<std::filesystem::path>& paths, const ReadOptions& opt, const ImportLimits& lim) {
  if (paths.empty()) throw InputError("<command line>", "<volume>", "a volume file or folder");
  const std::filesystem::path& path = paths.front();
  if (opt.spacing_mm) check_spacing(path.string(), *opt.spacing_mm);
  std::error_code ec;
  const bool folder = std::filesystem::is_directory(path, ec);
  if (paths.size() > 1 || (folder && folder_holds_dicom(path)) || (!folder && looks_like_dicom(path))) {
    DicomOptions d;
    d.series_uid = opt.dicom_series;
    d.spacing_mm = opt.spacing_mm;
    return read_dicom(paths, d, lim);
  }
  if (!opt.dicom_series.empty()) throw InputError(path.string(), "--dicom-series", "a DICOM file or folder with it");
  if (folder && is_skyscan_folder(path)) {
    ImageVolume v = read_skyscan(path, lim);
    if (opt.spacing_mm) v.spacing_mm = *opt.spacing_mm;
    return v;
  }
  if (folder) {
    if (!opt.spacing_mm) throw InputError(path.string(), "spacing", "--spacing-mm sx,sy,sz for a slice stack");
    return read_slice_stack(path, *opt.spacing_mm, {0, 0, 0}, lim);
  }
  ImageVolume v;
  const std::string ext = lower(path.extension().string());
  if (ext == ".nrrd" || ext == ".nhdr") v = read_nrrd(path, lim);
  else if (ext == ".mha" || ext == ".mhd") v = read_metaimage(path, lim);
  else if (ext.rfind(".isq", 0) == 0 || is_isq(path)) v = read_isq(path, lim);  // "C0001234.ISQ;1" too
  else throw InputError(path.string(), "<file>", "a .nrrd/.nhdr/.mha/.mhd/.dcm/.isq file or a folder of slices, DICOM files or a SkyScan reconstruction", "'" + ext + "'");
  if (opt.spacing_mm) v.spacing_mm = *opt.spacing_mm;
  return v;
}

ImageVolume read_volume(const std::filesystem::path& path, std::optional<glm::dvec3> spacing_mm, const ImportLimits& lim) {
  ReadOptions opt;
  opt.spacing_mm = spacing_mm;
  return read_volume(std::vector<std::filesystem::path>{path}, opt, lim);
}

}  // namespace burrbench::data_schema::import
