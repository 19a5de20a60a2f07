#pragma once
// A command's output folder (calibrate, validate, report): its files appear all together or
// not at all, and nothing of the user's is replaced unless asked (issue 12; README,
// "the overwrite policy"). Several files outside a folder: output_files.hpp.
//
// - The folder must be new or empty; an existing folder that holds files is refused
//   (InputError, exit 2) before any work, unless `overwrite`: then the command's files
//   replace their namesakes and every other file is left alone.
// - The command writes into staging(), never into the folder itself. commit() moves the
//   staged files in: a folder the command created (or found empty) appears whole in one
//   rename; into an existing folder each file is renamed over its namesake.
// - The folder is locked (flock) from construction to commit, so a second command writing
//   the same folder is refused (exit 2) instead of mixing its files with ours.
// - Without commit() — a failure, an exception, Ctrl-C or SIGTERM — the staging folder
//   and a folder the command created are removed: nothing is left behind.
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

namespace burrbench::data_schema {

class OutputFolder {
 public:
  OutputFolder(const std::filesystem::path& target, const std::string& option, bool overwrite);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  // Where the command writes its files until commit().
  const std::filesystem::path& staging() const { return staging_; }
  const std::filesystem::path& target() const { return target_; }

  // InputError(option) when a file the command will write (a name in the folder) is one
  // of its inputs: an input is never replaced, not even with --overwrite.
  void refuse_inputs(const std::vector<std::string>& names, const std::vector<std::filesystem::path>& inputs) const;

  // fn(staging()); a failed write's message names the folder, not the staging folder.
  void write(const std::function<void(const std::filesystem::path& staging)>& fn) const;

  // Moves the staged files into the folder (fsynced). std::runtime_error naming the folder
  // when a rename fails (exit 3).
  void commit();

 private:
  std::filesystem::path target_, staging_;
  std::string option_;
  bool created_ = false;        // the command made the folder: removed again on failure
  bool whole_rename_ = false;   // the folder was empty: the staging folder replaces it
  int target_slot_ = -1, staging_slot_ = -1;
  int lock_fd_ = -1;
};

}  // namespace burrbench::data_schema
