#include "hdf5/h5.hpp"

#include <fcntl.h>
#include <malloc.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <functional>
#include <mutex>
#include <set>
#include <tuple>
#include <cstring>
#include <stdexcept>
#include <system_error>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema::h5 {

Handle& Handle::operator=(Handle&& o) noexcept {
  if (this != &o) {
    reset();
    id_ = o.id_;
    close_ = o.close_;
    o.id_ = -1;
  }
  return *this;
}

void Handle::reset() {
  if (id_ >= 0 && close_) close_(id_);
  id_ = -1;
}

namespace {
// HDF5 closes itself at exit; after a read of a corrupt file it may be unable to release
// some cached metadata and then prints "infinite loop closing library" to stderr. Our
// writers always close their files explicitly, so we let the OS reclaim the rest.
void init_library() {
  static const bool done = [] {
    H5dont_atexit();
    H5open();
    return true;
  }();
  (void)done;
}
}  // namespace

bool is_hdf5(const std::filesystem::path& path) {
  init_library();
  ErrorSilencer quiet;
  return H5Fis_hdf5(path.string().c_str()) > 0;
}

ErrorSilencer::ErrorSilencer() {
  init_library();
  H5Eget_auto2(H5E_DEFAULT, &old_func_, &old_data_);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
}
ErrorSilencer::~ErrorSilencer() { H5Eset_auto2(H5E_DEFAULT, old_func_, old_data_); }

const char* elem_name(Elem e) {
  switch (e) {
    case Elem::kInt64: return "int64";
    case Elem::kUInt16: return "uint16";
    case Elem::kUInt8: return "uint8";
    case Elem::kFloat64: return "float64";
    case Elem::kFloat32: return "float32";
  }
  BURRBENCH_UNREACHABLE();
}

namespace {

hid_t native(Elem e) {
  switch (e) {
    case Elem::kInt64: return H5T_NATIVE_INT64;
    case Elem::kUInt16: return H5T_NATIVE_UINT16;
    case Elem::kUInt8: return H5T_NATIVE_UINT8;
    case Elem::kFloat64: return H5T_NATIVE_DOUBLE;
    case Elem::kFloat32: return H5T_NATIVE_FLOAT;
  }
  BURRBENCH_UNREACHABLE();
}

template <class T> Elem elem_of();
template <> Elem elem_of<std::int64_t>() { return Elem::kInt64; }
template <> Elem elem_of<std::uint16_t>() { return Elem::kUInt16; }
template <> Elem elem_of<std::uint8_t>() { return Elem::kUInt8; }
template <> Elem elem_of<double>() { return Elem::kFloat64; }
template <> Elem elem_of<float>() { return Elem::kFloat32; }

hid_t file_type(Elem e) {
  switch (e) {
    case Elem::kInt64: return H5T_STD_I64LE;
    case Elem::kUInt16: return H5T_STD_U16LE;
    case Elem::kUInt8: return H5T_STD_U8LE;
    case Elem::kFloat64: return H5T_IEEE_F64LE;
    case Elem::kFloat32: return H5T_IEEE_F32LE;
  }
  BURRBENCH_UNREACHABLE();
}

std::string describe_type(hid_t t) {
  const H5T_class_t c = H5Tget_class(t);
  const std::size_t bits = 8 * H5Tget_size(t);
  switch (c) {
    case H5T_INTEGER:
      return fmt::format("{}int{}", H5Tget_sign(t) == H5T_SGN_NONE ? "u" : "", bits);
    case H5T_FLOAT: return fmt::format("float{}", bits);
    case H5T_STRING: return "string";
    case H5T_COMPOUND: return "compound";
    case H5T_ENUM: return "enum";
    case H5T_ARRAY: return "array";
    default: return "another type";
  }
}

// Whether HDF5 may convert a stored type to `e` without losing values.
bool convertible(hid_t t, Elem e) {
  const H5T_class_t c = H5Tget_class(t);
  const std::size_t size = H5Tget_size(t);
  const bool is_unsigned = c == H5T_INTEGER && H5Tget_sign(t) == H5T_SGN_NONE;
  switch (e) {
    case Elem::kFloat64: return c == H5T_FLOAT && size <= 8;
    case Elem::kFloat32: return c == H5T_FLOAT && size == 4;
    case Elem::kInt64: return c == H5T_INTEGER && (size < 8 || (size == 8 && !is_unsigned));
    case Elem::kUInt16: return c == H5T_INTEGER && is_unsigned && size <= 2;
    case Elem::kUInt8: return c == H5T_INTEGER && is_unsigned && size == 1;
  }
  BURRBENCH_UNREACHABLE();
}

std::string dims_text(const std::vector<hsize_t>& d) {
  if (d.empty()) return "scalar";
  std::string s = "[";
  for (std::size_t i = 0; i < d.size(); ++i) s += (i ? "×" : "") + std::to_string(d[i]);
  return s + "]";
}

Handle string_type() {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), H5T_VARIABLE);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

