// Sample volume: validator, HDF5 writer and reader. Layout (docs/formats.md):
//   /@format, /@format_version, /@voxel_size_mm, /@origin_mm, /labels [nz][ny][nx] uint8,
//   /fraction [nz][ny][nx] float32 | uint8 (@encoding), /classes/{id,name},
//   /sources/{path,sha256}, /segmentation_json, /provenance.
#include "burrbench/data_schema/sample_volume.hpp"

#include <cmath>
#include <set>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/error.hpp"
#include "format_common.hpp"
#include "hdf5/h5.hpp"
#include "hdf5/h5_common.hpp"

namespace burrbench::data_schema {

namespace {

constexpr std::uint64_t kMaxClassesStored = kMaxClassId;
constexpr std::uint64_t kMaxTextBytes = 16ull << 20;

void check_dims(const std::string& file, const std::string& field, const std::array<std::size_t, 3>& d) {
  const std::string got = fmt::format("{}×{}×{}", d[0], d[1], d[2]);
  if (d[0] == 0 || d[1] == 0 || d[2] == 0) throw InputError(file, field, "dims > 0", got);
  std::uint64_t n = 1;
  for (std::size_t x : d) {
    if (x > kMaxSampleVoxels || n * x > kMaxSampleVoxels)
      throw InputError(file, field,
                       fmt::format("at most {} voxels (4 GiB memory budget)", kMaxSampleVoxels), got);
    n *= x;
  }
}

void check_classes(const std::string& file, const std::map<std::uint8_t, std::string>& classes) {
  std::set<std::string> names;
  for (const auto& [id, name] : classes) {
    const std::string f = fmt::format("/classes[{}]", int(id));
    if (id == kEmpty) throw InputError(file, f, "class ids 1..255 (0 means empty)", "0");
    if (name.empty()) throw InputError(file, f, "a class name", "empty");
    if (!names.insert(name).second) throw InputError(file, f, "unique class names", "\"" + name + "\" twice");
  }
}

void check_geometry(const std::string& file, double voxel_mm, const glm::dvec3& origin) {
  if (!std::isfinite(voxel_mm) || voxel_mm <= 0)
    throw InputError(file, "/@voxel_size_mm", "a finite voxel size > 0 mm", fmt::format("{}", voxel_mm));
  if (!std::isfinite(origin.x) || !std::isfinite(origin.y) || !std::isfinite(origin.z))
    throw InputError(file, "/@origin_mm", "a finite origin", "NaN/Inf");
}

std::string voxel_field(const SampleVolume& v, const char* ds, std::size_t i) {
  const std::size_t x = i % v.dims[0], y = (i / v.dims[0]) % v.dims[1], z = i / (v.dims[0] * v.dims[1]);
  return fmt::format("/{}[z={}][y={}][x={}]", ds, z, y, x);
}

}  // namespace

void validate(const SampleVolume& v, const std::string& file) {
  check_dims(file, "/labels", v.dims);
  check_geometry(file, v.voxel_mm, v.origin_mm);
  check_classes(file, v.classes);
  const std::size_t n = v.voxel_count();
  if (v.labels.size() != n)
    throw InputError(file, "/labels", fmt::format("{} voxels", n), std::to_string(v.labels.size()));
  if (v.fraction.size() != n)
    throw InputError(file, "/fraction", fmt::format("{} voxels", n), std::to_string(v.fraction.size()));
  std::array<bool, 256> known{};
  known[kEmpty] = true;
  for (const auto& [id, name] : v.classes) known[id] = true;
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint8_t l = v.labels[i];
    const float chi = v.fraction[i];
    if (!known[l])
      throw InputError(file, voxel_field(v, "labels", i), "0 or a label of the class table", std::to_string(l));
    if (!(chi >= 0.0f && chi <= 1.0f))
      throw InputError(file, voxel_field(v, "fraction", i), "a bone fraction in [0, 1]", fmt::format("{}", chi));
    if (l == kEmpty && chi != 0.0f)
      throw InputError(file, voxel_field(v, "fraction", i), "0 where the label is 0 (empty)",
                       fmt::format("{}", chi));
  }
  if (!v.segmentation_json.empty() && !nlohmann::json::accept(v.segmentation_json))
    throw InputError(file, "/segmentation_json", "JSON text", "unparsable");
}

void write_sample(const std::filesystem::path& path, const SampleVolume& v, FractionEncoding enc) {
  validate(v, path.string());
  h5::Writer w(path);
  h5::write_header(w, kSampleFormat, kSampleVersionMajor, kSampleVersionMinor, v.provenance);
  w.attr("/", "voxel_size_mm", v.voxel_mm);
  w.attr("/", "origin_mm", std::vector<double>{v.origin_mm.x, v.origin_mm.y, v.origin_mm.z});
  const std::vector<hsize_t> shape{v.dims[2], v.dims[1], v.dims[0]};
  w.dataset("/labels", shape, v.labels.data(), true);
  if (enc == FractionEncoding::kFloat32) {
    w.dataset("/fraction", shape, v.fraction.data(), true);
    w.attr("/fraction", "encoding", std::string("float32"));
  } else {
    std::vector<std::uint8_t> counter(v.fraction.size());
    for (std::size_t i = 0; i < counter.size(); ++i)
      counter[i] = static_cast<std::uint8_t>(std::lround(double(v.fraction[i]) * 255.0));
    w.dataset("/fraction", shape, counter.data(), true);
    w.attr("/fraction", "encoding", std::string("counter255"));
  }
  w.group("/classes");
  std::vector<std::uint8_t> ids;
  std::vector<std::string> names;
  for (const auto& [id, name] : v.classes) {
    ids.push_back(id);
    names.push_back(name);
  }
  w.dataset("/classes/id", {hsize_t(ids.size())}, ids.data());
  w.strings("/classes/name", names);
  h5::write_files(w, "/sources", v.sources);
  w.string("/segmentation_json", v.segmentation_json.empty() ? std::string("{}") : v.segmentation_json);
  w.commit();
}

