#pragma once
// One way to write a file (issue 12). The bytes go to a temporary file beside the target;
// every write, the flush, fsync and close are checked; only then is it renamed over the
// target, so a reader sees the old file or the whole new one, never a part. On any
// failure — a full disk, a file-size limit (SIGXFSZ is ignored, so it is an error), an
// I/O error, Ctrl-C or SIGTERM — the temporary is removed and the target is untouched.
// Failures throw std::runtime_error naming the target (exit 3 in the command line).
#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>

namespace burrbench::data_schema {

class AtomicFile {
 public:
  explicit AtomicFile(std::filesystem::path target);
  ~AtomicFile();  // without commit(): the temporary is removed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(std::string_view bytes);
  AtomicFile& operator<<(std::string_view bytes) {
    write(bytes);
    return *this;
  }
  // Flush, fsync, close, rename over the target, fsync the folder. Throws on any failure
  // (the temporary is then gone and the target as it was).
  void commit();
  const std::filesystem::path& target() const { return target_; }

 private:
  void flush();
  [[noreturn]] void fail(const std::string& what, int err);
  std::filesystem::path target_, tmp_;
  int fd_ = -1;
  int slot_ = -1;  // in the signal handler's list of temporaries
  std::string buf_;
};

// The whole file in one call.
void write_file_atomic(const std::filesystem::path& target, std::string_view bytes);
// A copy of `from` written the same way (read whole: for the small files copied beside an
// output, criteria, parameters, predictions).
void copy_file_atomic(const std::filesystem::path& from, const std::filesystem::path& target);

// The last step of every writer, for writers that must own their temporary by path
// (HDF5): fsync the finished temporary, rename it onto the target, fsync the folder.
// std::runtime_error naming `target` on failure (the temporary is then removed).
void publish_temporary(const std::filesystem::path& tmp, const std::filesystem::path& target);

// fsync a folder, so the renames in it are durable (best effort: some filesystems refuse).
void sync_folder(const std::filesystem::path& dir);

// Temporaries of other writers (HDF5) that a SIGINT/SIGTERM must remove too. register
// returns a slot (or -1 when the list is full: the file is then only removed on error).
int register_temporary(const std::filesystem::path& tmp, bool folder = false);
// A staging folder: on SIGINT/SIGTERM its files are unlinked, then the folder removed.
int register_temporary_tree(const std::filesystem::path& folder);
void unregister_temporary(int slot);

}  // namespace burrbench::data_schema
