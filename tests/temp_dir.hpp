#pragma once
// A fresh folder under the system's temp directory, removed with everything in it when it
// goes out of scope: tests leave nothing behind. It is its own path (`dir / "x.h5"`,
// `dir.string()`), so it passes wherever a path is taken.
#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

namespace burrbench::test {

class TempDir : public std::filesystem::path {
 public:
  // `prefix`: the folder's name up to a unique suffix (mkdtemp), to tell tests apart.
  explicit TempDir(const std::string& prefix = "bb-test") : std::filesystem::path(make(prefix)) {}
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(*this, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::filesystem::path& path() const { return *this; }

 private:
  static std::string make(const std::string& prefix) {
    std::string tmpl = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
    if (!mkdtemp(tmpl.data())) throw std::runtime_error("cannot create a temporary folder " + tmpl);
    return tmpl;
  }
};

}  // namespace burrbench::test