// We write fixed-length UTF-8 strings (NUL-terminated, size = longest + 1): variable-length
// strings live in HDF5's global heap, which has no checksum and whose corruption crashes
// libhdf5 1.10 (H5HG_read). h5py reads them as bytes (.asstr() / .decode()), MATLAB as char.
Handle fixed_string_type(std::size_t longest) {
  Handle t(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(t.get(), longest + 1);
  H5Tset_strpad(t.get(), H5T_STR_NULLTERM);
  H5Tset_cset(t.get(), H5T_CSET_UTF8);
  return t;
}

// Packs strings into one buffer of n × (longest + 1) bytes, NUL-padded. A NUL inside a
// string would silently cut it short on reading: refused (file, field named).
std::vector<char> pack(const std::vector<std::string>& values, std::size_t& longest, const std::string& file,
                       const std::string& field) {
  longest = 0;
  for (const auto& v : values) {
    if (v.find('\0') != std::string::npos) throw InputError(file, field, "text without NUL characters", "a NUL character");
    longest = std::max(longest, v.size());
  }
  std::vector<char> buf(std::max<std::size_t>(values.size(), 1) * (longest + 1), '\0');
  for (std::size_t i = 0; i < values.size(); ++i) std::memcpy(buf.data() + i * (longest + 1), values[i].data(), values[i].size());
  return buf;
}

std::vector<hsize_t> space_dims(hid_t space) {
  const int rank = H5Sget_simple_extent_ndims(space);
  std::vector<hsize_t> d(rank > 0 ? std::size_t(rank) : 0);
  if (rank > 0) H5Sget_simple_extent_dims(space, d.data(), nullptr);
  return d;
}

std::uint64_t product(const std::vector<hsize_t>& d, std::uint64_t cap) {
  std::uint64_t n = 1;
  for (hsize_t x : d) {
    if (x != 0 && n > cap / x) return cap + 1;  // saturate: more than anything we accept
    n *= x;
  }
  return n;
}

// Strings of an attribute: provenance, metadata, notes (a rig map is a dataset).
constexpr std::uint64_t kMaxAttrStringBytes = 16u << 20;
// All strings of one string dataset together (the per-element count is checked too).
constexpr std::uint64_t kMaxStringsBytes = 64u << 20;

// Reads a string-typed attribute or dataset (fixed or variable length) into `out`. A
// fixed-length type declares its size: more than `max_bytes` in all is refused before
// anything is allocated (a small file can declare 2 GiB strings with nothing stored).
template <class ReadFn>
bool read_string_values(hid_t type, std::size_t n, std::vector<std::string>& out, ReadFn read,
                        hid_t space, std::uint64_t max_bytes, const std::string& file, const std::string& field) {
  out.assign(n, {});
  if (n == 0) return true;
  if (H5Tis_variable_str(type) <= 0) {
    const std::uint64_t declared = H5Tget_size(type);
    if (declared > max_bytes || n > max_bytes / std::max<std::uint64_t>(declared, 1))
      throw InputError(file, field, fmt::format("strings of at most {} bytes in all", max_bytes),
                       fmt::format("{} string{} of {} bytes declared", n, n == 1 ? "" : "s", declared));
  }
  if (H5Tis_variable_str(type) > 0) {
    Handle mt = string_type();
    std::vector<char*> ptrs(n, nullptr);
    if (read(mt.get(), ptrs.data()) < 0) return false;
    // Variable length: stored in the file, so bounded by it; still held to the budget.
    std::uint64_t total = 0;
    for (std::size_t i = 0; i < n; ++i) total += ptrs[i] ? std::strlen(ptrs[i]) : 0;
    if (total <= max_bytes)
      for (std::size_t i = 0; i < n; ++i) out[i] = ptrs[i] ? ptrs[i] : "";
    H5Dvlen_reclaim(mt.get(), space, H5P_DEFAULT, ptrs.data());
    if (total > max_bytes)
      throw InputError(file, field, fmt::format("strings of at most {} bytes in all", max_bytes),
                       fmt::format("{} bytes", total));
    return true;
  }
  // Fixed length (MATLAB, Fortran): one extra byte so a NULLTERM memory type keeps all
  // characters of NULLPAD/SPACEPAD/NULLTERM file strings.
  const std::size_t size = H5Tget_size(type) + 1;
  Handle mt(H5Tcopy(type), H5Tclose);
  H5Tset_size(mt.get(), size);
  H5Tset_strpad(mt.get(), H5T_STR_NULLTERM);
  std::vector<char> buf(n * size);
  if (read(mt.get(), buf.data()) < 0) return false;
  for (std::size_t i = 0; i < n; ++i) {
    const char* s = buf.data() + i * size;
    out[i].assign(s, strnlen(s, size));
  }
  return true;
}

}  // namespace

// ---------------------------------------------------------------- structure probe

