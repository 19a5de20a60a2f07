#pragma once
// The output files of one command that writes more than one file outside an output folder
// (`replay --out --csv`, `synth --out --truth`, `sample export-nrrd`): they appear all
// together or not at all. Before, a failure on the second file (a full disk, a file-size
// limit) left the first one written.
//
// - Each writer writes its file to stage(target), a hidden file beside the target
//   (".NAME.staged-PID"), with its usual temporary, checks and fsync.
// - commit(), once every file is staged, renames each onto its target. A rename in one
//   folder does not need space; should one fail anyway, the targets already renamed are
//   put back as they were (a replaced file from a hard link kept until the end, a new one
//   removed) and the error names the target.
// - Without commit() — a failure, an exception, Ctrl-C or SIGTERM — every staged file is
//   removed and no target is touched.
#include <filesystem>
#include <functional>
#include <vector>

namespace burrbench::data_schema {

class OutputFiles {
 public:
  OutputFiles() = default;
  ~OutputFiles();
  OutputFiles(const OutputFiles&) = delete;
  OutputFiles& operator=(const OutputFiles&) = delete;

  // Where a writer writes `target` until commit().
  std::filesystem::path stage(const std::filesystem::path& target);
  // writer(stage(target)); a std::runtime_error it throws names `target`, not the hidden
  // file (an InputError passes unchanged).
  void write(const std::filesystem::path& target, const std::function<void(const std::filesystem::path&)>& writer);
  // Renames every staged file onto its target (fsynced). std::runtime_error naming the
  // target when one fails (exit 3); the targets are then as they were before commit().
  // replace = false (no --overwrite): a target that appeared since the command checked it
  // (another run writing the same output) is never replaced: InputError naming it, and
  // no target is written (issue 59, N2; folders are refused the same way, OutputFolder).
  void commit(bool replace = true);

 private:
  struct Staged {
    std::filesystem::path target, staged;
    int slot = -1;  // in the signal handler's list of temporaries
  };
  std::vector<Staged> files_;
};

// In a catch block: rethrows the exception in flight; a plain std::runtime_error (a failed
// write) with `staged` replaced by `target` in its message, so the line names the user's
// path, not a hidden one. Shared with OutputFolder.
[[noreturn]] void rethrow_naming(const std::filesystem::path& staged, const std::filesystem::path& target);

}  // namespace burrbench::data_schema