namespace {

SampleHeader read_header(const h5::Reader& r) {
  SampleHeader h;
  h.format_version = h5::check_header(r, kSampleFormat, kSampleVersionMajor);
  r.expect_only("/", {"provenance", "labels", "fraction", "classes", "sources", "segmentation_json"});
  h.voxel_mm = r.attr_double("/", "voxel_size_mm");
  const auto o = r.attr_doubles("/", "origin_mm", 3);
  h.origin_mm = {o[0], o[1], o[2]};
  check_geometry(r.file(), h.voxel_mm, h.origin_mm);
  const auto ls = r.shape("/labels", h5::Elem::kUInt8);
  if (ls.size() != 3)
    throw InputError(r.file(), "/labels", "a 3-D uint8 dataset [nz][ny][nx]", fmt::format("rank {}", ls.size()));
  h.dims = {std::size_t(ls[2]), std::size_t(ls[1]), std::size_t(ls[0])};
  check_dims(r.file(), "/labels", h.dims);
  const std::string enc = r.attr_string("/fraction", "encoding");
  if (enc == "float32")
    h.encoding = FractionEncoding::kFloat32;
  else if (enc == "counter255")
    h.encoding = FractionEncoding::kCounter8;
  else
    throw InputError(r.file(), "/fraction/@encoding", "\"float32\" or \"counter255\"", "\"" + enc + "\"");
  const auto fs = r.shape("/fraction", h.encoding == FractionEncoding::kFloat32 ? h5::Elem::kFloat32
                                                                                 : h5::Elem::kUInt8);
  if (fs != ls)
    throw InputError(r.file(), "/fraction", fmt::format("the shape of /labels [{}×{}×{}]", ls[0], ls[1], ls[2]),
                     fs.size() == 3 ? fmt::format("[{}×{}×{}]", fs[0], fs[1], fs[2]) : fmt::format("rank {}", fs.size()));
  r.expect_only("/classes", {"id", "name"});
  std::vector<hsize_t> shape;
  const auto ids = r.read<std::uint8_t>("/classes/id", h5::Elem::kUInt8, &shape, kMaxClassesStored);
  const auto names = r.read_strings("/classes/name", kMaxClassesStored);
  if (shape.size() != 1 || names.size() != ids.size())
    throw InputError(r.file(), "/classes", "1-D id and name datasets of equal length");
  for (std::size_t i = 0; i < ids.size(); ++i)
    if (!h.classes.emplace(ids[i], names[i]).second)
      throw InputError(r.file(), fmt::format("/classes/id[{}]", i), "unique class ids", std::to_string(ids[i]));
  check_classes(r.file(), h.classes);
  return h;
}

}  // namespace

SampleHeader read_sample_header(const std::filesystem::path& path) {
  h5::Reader r(path);
  return read_header(r);
}

namespace {
SampleVolume read_sample_from(const h5::Reader& r);
}  // namespace

SampleVolume read_sample(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  return read_sample_from(h5::Reader(path));
}

SampleVolume read_sample_image(std::string_view image, const std::string& name) {
  const ReadingFile reading(name);
  return read_sample_from(h5::Reader(image, name));
}

namespace {
SampleVolume read_sample_from(const h5::Reader& r) {
  const SampleHeader h = read_header(r);  // dims within budget before any allocation
  SampleVolume v;
  v.dims = h.dims;
  v.voxel_mm = h.voxel_mm;
  v.origin_mm = h.origin_mm;
  v.classes = h.classes;
  v.labels = r.read<std::uint8_t>("/labels", h5::Elem::kUInt8, nullptr, kMaxSampleVoxels);
  if (h.encoding == FractionEncoding::kFloat32) {
    v.fraction = r.read<float>("/fraction", h5::Elem::kFloat32, nullptr, kMaxSampleVoxels);
  } else {
    const auto counter = r.read<std::uint8_t>("/fraction", h5::Elem::kUInt8, nullptr, kMaxSampleVoxels);
    v.fraction.resize(counter.size());
    for (std::size_t i = 0; i < counter.size(); ++i) v.fraction[i] = static_cast<float>(counter[i]) / 255.0f;
  }
  v.sources = h5::read_files(r, "/sources");
  v.segmentation_json = r.read_string("/segmentation_json", kMaxTextBytes);
  v.provenance = h5::read_provenance(r);
  validate(v, r.file());
  return v;
}
}  // namespace

}  // namespace burrbench::data_schema