namespace {

// libhdf5 1.10 (Debian's) crashes on some corrupt files instead of failing: a group whose
// dense link storage is damaged makes H5Literate free a pointer it never allocated (SIGSEGV;
// found by bench/fuzz/fuzz_prediction_h5, issue 59). No input may crash us, so before a
// file is read in-process a forked child opens it and walks its whole structure the way
// the readers do: every object reached from the root, each group's links in creation and
// in name order, each object's attributes (values read), each dataset's type and shape
// (values read up to kProbeDataBytes). A child that does not exit normally — killed by a
// signal, aborted by the C library's heap checks (its message goes to /dev/null, not to the
// user's terminal), still walking after kProbeSeconds (a loop in a corrupt B-tree) — marks
// the file corrupt. A clean failure in the child is the in-process reader's to report, with
// its own message.
// The crash libhdf5 1.10.8 has on a damaged link heap frees entries of a link table it
// malloc'd and never filled (H5G__link_release_table after a failed decode): whether that
// aborts depends on what the heap held before, so a child walking a different heap than the
// reader's could survive a file the reader then dies on (seen: a longer file path turned a
// refusal into `free(): invalid pointer` in the Python module). The child therefore fills
// every allocation with a byte pattern (M_PERTURB): an uninitialised pointer is then never
// null and never aligned, and freeing it aborts the child every time.
constexpr unsigned kProbeSeconds = 60;
constexpr hsize_t kProbeDataBytes = hsize_t{16} << 20;
// Allocations read as the complement, 0xa5 bytes: 0xa5a5… is odd, so never a pointer malloc gave.
constexpr int kProbePerturbByte = 0x5a;

void probe_read(hid_t obj, hid_t space, hid_t ftype, bool attribute) {
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  const Handle mtype(H5Tget_native_type(ftype, H5T_DIR_DEFAULT), H5Tclose);
  if (n < 0 || !mtype.valid()) return;
  const std::size_t size = H5Tget_size(mtype.get());
  if (size == 0 || static_cast<hsize_t>(n) > kProbeDataBytes / size) return;
  std::vector<char> buf(static_cast<std::size_t>(n) * size + 16);
  if (attribute) H5Aread(obj, mtype.get(), buf.data());
  else H5Dread(obj, mtype.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data());
}

herr_t probe_attribute(hid_t loc, const char* name, const H5A_info_t*, void*) {
  const Handle a(H5Aopen(loc, name, H5P_DEFAULT), H5Aclose);
  if (!a.valid()) return 0;
  const Handle t(H5Aget_type(a.get()), H5Tclose), sp(H5Aget_space(a.get()), H5Sclose);
  if (t.valid() && sp.valid()) probe_read(a.get(), sp.get(), t.get(), true);
  return 0;
}

void probe_attributes(hid_t obj) {
  for (const H5_index_t by : {H5_INDEX_CRT_ORDER, H5_INDEX_NAME}) {
    hsize_t at = 0;
    H5Aiterate2(obj, by, H5_ITER_INC, &at, probe_attribute, nullptr);
  }
}

// A group's links in both orders (as Reader::members lists them), then every object they
// lead to, once each (by address: hard links may form cycles), at most 64 groups deep.
void probe_group(hid_t g, int depth, std::set<haddr_t>& seen) {
  std::vector<std::string> names;
  const auto collect = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->emplace_back(name);
    return 0;
  };
  for (const H5_index_t by : {H5_INDEX_CRT_ORDER, H5_INDEX_NAME}) {
    hsize_t at = 0;
    H5Literate(g, by, H5_ITER_INC, &at, collect, &names);
  }
  std::sort(names.begin(), names.end());
  names.erase(std::unique(names.begin(), names.end()), names.end());
  probe_attributes(g);
  for (const auto& name : names) {
    H5O_info_t info{};
    if (H5Oget_info_by_name2(g, name.c_str(), &info, H5O_INFO_BASIC, H5P_DEFAULT) < 0) continue;
    if (!seen.insert(info.addr).second) continue;
    const Handle o(H5Oopen(g, name.c_str(), H5P_DEFAULT), H5Oclose);
    if (!o.valid()) continue;
    if (info.type == H5O_TYPE_GROUP) {
      if (depth < 64) probe_group(o.get(), depth + 1, seen);
      continue;
    }
    probe_attributes(o.get());
    if (info.type == H5O_TYPE_DATASET) {
      const Handle t(H5Dget_type(o.get()), H5Tclose), sp(H5Dget_space(o.get()), H5Sclose);
      if (t.valid() && sp.valid()) probe_read(o.get(), sp.get(), t.get(), false);
    }
  }
}

