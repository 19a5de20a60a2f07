#include "burrbench/data_schema/output_files.hpp"

#include <fcntl.h>
#include <stdio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <string>
#include <typeinfo>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"

namespace burrbench::data_schema {
namespace fs = std::filesystem;

namespace {

fs::path beside(const fs::path& target, const char* what) {
  return target.parent_path() / fmt::format(".{}.{}-{}", target.filename().string(), what, ::getpid());
}

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (std::size_t i = s.find(from); !from.empty() && i != std::string::npos; i = s.find(from, i + to.size()))
    s.replace(i, from.size(), to);
  return s;
}

}  // namespace

OutputFiles::~OutputFiles() {
  for (const Staged& f : files_) {
    if (!f.staged.empty()) ::unlink(f.staged.c_str());
    unregister_temporary(f.slot);
  }
}

fs::path OutputFiles::stage(const fs::path& target) {
  for (const Staged& f : files_)
    if (f.target == target) throw std::logic_error("OutputFiles: " + target.string() + " staged twice");
  Staged f{target, beside(target, "staged")};
  ::unlink(f.staged.c_str());  // a leftover of a killed run with our pid
  f.slot = register_temporary(f.staged);
  files_.push_back(f);
  return f.staged;
}

void rethrow_naming(const fs::path& staged, const fs::path& target) {
  try {
    throw;
  } catch (const std::runtime_error& e) {
    if (typeid(e) != typeid(std::runtime_error)) throw;  // InputError and the like keep their exit code
    throw std::runtime_error(replace_all(e.what(), staged.string(), target.string()));
  }
}

void OutputFiles::write(const fs::path& target, const std::function<void(const fs::path&)>& writer) {
  const fs::path staged = stage(target);
  try {
    writer(staged);
  } catch (...) {
    rethrow_naming(staged, target);
  }
}

void OutputFiles::commit(bool replace) {
  struct Renamed {
    fs::path target, previous;  // previous: a hard link to the file it replaced, or empty
    bool existed = false;
    int slot = -1;
  };
  std::vector<Renamed> renamed;
  const auto drop = [](Renamed& r) {
    if (!r.previous.empty()) ::unlink(r.previous.c_str());
    unregister_temporary(r.slot);
  };
  for (Staged& f : files_) {
    Renamed r{f.target, {}, false, -1};
    std::error_code ec;
    if (fs::exists(fs::symlink_status(f.target, ec))) {
      r.existed = true;
      r.previous = beside(f.target, "previous");
      ::unlink(r.previous.c_str());
      r.slot = register_temporary(r.previous);
      // link() does not follow a symbolic link: the link itself is kept and put back.
      if (::link(f.target.c_str(), r.previous.c_str()) != 0) r.previous.clear();  // no hard links: no undo
    }
    // Without replace: renameat2(RENAME_NOREPLACE) fails with EEXIST, atomically, when
    // the target exists by now (another run got there first).
    const int rc = replace ? ::rename(f.staged.c_str(), f.target.c_str())
                           : ::renameat2(AT_FDCWD, f.staged.c_str(), AT_FDCWD, f.target.c_str(), RENAME_NOREPLACE);
    if (rc != 0) {
      const int err = errno;
      drop(r);
      for (auto it = renamed.rbegin(); it != renamed.rend(); ++it) {  // undo, newest first
        if (!it->previous.empty())
          ::rename(it->previous.c_str(), it->target.c_str());
        else if (!it->existed)
          ::unlink(it->target.c_str());
        drop(*it);
      }
      if (!replace && err == EEXIST)
        throw InputError(f.target.string(), "<output>", "a file that does not exist yet (--overwrite replaces it)",
                         "it appeared while this command ran (another run writing the same output?); no output was written");
      throw std::runtime_error(fmt::format("{}: cannot rename the finished file onto it ({}); no output was written",
                                           f.target.string(), std::strerror(err)));
    }
    unregister_temporary(f.slot);
    f.slot = -1;
    f.staged.clear();
    renamed.push_back(r);
  }
  for (Renamed& r : renamed) {
    drop(r);
    sync_folder(r.target.parent_path());
  }
  files_.clear();
}

}  // namespace burrbench::data_schema
