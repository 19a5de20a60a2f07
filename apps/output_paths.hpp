#pragma once
// Inputs are never written: every verb refuses an output path that names one of its
// inputs (the same file through another spelling, a symlink or a hard link included).
#include <unistd.h>

#include <filesystem>
#include <string>
#include <vector>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/same_file.hpp"

namespace burrbench::apps {

using data_schema::same_file;

// InputError(out, option, ...) when `out` is one of `inputs` (empty paths are skipped).
inline void refuse_output_over_inputs(const std::string& out, const std::string& option,
                                      const std::vector<std::string>& inputs) {
  if (out.empty()) return;
  for (const auto& in : inputs)
    if (!in.empty() && same_file(out, in))
      throw InputError(out, option, "a path different from the inputs (inputs are never written)", in);
}

// InputError when two outputs of one command name the same file (one would replace the
// other: `replay --out X --csv X`).
inline void refuse_same_outputs(const std::string& a, const std::string& option_a, const std::string& b,
                                const std::string& option_b) {
  if (!a.empty() && !b.empty() && same_file(a, b))
    throw InputError(b, option_b, "a file other than " + option_a + " (one output would replace the other)", a);
}

// Checked before long work, not after it: an output file's folder must exist and be
// writable, and the path must not name a folder.
inline void check_output_location(const std::string& out, const std::string& option) {
  if (out.empty()) return;
  const std::filesystem::path p(out);
  std::error_code ec;
  if (std::filesystem::is_directory(p, ec))
    throw InputError(out, option, "a file path (it names a folder)", "a folder");
  const auto dir = p.parent_path().empty() ? std::filesystem::path(".") : p.parent_path();
  if (!std::filesystem::is_directory(dir, ec))
    throw InputError(out, option, "a path in an existing folder", "no folder " + dir.string());
  if (::access(dir.c_str(), W_OK) != 0)
    throw InputError(out, option, "a path in a folder we may write", "folder " + dir.string() + " is not writable");
}

// An output file, checked before any work: its folder exists and is writable, it names no
// folder, and it never replaces an existing file unless the user says --overwrite.
inline void refuse_existing(const std::string& out, const std::string& option, bool overwrite) {
  check_output_location(out, option);
  std::error_code ec;
  if (out.empty() || overwrite || !std::filesystem::exists(std::filesystem::symlink_status(out, ec))) return;
  throw InputError(out, option, "a file that does not exist yet (--overwrite replaces it)", "exists");
}

}  // namespace burrbench::apps