// True when a child that opens the file with `open` (H5Fopen with the reader's access
// properties) and walks it survives; also when no child can be made (read in-process).
bool structure_survives(const std::function<hid_t()>& open) {
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid < 0) return true;
  if (pid == 0) {
    if (const int null = ::open("/dev/null", O_WRONLY); null >= 0) {
      ::dup2(null, STDOUT_FILENO);
      ::dup2(null, STDERR_FILENO);
    }
    for (const int sig : {SIGSEGV, SIGBUS, SIGILL, SIGFPE, SIGABRT, SIGALRM}) ::signal(sig, SIG_DFL);
    ::mallopt(M_PERTURB, kProbePerturbByte);
    ::alarm(kProbeSeconds);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    const hid_t f = open();
    if (f >= 0) {
      std::set<haddr_t> seen;
      const Handle root(H5Gopen2(f, "/", H5P_DEFAULT), H5Gclose);
      if (root.valid()) probe_group(root.get(), 0, seen);
    }
    ::_exit(0);  // no H5Fclose, no atexit handlers: nothing of the parent's is flushed twice
  }
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return true;
  return WIFEXITED(status) && WEXITSTATUS(status) == 0;
}

// A file probed once per process is not probed again while it stays the same file with the
// same size and modification time (a command opens its inputs several times; each probe is
// a fork, ~20 ms on a VM).
bool file_survives(const std::string& file) {
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0)
    return structure_survives([&] { return H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT); });
  using Key = std::tuple<dev_t, ino_t, off_t, std::int64_t>;
  const Key key{st.st_dev, st.st_ino, st.st_size,
                static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec};
  static std::mutex m;
  static std::set<Key> survived;
  {
    std::lock_guard lk(m);
    if (survived.count(key)) return true;
  }
  if (!structure_survives([&] { return H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT); })) return false;
  std::lock_guard lk(m);
  survived.insert(key);
  return true;
}

}  // namespace

// ---------------------------------------------------------------- Reader

Reader::Reader(const std::filesystem::path& path) : file_(path.string()) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InputError(file_, "<file>", "an existing regular file");
  if (H5Fis_hdf5(file_.c_str()) <= 0)
    throw InputError(file_, "<file>", "an HDF5 file", "no HDF5 signature");
  if (!file_survives(file_))
    throw InputError(file_, "<file>", "an HDF5 file libhdf5 can walk", "a corrupt file (the HDF5 library crashed reading its structure)");
  f_ = Handle(H5Fopen(file_.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!f_.valid())
    throw InputError(file_, "<file>", "a readable HDF5 file", "HDF5 cannot open it (truncated or corrupt?)");
}

Reader::Reader(std::string_view image, const std::string& name) : file_(name) {
  // H5Fis_hdf5 on an image: the signature at 0, 512, 1024, … (a user block before it).
  constexpr std::string_view kSignature{"\x89HDF\r\n\x1a\n", 8};
  bool signed_image = false;
  for (std::size_t at = 0; !signed_image && at + kSignature.size() <= image.size(); at = at ? 2 * at : 512)
    signed_image = image.substr(at, kSignature.size()) == kSignature;
  if (!signed_image) throw InputError(file_, "<file>", "an HDF5 file", "no HDF5 signature");
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  if (!fapl.valid() || H5Pset_fapl_core(fapl.get(), 1 << 16, 0) < 0 ||
      H5Pset_file_image(fapl.get(), const_cast<char*>(image.data()), image.size()) < 0)
    throw InputError(file_, "<file>", "an HDF5 file image HDF5 accepts", "H5Pset_file_image failed");
  if (!structure_survives([&] { return H5Fopen(file_.c_str(), H5F_ACC_RDONLY, fapl.get()); }))
    throw InputError(file_, "<file>", "an HDF5 file libhdf5 can walk", "a corrupt file (the HDF5 library crashed reading its structure)");
  f_ = Handle(H5Fopen(file_.c_str(), H5F_ACC_RDONLY, fapl.get()), H5Fclose);
  if (!f_.valid())
    throw InputError(file_, "<file>", "a readable HDF5 file", "HDF5 cannot open it (truncated or corrupt?)");
}

bool Reader::exists(const std::string& obj_path) const {
  if (obj_path == "/") return true;
  std::string partial;
  std::size_t pos = 1;
  while (pos <= obj_path.size()) {
    std::size_t next = obj_path.find('/', pos);
    if (next == std::string::npos) next = obj_path.size();
    partial = obj_path.substr(0, next);
    if (H5Lexists(f_.get(), partial.c_str(), H5P_DEFAULT) <= 0) return false;
    if (H5Oexists_by_name(f_.get(), partial.c_str(), H5P_DEFAULT) <= 0) return false;
    pos = next + 1;
  }
  return true;
}

Handle Reader::open_object(const std::string& obj_path) const {
  if (!exists(obj_path)) throw InputError(file_, obj_path, "an existing object", "missing");
  Handle o(H5Oopen(f_.get(), obj_path.c_str(), H5P_DEFAULT), H5Oclose);
  if (!o.valid()) throw InputError(file_, obj_path, "a readable object (file truncated or corrupt?)");
  return o;
}

