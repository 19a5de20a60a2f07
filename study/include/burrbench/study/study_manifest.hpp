#pragma once
// A study: many specimens, each an experiment (its sample, recordings and roles), with
// shared acceptance criteria and fit options. Format "burrbench.study" (TOML,
// docs/formats.md, docs/study.md).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace burrbench::study {

inline constexpr const char* kStudyFormat = "burrbench.study";
inline constexpr int kStudyVersionMajor = 1;

struct Specimen {
  std::string id;                     // [A-Za-z0-9_.-], unique: names its result folder
  std::filesystem::path experiment;   // the specimen's experiment manifest (absolute)
  std::vector<std::filesystem::path> inputs;  // manifest, samples, recordings: a job's inputs
};

// Shared fit options, passed to every `burrbench calibrate`.
struct FitOptions {
  std::int64_t starts = 16;
  bool profiles = true;
  bool cross_validation = false;
  bool discretization_check = false;
  std::vector<std::string> calibrate_args() const;
};

struct StudyManifest {
  std::filesystem::path file;  // absolute
  std::string name, description;
  std::optional<std::filesystem::path> criteria;  // absolute; validate runs when given
  FitOptions fit;
  std::vector<Specimen> specimens;
};

// Validates the study and every specimen's experiment manifest (paths resolved against
// the study file's folder); InputError naming the file and field.
StudyManifest read_study(const std::filesystem::path& path);

}  // namespace burrbench::study
