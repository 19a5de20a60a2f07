// DICOM series through GDCM: files → series by UID → slices along the normal → volume.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <map>
#include <set>

#include <fmt/format.h>
#include <gdcmByteValue.h>
#include <gdcmDataSet.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmPixelFormat.h>
#include <gdcmReader.h>
#include <gdcmStringFilter.h>
#include <gdcmTag.h>
#include <gdcmTrace.h>
#include <gdcmTransferSyntax.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"
#include "import/volume_decode.hpp"

namespace burrbench::data_schema::import {
namespace {
namespace fs = std::filesystem;
using namespace detail;

const gdcm::Tag kSeriesUid(0x0020, 0x000e), kSeriesDescription(0x0008, 0x103e), kModality(0x0008, 0x0060),
    kPosition(0x0020, 0x0032), kOrientation(0x0020, 0x0037), kPixelSpacing(0x0028, 0x0030),
    kRows(0x0028, 0x0010), kColumns(0x0028, 0x0011), kSamples(0x0028, 0x0002), kFrames(0x0028, 0x0008),
    kBitsAllocated(0x0028, 0x0100), kPixelRepresentation(0x0028, 0x0103), kSlope(0x0028, 0x1053),
    kIntercept(0x0028, 0x1052), kRescaleType(0x0028, 0x1054), kSliceThickness(0x0018, 0x0050),
    kSpacingBetween(0x0018, 0x0088), kPixelData(0x7fe0, 0x0010), kPhotometric(0x0028, 0x0004);

// One file's header, as far as the volume needs it.
struct Slice {
  fs::path file;
  std::string series_uid, description, modality, photometric, rescale_type, transfer_syntax;
  std::optional<glm::dvec3> position;
  std::optional<std::array<double, 6>> orientation;
  std::optional<std::array<double, 2>> pixel_spacing;  // row spacing (along columns), column spacing
  std::size_t rows = 0, columns = 0;
  int bits_allocated = 0, pixel_representation = 0;
  double slope = 1, intercept = 0;
  std::optional<double> slice_thickness, spacing_between;
  double along = 0;  // position along the series' normal
};

void quiet_gdcm() {
  gdcm::Trace::SetDebug(false);
  gdcm::Trace::SetWarning(false);
  gdcm::Trace::SetError(false);
}

std::string value(const gdcm::StringFilter& sf, const gdcm::DataSet& ds, const gdcm::Tag& t) {
  if (!ds.FindDataElement(t) || ds.GetDataElement(t).IsEmpty()) return {};
  std::string s = sf.ToString(t);
  // DICOM pads strings to an even length with a space or NUL.
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  return trim(s);
}

std::vector<double> numbers(const std::string& s, const std::string& file, const std::string& field, std::size_t count) {
  std::vector<double> out;
  std::size_t start = 0;
  while (true) {
    const std::size_t end = s.find('\\', start);
    const auto d = to_double(trim(s.substr(start, end == std::string::npos ? std::string::npos : end - start)));
    if (!d) throw InputError(file, field, fmt::format("{} backslash-separated finite numbers", count), "'" + s + "'");
    out.push_back(*d);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  if (out.size() != count) throw InputError(file, field, fmt::format("{} numbers", count), fmt::format("{} ('{}')", out.size(), s));
  return out;
}

std::optional<double> number(const std::string& s, const std::string& file, const std::string& field) {
  if (s.empty()) return std::nullopt;
  return numbers(s, file, field, 1)[0];
}

std::size_t count_field(const std::string& s, const std::string& file, const std::string& field, std::size_t lo, std::size_t hi) {
  const auto v = to_int(s);
  if (!v || *v < static_cast<long long>(lo) || *v > static_cast<long long>(hi))
    throw InputError(file, field, fmt::format("an integer {}..{}", lo, hi), s.empty() ? "nothing" : "'" + s + "'");
  return static_cast<std::size_t>(*v);
}

// Debian builds GDCM with assertions on: some damaged files (a header cut inside an
// element) end in assert() → abort() rather than an error. So each file is first read,
// pixels decoded, in a forked child; a child that dies marks the file as damaged.
bool gdcm_survives(const fs::path& file) {
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return true;  // cannot probe: read it in-process
  if (pid == 0) {
    const QuietStderr quiet;
    int rc = 1;
    try {
      gdcm::ImageReader r;
      r.SetFileName(file.c_str());
      if (r.Read()) {
        const gdcm::Image& img = r.GetImage();
        std::vector<char> buf(img.GetBufferLength());
        img.GetBuffer(buf.data());
      }
      rc = 0;  // a clean failure is the in-process reader's to report
    } catch (...) {
      rc = 0;
    }
    ::_exit(rc);
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return true;
  }
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

Slice read_header(const fs::path& file, const ImportLimits& lim) {
  const std::string f = file.string();
  const ReadingFile reading(f);
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) throw InputError(f, "<file>", "a readable DICOM file", ec.message());
  if (size > lim.max_bytes) throw InputError(f, "<file>", fmt::format("a file within the memory budget of {} bytes", lim.max_bytes), fmt::format("{} bytes", size));
  if (!gdcm_survives(file))
    throw InputError(f, "<file>", "a DICOM file GDCM can parse", "a damaged file (cut short or corrupt: the parser stopped on it)");
  gdcm::Reader reader;
  reader.SetFileName(f.c_str());
  bool ok = false;
  try {
    const QuietStderr quiet;
    ok = reader.ReadUpToTag(kPixelData);
  } catch (const std::exception& e) {
    throw InputError(f, "<file>", "a DICOM file GDCM can parse", e.what());
  }
  if (!ok) throw InputError(f, "<file>", "a DICOM file GDCM can parse", "an unreadable or damaged header");
  const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
  gdcm::StringFilter sf;
  sf.SetFile(reader.GetFile());
  Slice s;
  s.file = file;
  s.transfer_syntax = reader.GetFile().GetHeader().GetDataSetTransferSyntax().GetString();
  s.series_uid = value(sf, ds, kSeriesUid);
  s.description = value(sf, ds, kSeriesDescription);
  s.modality = value(sf, ds, kModality);
  s.photometric = value(sf, ds, kPhotometric);
  s.rescale_type = value(sf, ds, kRescaleType);
  if (!ds.FindDataElement(kPixelData)) throw InputError(f, "PixelData (7FE0,0010)", "an image (pixel data)", "none");
  if (const std::string v = value(sf, ds, kPosition); !v.empty()) {
    const auto p = numbers(v, f, "ImagePositionPatient (0020,0032)", 3);
    s.position = glm::dvec3(p[0], p[1], p[2]);
  }
  if (const std::string v = value(sf, ds, kOrientation); !v.empty()) {
    const auto o = numbers(v, f, "ImageOrientationPatient (0020,0037)", 6);
    s.orientation = std::array<double, 6>{o[0], o[1], o[2], o[3], o[4], o[5]};
  }
  if (const std::string v = value(sf, ds, kPixelSpacing); !v.empty()) {
    const auto p = numbers(v, f, "PixelSpacing (0028,0030)", 2);
    if (!(p[0] > 0 && p[1] > 0)) throw InputError(f, "PixelSpacing (0028,0030)", "two positive spacings (mm)", v);
    s.pixel_spacing = std::array<double, 2>{p[0], p[1]};
  }
  s.rows = count_field(value(sf, ds, kRows), f, "Rows (0028,0010)", 1, 65535);
  s.columns = count_field(value(sf, ds, kColumns), f, "Columns (0028,0011)", 1, 65535);
  if (const std::string v = value(sf, ds, kSamples); count_field(v.empty() ? "1" : v, f, "SamplesPerPixel (0028,0002)", 1, 4) != 1)
    throw InputError(f, "SamplesPerPixel (0028,0002)", "1 (a greyscale image)", v);
  if (const std::string v = value(sf, ds, kFrames); !v.empty() && count_field(v, f, "NumberOfFrames (0028,0008)", 1, 1u << 20) != 1)
    throw InputError(f, "NumberOfFrames (0028,0008)", "1 (a series of single-frame slices; convert a multi-frame file with 3D Slicer to NRRD)", v);
  s.bits_allocated = static_cast<int>(count_field(value(sf, ds, kBitsAllocated), f, "BitsAllocated (0028,0100)", 1, 64));
  if (s.bits_allocated != 8 && s.bits_allocated != 16)
    throw InputError(f, "BitsAllocated (0028,0100)", "8 or 16", std::to_string(s.bits_allocated));
  if (const std::string v = value(sf, ds, kPixelRepresentation); !v.empty())
    s.pixel_representation = static_cast<int>(count_field(v, f, "PixelRepresentation (0028,0103)", 0, 1));
  if (!s.photometric.empty() && s.photometric != "MONOCHROME1" && s.photometric != "MONOCHROME2")
    throw InputError(f, "PhotometricInterpretation (0028,0004)", "MONOCHROME1 or MONOCHROME2", s.photometric);
  if (const auto v = number(value(sf, ds, kSlope), f, "RescaleSlope (0028,1053)")) {
    if (*v == 0) throw InputError(f, "RescaleSlope (0028,1053)", "a non-zero slope", "0");
    s.slope = *v;
  }
  if (const auto v = number(value(sf, ds, kIntercept), f, "RescaleIntercept (0028,1052)")) s.intercept = *v;
  s.slice_thickness = number(value(sf, ds, kSliceThickness), f, "SliceThickness (0018,0050)");
  s.spacing_between = number(value(sf, ds, kSpacingBetween), f, "SpacingBetweenSlices (0018,0088)");
  return s;
}

// Decoded pixels of one slice (rows × columns, column index fastest), rescaled.
void read_pixels(const Slice& s, float* dst) {
  const std::string f = s.file.string();
  const ReadingFile reading(f);
  gdcm::ImageReader reader;
  reader.SetFileName(f.c_str());
  std::vector<char> buf;
  gdcm::PixelFormat pf;
  try {
    const QuietStderr quiet;
    // GDCM pads pixel data cut short by the end of the file and only warns ("Incomplete
    // Pixel Data found"): its warnings are caught for the read, and that one refuses the file.
    std::ostringstream warnings;
    gdcm::Trace::SetWarningStream(warnings);
    gdcm::Trace::SetWarning(true);
    const bool read_ok = reader.Read();
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetWarningStream(std::cerr);
    if (!read_ok) throw InputError(f, "PixelData (7FE0,0010)", "pixel data GDCM can read", "an unreadable or damaged file");
    if (warnings.str().find("Incomplete Pixel Data") != std::string::npos)
      throw InputError(f, "PixelData (7FE0,0010)", fmt::format("{} bytes of pixels", s.rows * s.columns * (s.bits_allocated / 8)),
                       "fewer: the file ends inside them (truncated)");
    const gdcm::Image& img = reader.GetImage();
    pf = img.GetPixelFormat();
    const unsigned int* d = img.GetDimensions();
    if (img.GetNumberOfDimensions() < 2 || d[0] != s.columns || d[1] != s.rows || (img.GetNumberOfDimensions() > 2 && d[2] != 1))
      throw InputError(f, "PixelData (7FE0,0010)", fmt::format("one {}x{} frame", s.columns, s.rows), "another size");
    const std::size_t expected = s.rows * s.columns * (s.bits_allocated / 8);
    const gdcm::DataSet& ds = reader.GetFile().GetDataSet();
    if (ds.FindDataElement(kPixelData)) {
      // Native (not encapsulated) pixel data must hold the whole frame: GDCM would pad it.
      if (const gdcm::ByteValue* bv = ds.GetDataElement(kPixelData).GetByteValue(); bv && bv->GetLength() < expected)
        throw InputError(f, "PixelData (7FE0,0010)", fmt::format("{} bytes for {}x{} {}-bit pixels", expected, s.columns, s.rows, s.bits_allocated),
                         fmt::format("{} bytes (truncated)", bv->GetLength()));
    }
    if (img.GetBufferLength() != expected)
      throw InputError(f, "PixelData (7FE0,0010)", fmt::format("{} bytes of pixels", expected), fmt::format("{}", img.GetBufferLength()));
    buf.resize(expected);
    if (!img.GetBuffer(buf.data()))
      throw InputError(f, "PixelData (7FE0,0010)",
                       fmt::format("pixel data that decodes ({})", gdcm::TransferSyntax::GetTSString(img.GetTransferSyntax())),
                       "truncated or corrupt data");
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(f, "PixelData (7FE0,0010)", "pixel data GDCM can decode", e.what());
  }
  const std::size_t n = s.rows * s.columns;
  const auto put = [&](auto tag) {
    using T = decltype(tag);
    for (std::size_t i = 0; i < n; ++i) {
      T v;
      std::memcpy(&v, buf.data() + i * sizeof(T), sizeof(T));
      dst[i] = static_cast<float>(s.slope * static_cast<double>(v) + s.intercept);
    }
  };
  switch (pf.GetScalarType()) {
    case gdcm::PixelFormat::UINT8: put(std::uint8_t{}); break;
    case gdcm::PixelFormat::INT8: put(std::int8_t{}); break;
    case gdcm::PixelFormat::UINT16: put(std::uint16_t{}); break;
    case gdcm::PixelFormat::INT16: put(std::int16_t{}); break;
    default:
      throw InputError(f, "BitsAllocated (0028,0100)", "8- or 16-bit integer pixels", pf.GetScalarTypeAsString());
  }
}

std::vector<fs::path> expand(const std::vector<fs::path>& inputs) {
  std::vector<fs::path> files;
  std::error_code ec;
  if (inputs.empty()) throw InputError("<command line>", "DICOM", "a folder or a list of DICOM files");
  for (const auto& in : inputs) {
    if (fs::is_directory(in, ec)) {
      if (inputs.size() != 1) throw InputError(in.string(), "<folder>", "one folder, or a list of files (not both)");
      std::vector<std::string> names;
      for (const auto& e : fs::directory_iterator(in, ec)) {
        const std::string name = e.path().filename().string();
        if (!e.is_regular_file() || name.empty() || name[0] == '.' || lower(name) == "dicomdir") continue;
        names.push_back(name);
      }
      if (ec) throw InputError(in.string(), "<folder>", "a readable folder", ec.message());
      std::sort(names.begin(), names.end(), natural_less);
      for (const auto& n : names) files.push_back(in / n);
      if (files.empty()) throw InputError(in.string(), "<folder>", "DICOM files", "none");
    } else if (fs::is_regular_file(in, ec)) {
      files.push_back(in);
    } else {
      throw InputError(in.string(), "<file>", "an existing DICOM file or folder");
    }
  }
  return files;
}

std::string describe(const std::vector<Slice>& series, const std::string& uid) {
  std::size_t n = 0;
  std::string desc;
  for (const auto& s : series) {
    if (s.series_uid != uid) continue;
    if (!n) desc = s.description.empty() ? s.modality : s.modality + " '" + s.description + "'";
    ++n;
  }
  return fmt::format("{} ({} file{}{})", uid.empty() ? "<no SeriesInstanceUID>" : uid, n, n == 1 ? "" : "s", desc.empty() ? "" : ", " + desc);
}

}  // namespace

bool looks_like_dicom(const fs::path& file) {
  const std::string ext = lower(file.extension().string());
  if (ext == ".dcm" || ext == ".dicom" || ext == ".ima") return true;
  std::ifstream in(file, std::ios::binary);
  char magic[132] = {};
  if (!in.read(magic, sizeof magic)) return false;
  return std::memcmp(magic + 128, "DICM", 4) == 0;
}

namespace {

// The series read: the only one, or the one --dicom-series names. The other series' files
// go to `set_aside`.
std::vector<Slice> choose_series(std::vector<Slice>& all, const DicomOptions& opt, const std::string& where,
                                 std::string& uid, std::vector<fs::path>& set_aside) {
  std::set<std::string> uids;
  for (const auto& s : all) uids.insert(s.series_uid);
  uid = opt.series_uid;
  const auto list = [&] {
    std::string l;
    for (const auto& u : uids) l += (l.empty() ? "" : "; ") + describe(all, u);
    return l;
  };
  if (uid.empty()) {
    if (uids.size() > 1)
      throw InputError(where, "SeriesInstanceUID (0020,000E)", "one series, or --dicom-series UID choosing one of: " + list(),
                       fmt::format("{} series", uids.size()));
    uid = *uids.begin();
  } else if (!uids.count(uid)) {
    throw InputError(where, "SeriesInstanceUID (0020,000E)", "the series " + uid + " given by --dicom-series among: " + list());
  }
  std::vector<Slice> slices;
  for (auto& s : all) {
    if (s.series_uid == uid) slices.push_back(std::move(s));
    else set_aside.push_back(s.file);
  }
  return slices;
}

// Every slice like the first: size, pixel type, geometry tags, orientation, spacing.
void check_like_first(const std::vector<Slice>& slices, const DicomOptions& opt) {
  const Slice& first = slices.front();
  const std::string f0 = first.file.string();
  for (const auto& s : slices) {
    const std::string f = s.file.string();
    if (s.rows != first.rows || s.columns != first.columns)
      throw InputError(f, "Rows/Columns", fmt::format("{}x{} like {}", first.columns, first.rows, f0), fmt::format("{}x{}", s.columns, s.rows));
    if (s.bits_allocated != first.bits_allocated || s.pixel_representation != first.pixel_representation)
      throw InputError(f, "BitsAllocated/PixelRepresentation", fmt::format("{}-bit {} like {}", first.bits_allocated,
                       first.pixel_representation ? "signed" : "unsigned", f0), fmt::format("{}-bit {}", s.bits_allocated, s.pixel_representation ? "signed" : "unsigned"));
    if (s.position.has_value() != first.position.has_value() || s.orientation.has_value() != first.orientation.has_value())
      throw InputError(f, "ImagePositionPatient/ImageOrientationPatient", "the same geometry tags in every slice, like " + f0);
    if (s.orientation) {
      for (int i = 0; i < 6; ++i)
        if (std::abs((*s.orientation)[static_cast<std::size_t>(i)] - (*first.orientation)[static_cast<std::size_t>(i)]) > 1e-4)
          throw InputError(f, "ImageOrientationPatient (0020,0037)", "the orientation of " + f0 + " (one stack of parallel slices)");
    }
    if (!opt.spacing_mm) {
      if (s.pixel_spacing.has_value() != first.pixel_spacing.has_value() ||
          (s.pixel_spacing && (std::abs((*s.pixel_spacing)[0] - (*first.pixel_spacing)[0]) > 1e-6 * (*first.pixel_spacing)[0] ||
                               std::abs((*s.pixel_spacing)[1] - (*first.pixel_spacing)[1]) > 1e-6 * (*first.pixel_spacing)[1])))
        throw InputError(f, "PixelSpacing (0028,0030)", "the pixel spacing of " + f0);
    }
  }
}

struct Directions {
  glm::dvec3 row{1, 0, 0}, column{0, 1, 0}, normal{0, 0, 1};
};

// The slices' directions from the first's orientation, and the slices sorted along the
// normal.
Directions sort_along_normal(std::vector<Slice>& slices) {
  const Slice& first = slices.front();
  const std::string f0 = first.file.string();
  Directions d;
  // Directions: row direction r (along a row, i.e. increasing column index = x index),
  // column direction c (increasing row index = y index), normal n = r × c.
  glm::dvec3& r = d.row;
  glm::dvec3& c = d.column;
  if (first.orientation) {
    const auto& o = *first.orientation;
    r = {o[0], o[1], o[2]};
    c = {o[3], o[4], o[5]};
    if (std::abs(glm::length(r) - 1) > 1e-3 || std::abs(glm::length(c) - 1) > 1e-3 || std::abs(glm::dot(r, c)) > 1e-3)
      throw InputError(f0, "ImageOrientationPatient (0020,0037)", "two orthogonal unit vectors",
                       fmt::format("({},{},{}) and ({},{},{})", r.x, r.y, r.z, c.x, c.y, c.z));
    r = glm::normalize(r);
    c = glm::normalize(c);
  }
  d.normal = glm::normalize(glm::cross(r, c));
  const glm::dvec3& n = d.normal;
  if (slices.size() > 1 && !first.position)
    throw InputError(f0, "ImagePositionPatient (0020,0032)", "a position in every slice of a series of several");
  if (first.position)
    for (auto& s : slices) s.along = glm::dot(*s.position, n);
  std::stable_sort(slices.begin(), slices.end(), [](const Slice& a, const Slice& b) { return a.along < b.along; });
  return d;
}

// The mean gap of several slices, checked even (within opt.gap_tolerance) and stacked
// along the normal (within opt.lateral_tolerance of a pixel); its range into `geometry`.
double even_slice_gap(const std::vector<Slice>& slices, const glm::dvec3& n, const glm::dvec3& spacing,
                      const DicomOptions& opt, nlohmann::json& geometry) {
  const Slice& first = slices.front();
  const double gap = (slices.back().along - slices.front().along) / double(slices.size() - 1);
  double min_gap = gap, max_gap = gap, worst_dev = -1;
  std::size_t worst = 1;
  for (std::size_t i = 1; i < slices.size(); ++i) {
    const double g = slices[i].along - slices[i - 1].along;
    if (std::abs(g) <= 1e-6 * std::max(1.0, std::abs(gap)))
      throw InputError(slices[i].file.string(), "ImagePositionPatient (0020,0032)",
                       "one slice per position (a series with several images at one place, e.g. echoes or phases, "
                       "needs its files listed)", "the same position as " + slices[i - 1].file.string());
    if (std::abs(g - gap) > worst_dev) {
      worst_dev = std::abs(g - gap);
      worst = i;
    }
    min_gap = std::min(min_gap, g);
    max_gap = std::max(max_gap, g);
  }
  if (max_gap - gap > opt.gap_tolerance * gap || gap - min_gap > opt.gap_tolerance * gap)
    throw InputError(slices[worst].file.string(), "ImagePositionPatient (0020,0032)",
                     fmt::format("evenly spaced slices (every gap within {:g} % of the mean {:.6g} mm; resample the series in "
                                 "3D Slicer first)", 100 * opt.gap_tolerance, gap),
                     fmt::format("gaps from {:.6g} to {:.6g} mm", min_gap, max_gap));
  const double pixel = first.pixel_spacing ? std::min(spacing.x, spacing.y) : gap;
  for (const auto& s : slices) {
    const glm::dvec3 d = *s.position - *slices.front().position;
    const glm::dvec3 lateral = d - glm::dot(d, n) * n;
    if (glm::length(lateral) > opt.lateral_tolerance * pixel)
      throw InputError(s.file.string(), "ImagePositionPatient (0020,0032)",
                       fmt::format("slices stacked along the normal of ImageOrientationPatient (within {:g} of a pixel; a "
                                   "gantry-tilted series must be resampled in 3D Slicer first)", opt.lateral_tolerance),
                       fmt::format("a tilt of {:.3g}° ({:.4g} mm sideways over {:.4g} mm)",
                                   std::atan2(glm::length(lateral), std::abs(glm::dot(d, n))) * 180 / M_PI,
                                   glm::length(lateral), std::abs(glm::dot(d, n))));
  }
  geometry["slice_gap_mm"] = {{"mean", gap}, {"min", min_gap}, {"max", max_gap}};
  return gap;
}

// The voxel spacing: the pixel spacing and the slices' gap (or the single slice's
// spacing tags), unless --spacing-mm gives it. How it was found goes into `geometry`.
glm::dvec3 voxel_spacing(const std::vector<Slice>& slices, const glm::dvec3& n, const DicomOptions& opt,
                         const std::string& where, nlohmann::json& geometry) {
  const Slice& first = slices.front();
  const std::string f0 = first.file.string();
  glm::dvec3 spacing{0, 0, 0};
  if (first.pixel_spacing) spacing = {(*first.pixel_spacing)[1], (*first.pixel_spacing)[0], 0};
  if (slices.size() > 1) {
    spacing.z = even_slice_gap(slices, n, spacing, opt, geometry);
  } else if (first.spacing_between && *first.spacing_between > 0) {
    spacing.z = *first.spacing_between;
    geometry["slice_spacing_from"] = "SpacingBetweenSlices";
  } else if (first.slice_thickness && *first.slice_thickness > 0) {
    spacing.z = *first.slice_thickness;
    geometry["slice_spacing_from"] = "SliceThickness";
  }
  if (opt.spacing_mm) {
    for (int i = 0; i < 3; ++i)
      if (!((*opt.spacing_mm)[i] > 0) || !std::isfinite((*opt.spacing_mm)[i]))
        throw InputError(where, "spacing", "3 positive finite spacings (mm)");
    spacing = *opt.spacing_mm;
    geometry["spacing_given"] = true;
  }
  if (!(spacing.x > 0 && spacing.y > 0))
    throw InputError(f0, "PixelSpacing (0028,0030)", "a pixel spacing (or --spacing-mm sx,sy,sz)", "none");
  if (!(spacing.z > 0))
    throw InputError(f0, "SliceThickness (0018,0050)", "a slice spacing for a single slice (SpacingBetweenSlices, SliceThickness or --spacing-mm)", "none");
  return spacing;
}

nlohmann::json dicom_source_info(const std::vector<Slice>& slices, const std::string& uid,
                                 const nlohmann::json& geometry) {
  const Slice& first = slices.front();
  std::set<std::string> syntaxes;
  for (const auto& s : slices) syntaxes.insert(s.transfer_syntax);
  nlohmann::json rescale = nlohmann::json::array();
  std::set<std::pair<double, double>> seen;
  for (const auto& s : slices)
    if (seen.insert({s.slope, s.intercept}).second) rescale.push_back({{"slope", s.slope}, {"intercept", s.intercept}});
  return {{"format", "DICOM"},
          {"series_uid", uid},
          {"modality", first.modality},
          {"series_description", first.description},
          {"slices", slices.size()},
          {"transfer_syntaxes", syntaxes},
          {"rescale", rescale},
          {"rescale_type", first.rescale_type},
          {"photometric", first.photometric},
          {"frame", first.position ? "DICOM patient (LPS), as the file states it" : "none in the file: origin 0, axes as stored"},
          {"geometry", geometry}};
}

}  // namespace

ImageVolume read_dicom(const std::vector<fs::path>& inputs, const DicomOptions& opt, const ImportLimits& lim) {
  quiet_gdcm();
  const std::vector<fs::path> files = expand(inputs);
  const std::string where = inputs.size() == 1 ? inputs[0].string() : files[0].string();
  std::vector<Slice> all;
  all.reserve(files.size());
  for (const auto& f : files) all.push_back(read_header(f, lim));

  std::string uid;
  std::vector<fs::path> set_aside;  // the other series' files, opened to learn their UIDs
  std::vector<Slice> slices = choose_series(all, opt, where, uid, set_aside);
  check_like_first(slices, opt);
  const Directions d = sort_along_normal(slices);
  const Slice& first = slices.front();
  const std::string f0 = first.file.string();
  nlohmann::json geometry = nlohmann::json::object();
  const glm::dvec3 spacing = voxel_spacing(slices, d.normal, opt, where, geometry);

  ImageVolume v;
  v.dims = {first.columns, first.rows, slices.size()};
  bool identity_rescale = true;
  for (const auto& s : slices) identity_rescale = identity_rescale && s.slope == 1 && s.intercept == 0;
  const VoxelType raw = first.bits_allocated == 8 ? VoxelType::kUint8 : first.pixel_representation ? VoxelType::kInt16 : VoxelType::kUint16;
  const std::size_t count = checked_voxel_count(v.dims, raw, lim, where, "Rows x Columns x slices");
  v.source_type = identity_rescale && !(first.bits_allocated == 8 && first.pixel_representation) ? raw : VoxelType::kFloat32;
  v.values.resize(count);
  const std::size_t per_slice = first.rows * first.columns;
  for (std::size_t z = 0; z < slices.size(); ++z) {
    read_pixels(slices[z], v.values.data() + z * per_slice);
    v.files.push_back(slices[z].file);
  }
  v.set_aside = std::move(set_aside);
  const glm::dvec3 origin = first.position ? *slices.front().position : glm::dvec3(0, 0, 0);
  apply_axis_aligned(v, {d.row * spacing.x, d.column * spacing.y, d.normal * spacing.z}, origin, f0, "ImageOrientationPatient (0020,0037)");

  v.source_info = dicom_source_info(slices, uid, geometry);
  return v;
}

}  // namespace burrbench::data_schema::import