Handle Reader::open_dataset(const std::string& ds_path) const {
  if (!exists(ds_path)) throw InputError(file_, ds_path, "a dataset", "missing");
  Handle d(H5Dopen2(f_.get(), ds_path.c_str(), H5P_DEFAULT), H5Dclose);
  if (!d.valid()) throw InputError(file_, ds_path, "a dataset", "not a readable dataset");
  return d;
}

std::vector<std::string> Reader::members(const std::string& group_path) const {
  if (!exists(group_path)) throw InputError(file_, group_path, "a group", "missing");
  Handle g(H5Gopen2(f_.get(), group_path.c_str(), H5P_DEFAULT), H5Gclose);
  if (!g.valid()) throw InputError(file_, group_path, "a group", "not a group");
  std::vector<std::string> names;
  auto collect = [](hid_t, const char* name, const H5L_info_t*, void* data) -> herr_t {
    static_cast<std::vector<std::string>*>(data)->emplace_back(name);
    return 0;
  };
  hsize_t idx = 0;
  if (H5Literate(g.get(), H5_INDEX_CRT_ORDER, H5_ITER_INC, &idx, collect, &names) < 0) {
    names.clear();
    idx = 0;
    if (H5Literate(g.get(), H5_INDEX_NAME, H5_ITER_INC, &idx, collect, &names) < 0)
      throw InputError(file_, group_path, "a readable group (file truncated or corrupt?)");
  }
  return names;
}

void Reader::expect_only(const std::string& group_path, const std::vector<std::string>& allowed) const {
  for (const auto& m : members(group_path)) {
    bool ok = false;
    for (const auto& a : allowed) ok = ok || a == m;
    if (!ok) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
      throw InputError(file_, (group_path == "/" ? "/" : group_path + "/") + m,
                       "only known members here (" + list + ")", "unknown member");
    }
  }
}

bool Reader::has_attr(const std::string& obj_path, const std::string& name) const {
  if (!exists(obj_path)) return false;
  return H5Aexists_by_name(f_.get(), obj_path.c_str(), name.c_str(), H5P_DEFAULT) > 0;
}

namespace {
std::string attr_field(const std::string& obj, const std::string& name) {
  return (obj == "/" ? "/" : obj + "/") + "@" + name;
}
}  // namespace

std::optional<std::string> Reader::attr_string_opt(const std::string& obj_path,
                                                   const std::string& name) const {
  if (!has_attr(obj_path, name)) return std::nullopt;
  return attr_string(obj_path, name);
}

