#pragma once
// Small private RAII layer over the HDF5 C API. Every failure becomes an InputError
// naming the file and the object path ("R.h5: /streams/ft_sensor/t_ns: expected ...");
// HDF5's own error stack printing is silenced while our files are open.
// Writers go through TempFile: data lands in "<target>.tmp-<pid>" and is renamed onto
// the target only after a clean close, so a failed write never leaves a half file.
// Debian's serial HDF5 is not thread-safe: do file I/O from one thread at a time.
#include <hdf5.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace burrbench::data_schema::h5 {

// Owns one hid_t and closes it with the matching H5?close.
class Handle {
 public:
  using Closer = herr_t (*)(hid_t);
  Handle() = default;
  Handle(hid_t id, Closer close) : id_(id), close_(close) {}
  Handle(Handle&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = -1; }
  Handle& operator=(Handle&& o) noexcept;
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  ~Handle() { reset(); }
  hid_t get() const { return id_; }
  bool valid() const { return id_ >= 0; }
  void reset();

 private:
  hid_t id_ = -1;
  Closer close_ = nullptr;
};

// Silences HDF5's automatic error printing for its lifetime (restores the old handler).
class ErrorSilencer {
 public:
  ErrorSilencer();
  ~ErrorSilencer();
  ErrorSilencer(const ErrorSilencer&) = delete;
  ErrorSilencer& operator=(const ErrorSilencer&) = delete;

 private:
  H5E_auto2_t old_func_ = nullptr;
  void* old_data_ = nullptr;
};

// True when the file carries the HDF5 signature.
bool is_hdf5(const std::filesystem::path& path);

// Element types we store; `name` is used in messages ("int64", "float32", ...).
enum class Elem { kInt64, kUInt16, kUInt8, kFloat64, kFloat32 };
const char* elem_name(Elem e);

// Read-only view of an existing file (opened H5F_ACC_RDONLY, never for writing).
class Reader {
 public:
  explicit Reader(const std::filesystem::path& path);
  // The same reader over an HDF5 file image in memory (the core driver over a copy of
  // `image`; nothing touches the disk); `name` stands for the file in messages.
  Reader(std::string_view image, const std::string& name);
  const std::string& file() const { return file_; }

  bool exists(const std::string& obj_path) const;
  // Names of a group's links, in creation order when tracked, else by name.
  std::vector<std::string> members(const std::string& group_path) const;
  // Rejects links not listed in `allowed` (unknown keys are rejected by the format rule).
  void expect_only(const std::string& group_path, const std::vector<std::string>& allowed) const;

  bool has_attr(const std::string& obj_path, const std::string& name) const;
  std::string attr_string(const std::string& obj_path, const std::string& name) const;
  std::optional<std::string> attr_string_opt(const std::string& obj_path, const std::string& name) const;
  std::vector<double> attr_doubles(const std::string& obj_path, const std::string& name,
                                   std::size_t expected_count) const;
  double attr_double(const std::string& obj_path, const std::string& name) const;
  std::int64_t attr_int64(const std::string& obj_path, const std::string& name) const;

  // Shape of a numeric dataset after checking its element type is convertible to `e`.
  std::vector<hsize_t> shape(const std::string& ds_path, Elem e) const;
  // Reads a whole numeric dataset after checking its type; refuses more than
  // max_elements from the header, before allocating.
  template <class T>
  std::vector<T> read(const std::string& ds_path, Elem e, std::vector<hsize_t>* shape_out,
                      std::uint64_t max_elements) const;
  std::vector<std::string> read_strings(const std::string& ds_path, std::uint64_t max_elements) const;
  std::string read_string(const std::string& ds_path, std::uint64_t max_bytes) const;

 private:
  Handle open_object(const std::string& obj_path) const;
  Handle open_dataset(const std::string& ds_path) const;
  std::string file_;
  ErrorSilencer silence_;
  Handle f_;
};

// A new file written under a temporary name; commit() closes and renames it.
class Writer {
 public:
  explicit Writer(const std::filesystem::path& target);
  ~Writer();  // removes the temporary file unless committed
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  void group(const std::string& path);  // creates with link creation order tracked
  void attr(const std::string& obj_path, const std::string& name, const std::string& value);
  void attr(const std::string& obj_path, const std::string& name, double value);
  void attr(const std::string& obj_path, const std::string& name, std::int64_t value);
  void attr(const std::string& obj_path, const std::string& name, const std::vector<double>& v);
  // Numeric dataset of the given shape; `compress`: chunked + deflate (big arrays).
  template <class T>
  void dataset(const std::string& path, const std::vector<hsize_t>& shape, const T* data,
               bool compress = false);
  void strings(const std::string& path, const std::vector<std::string>& values);
  void string(const std::string& path, const std::string& value);  // scalar string dataset
  void commit();

 private:
  std::filesystem::path target_, tmp_;
  std::string file_;
  ErrorSilencer silence_;
  Handle f_;
  bool committed_ = false;
  int temp_slot_ = -1;  // removed on SIGINT/SIGTERM too (atomic_file.hpp)
};

}  // namespace burrbench::data_schema::h5
