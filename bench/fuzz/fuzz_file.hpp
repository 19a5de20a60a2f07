#pragma once
// For parsers that take a path (and the files a parsed file names): a private scratch
// folder in /dev/shm (tmpfs: no disk I/O per execution; the system temp folder when there
// is none), created once per process and removed at exit, and a fast whole-file write.
#include <fcntl.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <string_view>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::fuzz {

inline const std::filesystem::path& scratch() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    const std::filesystem::path base = std::filesystem::is_directory("/dev/shm", ec)
                                           ? std::filesystem::path("/dev/shm")
                                           : std::filesystem::temp_directory_path();
    auto d = base / ("burrbench-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    static const std::string keep = d.string();
    std::atexit([] {
      std::error_code e;
      std::filesystem::remove_all(keep, e);
    });
    return d;
  }();
  return dir;
}

// Writes `bytes` to scratch()/name (replacing it) and returns the path.
inline std::filesystem::path put(const std::string& name, std::string_view bytes) {
  const auto p = scratch() / name;
  const int fd = ::open(p.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) std::abort();  // the harness's own failure, not a finding in the parser
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n <= 0) std::abort();
    done += static_cast<std::size_t>(n);
  }
  ::close(fd);
  return p;
}

inline std::string_view as_text(const std::uint8_t* data, std::size_t size) {
  return {reinterpret_cast<const char*>(data), size};
}

// One execution: InputError (one line naming file, field and expectation) is the only
// acceptable outcome for bad input; any other exception, a crash or a sanitizer report is
// a finding.
template <class F>
int expect_input_errors_only(F&& f) {
  try {
    f();
  } catch (const burrbench::InputError&) {
  }
  return 0;
}

}  // namespace burrbench::fuzz