std::string Reader::attr_string(const std::string& obj_path, const std::string& name) const {
  const std::string field = attr_field(obj_path, name);
  if (!has_attr(obj_path, name)) throw InputError(file_, field, "a string attribute", "missing");
  Handle a(H5Aopen_by_name(f_.get(), obj_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError(file_, field, "a readable attribute");
  Handle t(H5Aget_type(a.get()), H5Tclose);
  Handle s(H5Aget_space(a.get()), H5Sclose);
  if (H5Tget_class(t.get()) != H5T_STRING)
    throw InputError(file_, field, "a string attribute", describe_type(t.get()));
  if (H5Sget_simple_extent_npoints(s.get()) != 1)
    throw InputError(file_, field, "a single string", dims_text(space_dims(s.get())));
  std::vector<std::string> out;
  const hid_t aid = a.get();
  if (!read_string_values(t.get(), 1, out, [aid](hid_t mt, void* buf) { return H5Aread(aid, mt, buf); },
                          s.get(), kMaxAttrStringBytes, file_, field))
    throw InputError(file_, field, "a readable string attribute (file corrupt?)");
  return out[0];
}

std::vector<double> Reader::attr_doubles(const std::string& obj_path, const std::string& name,
                                         std::size_t expected_count) const {
  const std::string field = attr_field(obj_path, name);
  const std::string want = expected_count == 1 ? "a number" : fmt::format("{} numbers", expected_count);
  if (!has_attr(obj_path, name)) throw InputError(file_, field, want, "missing");
  Handle a(H5Aopen_by_name(f_.get(), obj_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError(file_, field, "a readable attribute");
  Handle t(H5Aget_type(a.get()), H5Tclose);
  Handle s(H5Aget_space(a.get()), H5Sclose);
  const H5T_class_t c = H5Tget_class(t.get());
  if (c != H5T_FLOAT && c != H5T_INTEGER) throw InputError(file_, field, want, describe_type(t.get()));
  const hssize_t n = H5Sget_simple_extent_npoints(s.get());
  if (n < 0 || std::size_t(n) != expected_count)
    throw InputError(file_, field, want, fmt::format("{} values", n));
  std::vector<double> v(expected_count);
  if (H5Aread(a.get(), H5T_NATIVE_DOUBLE, v.data()) < 0)
    throw InputError(file_, field, "a readable attribute (file corrupt?)");
  return v;
}

double Reader::attr_double(const std::string& obj_path, const std::string& name) const {
  return attr_doubles(obj_path, name, 1)[0];
}

std::int64_t Reader::attr_int64(const std::string& obj_path, const std::string& name) const {
  const std::string field = attr_field(obj_path, name);
  if (!has_attr(obj_path, name)) throw InputError(file_, field, "an int64 attribute", "missing");
  Handle a(H5Aopen_by_name(f_.get(), obj_path.c_str(), name.c_str(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!a.valid()) throw InputError(file_, field, "a readable attribute");
  Handle t(H5Aget_type(a.get()), H5Tclose);
  Handle s(H5Aget_space(a.get()), H5Sclose);
  if (!convertible(t.get(), Elem::kInt64) || H5Sget_simple_extent_npoints(s.get()) != 1)
    throw InputError(file_, field, "one int64 value", describe_type(t.get()));
  std::int64_t v = 0;
  if (H5Aread(a.get(), H5T_NATIVE_INT64, &v) < 0)
    throw InputError(file_, field, "a readable attribute (file corrupt?)");
  return v;
}

std::vector<hsize_t> Reader::shape(const std::string& ds_path, Elem e) const {
  Handle d = open_dataset(ds_path);
  Handle t(H5Dget_type(d.get()), H5Tclose);
  if (!convertible(t.get(), e))
    throw InputError(file_, ds_path, fmt::format("{} dataset", elem_name(e)), describe_type(t.get()));
  Handle s(H5Dget_space(d.get()), H5Sclose);
  return space_dims(s.get());
}

template <class T>
std::vector<T> Reader::read(const std::string& ds_path, Elem e, std::vector<hsize_t>* shape_out,
                            std::uint64_t max_elements) const {
  Handle d = open_dataset(ds_path);
  Handle t(H5Dget_type(d.get()), H5Tclose);
  if (!convertible(t.get(), e))
    throw InputError(file_, ds_path, fmt::format("{} dataset", elem_name(e)), describe_type(t.get()));
  Handle s(H5Dget_space(d.get()), H5Sclose);
  const std::vector<hsize_t> dims = space_dims(s.get());
  const std::uint64_t n = product(dims, max_elements);
  if (n > max_elements)  // refused from the header, before allocating anything
    throw InputError(file_, ds_path, fmt::format("at most {} elements (memory budget)", max_elements),
                     dims_text(dims));
  if (shape_out) *shape_out = dims;
  std::vector<T> v(n);
  if (n > 0 && H5Dread(d.get(), native(e), H5S_ALL, H5S_ALL, H5P_DEFAULT, v.data()) < 0)
    throw InputError(file_, ds_path, "readable data", "read failed (file truncated or corrupt?)");
  return v;
}

template std::vector<std::int64_t> Reader::read(const std::string&, Elem, std::vector<hsize_t>*, std::uint64_t) const;
template std::vector<std::uint16_t> Reader::read(const std::string&, Elem, std::vector<hsize_t>*, std::uint64_t) const;
template std::vector<std::uint8_t> Reader::read(const std::string&, Elem, std::vector<hsize_t>*, std::uint64_t) const;
template std::vector<double> Reader::read(const std::string&, Elem, std::vector<hsize_t>*, std::uint64_t) const;
template std::vector<float> Reader::read(const std::string&, Elem, std::vector<hsize_t>*, std::uint64_t) const;

std::vector<std::string> Reader::read_strings(const std::string& ds_path, std::uint64_t max_elements) const {
  Handle d = open_dataset(ds_path);
  Handle t(H5Dget_type(d.get()), H5Tclose);
  if (H5Tget_class(t.get()) != H5T_STRING)
    throw InputError(file_, ds_path, "a string dataset", describe_type(t.get()));
  Handle s(H5Dget_space(d.get()), H5Sclose);
  const std::vector<hsize_t> dims = space_dims(s.get());
  if (dims.size() != 1) throw InputError(file_, ds_path, "a 1-D string dataset", dims_text(dims));
  if (dims[0] > max_elements)
    throw InputError(file_, ds_path, fmt::format("at most {} strings", max_elements), dims_text(dims));
  std::vector<std::string> out;
  const hid_t did = d.get();
  if (!read_string_values(t.get(), dims[0], out,
                          [did](hid_t mt, void* buf) { return H5Dread(did, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf); },
                          s.get(), kMaxStringsBytes, file_, ds_path))
    throw InputError(file_, ds_path, "readable strings", "read failed (file truncated or corrupt?)");
  return out;
}

std::string Reader::read_string(const std::string& ds_path, std::uint64_t max_bytes) const {
  Handle d = open_dataset(ds_path);
  Handle t(H5Dget_type(d.get()), H5Tclose);
  if (H5Tget_class(t.get()) != H5T_STRING)
    throw InputError(file_, ds_path, "a string dataset", describe_type(t.get()));
  Handle s(H5Dget_space(d.get()), H5Sclose);
  if (H5Sget_simple_extent_npoints(s.get()) != 1)
    throw InputError(file_, ds_path, "a single string", dims_text(space_dims(s.get())));
  std::vector<std::string> out;
  const hid_t did = d.get();
  if (!read_string_values(t.get(), 1, out,
                          [did](hid_t mt, void* buf) { return H5Dread(did, mt, H5S_ALL, H5S_ALL, H5P_DEFAULT, buf); },
                          s.get(), max_bytes + 1, file_, ds_path))
    throw InputError(file_, ds_path, "a readable string", "read failed (file truncated or corrupt?)");
  if (out[0].size() > max_bytes)
    throw InputError(file_, ds_path, fmt::format("at most {} bytes", max_bytes), std::to_string(out[0].size()));
  return out[0];
}

// ---------------------------------------------------------------- Writer

namespace {
// The operating system's reason when HDF5's file driver failed ("No space left on device"):
// its error stack holds it as "... error message = 'REASON', ...". Empty otherwise.
std::string system_reason() {
  std::string reason;
  H5Ewalk2(
      H5E_DEFAULT, H5E_WALK_DOWNWARD,
      [](unsigned, const H5E_error2_t* e, void* out) -> herr_t {
        const std::string desc = e->desc ? e->desc : "";
        const std::string key = "error message = '";
        const auto i = desc.find(key);
        if (i == std::string::npos) return 0;
        const auto j = desc.find('\'', i + key.size());
        *static_cast<std::string*>(out) = desc.substr(i + key.size(), j == std::string::npos ? j : j - i - key.size());
        return 1;  // the first one found
      },
      &reason);
  return reason;
}

// A failed write is not bad input: exit 3, naming the file (the temporary is removed).
[[noreturn]] void write_error(const std::string& file, const std::string& field, const std::string& what) {
  const std::string reason = system_reason();
  throw std::runtime_error(fmt::format("{}: {}: {}{}; nothing was written there", file, field, what,
                                       reason.empty() ? "" : " (" + reason + ")"));
}
}  // namespace

Writer::Writer(const std::filesystem::path& target)
    : target_(target),
      tmp_(target.string() + fmt::format(".tmp-{}", ::getpid())),
      file_(target.string()) {
  Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose);
  H5Pset_link_creation_order(fcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  // The 1.8 file format checksums its metadata (superblock, object headers, heaps), so a
  // corrupted file is refused by HDF5 instead of being decoded (libhdf5 can crash on
  // corrupt v1 metadata). Readable by HDF5 >= 1.8: h5py, MATLAB, Slicer.
  Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose);
  H5Pset_libver_bounds(fapl.get(), H5F_LIBVER_V18, H5F_LIBVER_V18);
  temp_slot_ = register_temporary(tmp_);
  f_ = Handle(H5Fcreate(tmp_.string().c_str(), H5F_ACC_TRUNC, fcpl.get(), fapl.get()), H5Fclose);
  if (!f_.valid()) write_error(file_, "<file>", "cannot create " + tmp_.string());
}

Writer::~Writer() {
  if (!committed_) {
    f_.reset();
    std::error_code ec;
    std::filesystem::remove(tmp_, ec);
  }
  unregister_temporary(temp_slot_);
}

void Writer::group(const std::string& path) {
  Handle gcpl(H5Pcreate(H5P_GROUP_CREATE), H5Pclose);
  H5Pset_link_creation_order(gcpl.get(), H5P_CRT_ORDER_TRACKED | H5P_CRT_ORDER_INDEXED);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle g(H5Gcreate2(f_.get(), path.c_str(), lcpl.get(), gcpl.get(), H5P_DEFAULT), H5Gclose);
  if (!g.valid()) write_error(file_, path, "HDF5 could not create it");
}

namespace {
void write_attr(hid_t f, const std::string& file, const std::string& obj, const std::string& name,
                hid_t type, hid_t space, hid_t memtype, const void* data) {
  Handle a(H5Acreate_by_name(f, obj.c_str(), name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT,
                             H5P_DEFAULT),
           H5Aclose);
  if (!a.valid() || H5Awrite(a.get(), memtype, data) < 0)
    write_error(file, attr_field(obj, name), "HDF5 write failed");
}
}  // namespace

void Writer::attr(const std::string& obj, const std::string& name, const std::string& value) {
  std::size_t longest = 0;
  const std::vector<char> buf = pack({value}, longest, file_, attr_field(obj, name));
  Handle t = fixed_string_type(longest);
  Handle s(H5Screate(H5S_SCALAR), H5Sclose);
  write_attr(f_.get(), file_, obj, name, t.get(), s.get(), t.get(), buf.data());
}

void Writer::attr(const std::string& obj, const std::string& name, double value) {
  Handle s(H5Screate(H5S_SCALAR), H5Sclose);
  write_attr(f_.get(), file_, obj, name, H5T_IEEE_F64LE, s.get(), H5T_NATIVE_DOUBLE, &value);
}

void Writer::attr(const std::string& obj, const std::string& name, std::int64_t value) {
  Handle s(H5Screate(H5S_SCALAR), H5Sclose);
  write_attr(f_.get(), file_, obj, name, H5T_STD_I64LE, s.get(), H5T_NATIVE_INT64, &value);
}

void Writer::attr(const std::string& obj, const std::string& name, const std::vector<double>& v) {
  const hsize_t n = v.size();
  Handle s(H5Screate_simple(1, &n, nullptr), H5Sclose);
  write_attr(f_.get(), file_, obj, name, H5T_IEEE_F64LE, s.get(), H5T_NATIVE_DOUBLE, v.data());
}

template <class T>
void Writer::dataset(const std::string& path, const std::vector<hsize_t>& shape, const T* data,
                     bool compress) {
  const Elem e = elem_of<T>();
  Handle space(shape.empty() ? H5Screate(H5S_SCALAR)
                             : H5Screate_simple(int(shape.size()), shape.data(), nullptr),
               H5Sclose);
  Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose);
  std::uint64_t n = 1;
  for (hsize_t d : shape) n *= d;
  if (compress && !shape.empty() && n > 0) {
    // Chunks of at most ~1 MiB: halve the largest chunk side until it fits.
    std::vector<hsize_t> chunk = shape;
    auto bytes = [&] {
      std::uint64_t b = sizeof(T);
      for (hsize_t c : chunk) b *= c;
      return b;
    };
    while (bytes() > (1u << 20)) {
      std::size_t k = 0;
      for (std::size_t i = 1; i < chunk.size(); ++i)
        if (chunk[i] > chunk[k]) k = i;
      chunk[k] = (chunk[k] + 1) / 2;
    }
    H5Pset_chunk(dcpl.get(), int(chunk.size()), chunk.data());
    if (sizeof(T) > 1) H5Pset_shuffle(dcpl.get());
    H5Pset_deflate(dcpl.get(), 4);
  }
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle d(H5Dcreate2(f_.get(), path.c_str(), file_type(e), space.get(), lcpl.get(), dcpl.get(),
                      H5P_DEFAULT),
           H5Dclose);
  if (!d.valid()) write_error(file_, path, "HDF5 could not create it");
  if (n > 0 && H5Dwrite(d.get(), native(e), H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    write_error(file_, path, "HDF5 write failed");
}

template void Writer::dataset(const std::string&, const std::vector<hsize_t>&, const std::int64_t*, bool);
template void Writer::dataset(const std::string&, const std::vector<hsize_t>&, const std::uint16_t*, bool);
template void Writer::dataset(const std::string&, const std::vector<hsize_t>&, const std::uint8_t*, bool);
template void Writer::dataset(const std::string&, const std::vector<hsize_t>&, const double*, bool);
template void Writer::dataset(const std::string&, const std::vector<hsize_t>&, const float*, bool);

void Writer::strings(const std::string& path, const std::vector<std::string>& values) {
  std::size_t longest = 0;
  const std::vector<char> buf = pack(values, longest, file_, path);
  Handle t = fixed_string_type(longest);
  const hsize_t n = values.size();
  Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle d(H5Dcreate2(f_.get(), path.c_str(), t.get(), space.get(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT),
           H5Dclose);
  if (!d.valid()) write_error(file_, path, "HDF5 could not create it");
  if (n > 0 && H5Dwrite(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
    write_error(file_, path, "HDF5 write failed");
}

void Writer::string(const std::string& path, const std::string& value) {
  std::size_t longest = 0;
  const std::vector<char> buf = pack({value}, longest, file_, path);
  Handle t = fixed_string_type(longest);
  Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  Handle lcpl(H5Pcreate(H5P_LINK_CREATE), H5Pclose);
  H5Pset_create_intermediate_group(lcpl.get(), 1);
  Handle d(H5Dcreate2(f_.get(), path.c_str(), t.get(), space.get(), lcpl.get(), H5P_DEFAULT, H5P_DEFAULT),
           H5Dclose);
  if (!d.valid() || H5Dwrite(d.get(), t.get(), H5S_ALL, H5S_ALL, H5P_DEFAULT, buf.data()) < 0)
    write_error(file_, path, "HDF5 write failed");
}

void Writer::commit() {
  const hid_t id = f_.get();
  if (H5Fflush(id, H5F_SCOPE_GLOBAL) < 0) write_error(file_, "<file>", "flush failed");
  f_.reset();
  // Durable before it takes the target's name: a crash after the rename must not leave a
  // recording whose blocks never reached the disk.
  committed_ = true;  // from here on publish_temporary owns (and on failure removes) it
  publish_temporary(tmp_, target_);
}

}  // namespace burrbench::data_schema::h5
