#include "hdf5/h5_common.hpp"

#include "burrbench/data_schema/error.hpp"
#include "format_common.hpp"

namespace burrbench::data_schema::h5 {

namespace {
constexpr std::uint64_t kMaxListed = 1u << 20;  // input files / strings we accept in a list
}

void write_header(Writer& w, const char* format, int major, int minor, const Provenance& prov) {
  const Provenance p = detail::stamped(prov);
  w.attr("/", "format", std::string(format));
  w.attr("/", "format_version", version_string(major, minor));
  w.group("/provenance");
  w.attr("/provenance", "software_version", p.software_version);
  w.attr("/provenance", "command_line", p.command_line);
  w.attr("/provenance", "created_utc", p.created_utc);
  write_files(w, "/provenance/inputs", p.inputs);
}

std::string check_header(const Reader& r, const char* format, int major) {
  check_format(r.file(), "/@format", r.attr_string("/", "format"), format);
  const std::string v = r.attr_string("/", "format_version");
  check_version(r.file(), "/@format_version", v, major);
  return v;
}

Provenance read_provenance(const Reader& r) {
  r.expect_only("/provenance", {"inputs"});
  Provenance p;
  p.software_version = r.attr_string("/provenance", "software_version");
  p.command_line = r.attr_string("/provenance", "command_line");
  p.created_utc = r.attr_string("/provenance", "created_utc");
  p.inputs = read_files(r, "/provenance/inputs");
  return p;
}

void write_files(Writer& w, const std::string& group, const std::vector<InputFile>& files) {
  w.group(group);
  std::vector<std::string> paths, hashes;
  for (const auto& f : files) {
    paths.push_back(f.path);
    hashes.push_back(f.sha256);
  }
  w.strings(group + "/path", paths);
  w.strings(group + "/sha256", hashes);
}

std::vector<InputFile> read_files(const Reader& r, const std::string& group) {
  r.expect_only(group, {"path", "sha256"});
  const auto paths = r.read_strings(group + "/path", kMaxListed);
  const auto hashes = r.read_strings(group + "/sha256", kMaxListed);
  if (paths.size() != hashes.size())
    throw InputError(r.file(), group + "/sha256", std::to_string(paths.size()) + " strings (one per path)",
                     std::to_string(hashes.size()));
  std::vector<InputFile> out;
  for (std::size_t i = 0; i < paths.size(); ++i) {
    const auto& h = hashes[i];
    bool hex = h.size() == 64;
    for (char c : h) hex = hex && ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'));
    if (!hex)
      throw InputError(r.file(), group + "/sha256[" + std::to_string(i) + "]",
                       "64 lowercase hex digits", "\"" + h + "\"");
    out.push_back({paths[i], h});
  }
  return out;
}

}  // namespace burrbench::data_schema::h5
