#include "burrbench/data_schema/output_folder.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/output_files.hpp"

namespace burrbench::data_schema {
namespace fs = std::filesystem;

OutputFolder::OutputFolder(const fs::path& target, const std::string& option, bool overwrite) : option_(option) {
  std::error_code ec;
  target_ = fs::absolute(target, ec).lexically_normal();
  if (target_.filename().empty()) target_ = target_.parent_path();  // "out/" → "out"
  if (fs::exists(target_, ec)) {
    if (!fs::is_directory(target_, ec))
      throw InputError(target.string(), option, "a directory (or a path to create one)", "an existing file");
    if (!overwrite) {
      std::size_t n = 0;
      std::string first;
      for (const auto& e : fs::directory_iterator(target_, ec)) {
        if (n++ == 0) first = e.path().filename().string();
      }
      if (n > 0)
        throw InputError(target.string(), option,
                         "a new or empty folder (--overwrite writes into an existing one, replacing files "
                         "of the same names)",
                         fmt::format("it holds {} entr{} ({}{})", n, n == 1 ? "y" : "ies", first, n > 1 ? ", …" : ""));
    }
  } else {
    fs::create_directories(target_, ec);
    if (ec) throw InputError(target.string(), option, "a directory that can be created", ec.message());
    created_ = true;
    target_slot_ = register_temporary(target_, true);
  }
  lock_fd_ = ::open(target_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (lock_fd_ >= 0 && ::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    created_ = false;  // not ours to remove
    unregister_temporary(target_slot_);
    target_slot_ = -1;
    throw InputError(target.string(), option, "a folder no other burrbench command is writing", "in use by another run");
  }
  // A folder we created is staged beside it and appears whole in one rename; an existing
  // one (its parent may not be ours to write) is staged inside, hidden.
  whole_rename_ = created_;
  staging_ = whole_rename_ ? target_.parent_path() / fmt::format(".{}.staging-{}", target_.filename().string(), ::getpid())
                           : target_ / fmt::format(".staging-{}", ::getpid());
  fs::remove_all(staging_, ec);  // a leftover of a killed run with our pid
  if (!fs::create_directory(staging_, ec) || ec) {
    const std::string why = ec ? ec.message() : "exists";
    if (created_) {
      fs::remove(target_, ec);
      unregister_temporary(target_slot_);
      created_ = false;
    }
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw InputError(target.string(), option, "a folder in which a staging folder can be made", why);
  }
  staging_slot_ = register_temporary_tree(staging_);
}

OutputFolder::~OutputFolder() {
  std::error_code ec;
  if (!staging_.empty()) fs::remove_all(staging_, ec);
  unregister_temporary(staging_slot_);
  unregister_temporary(target_slot_);
  if (created_ && fs::is_empty(target_, ec)) fs::remove(target_, ec);
  if (lock_fd_ >= 0) ::close(lock_fd_);
}

void OutputFolder::refuse_inputs(const std::vector<std::string>& names, const std::vector<fs::path>& inputs) const {
  std::error_code ec;
  for (const auto& name : names) {
    const fs::path out = target_ / name;
    if (!fs::exists(out, ec)) continue;
    for (const auto& in : inputs)
      if (!in.empty() && fs::exists(in, ec) && fs::equivalent(out, in, ec))
        throw InputError(out.string(), option_,
                         "an output that is not one of the inputs (inputs are never replaced, not even with "
                         "--overwrite)",
                         "it is the input " + in.string());
  }
}

void OutputFolder::write(const std::function<void(const fs::path&)>& fn) const {
  try {
    fn(staging_);
  } catch (...) {
    rethrow_naming(staging_, target_);
  }
}

void OutputFolder::commit() {
  // On a failed move the finished files stay in the staging folder, for the user to take.
  const auto failed = [&](const fs::path& name, int err) {
    const fs::path kept = staging_;
    unregister_temporary(staging_slot_);
    staging_slot_ = -1;
    staging_.clear();  // not removed by the destructor
    created_ = false;
    throw std::runtime_error(fmt::format("{}: cannot move {} into it ({}); the finished files stay in {}",
                                         target_.string(), name.string(), std::strerror(err), kept.string()));
  };
  sync_folder(staging_);  // the staged files were fsynced by their writers; their names now
  if (whole_rename_ && ::rename(staging_.c_str(), target_.c_str()) == 0) {
    sync_folder(target_.parent_path());
  } else {
    // Into an existing folder (or one a user filled meanwhile): file by file, each rename
    // atomic, so every name holds the old file or the whole new one.
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(staging_, ec))
      if (::rename(e.path().c_str(), (target_ / e.path().filename()).c_str()) != 0)
        failed(e.path().filename(), errno);
    if (ec) failed(".", ec.value());
    fs::remove(staging_, ec);
    sync_folder(target_);
  }
  unregister_temporary(staging_slot_);
  unregister_temporary(target_slot_);
  staging_slot_ = target_slot_ = -1;
  staging_.clear();
  created_ = false;
}

}  // namespace burrbench::data_schema
