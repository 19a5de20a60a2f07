#pragma once
// A study: many specimens, each an experiment (its sample, recordings and roles), with
// shared acceptance criteria and fit options. Format "burrbench.study" (TOML,
// docs/formats.md, docs/study.md). Since 1.1 a specimen may give its sample and
// recordings as the lab's raw files (a CT or label volume, CSV exports with a column
// map), which the workflow imports before calibrating.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace burrbench::study {

inline constexpr const char* kStudyFormat = "burrbench.study";
inline constexpr int kStudyVersionMajor = 1;
inline constexpr int kStudyVersionMinor = 1;

// One of the specimen's experiment files made by the workflow from raw files:
// `burrbench sample import ARGS --out …` ([specimen.sample]) or `burrbench recording
// import ARGS --out …` ([[specimen.recording]]).
struct Import {
  enum class Kind { kSample, kRecording } kind = Kind::kSample;
  std::string id;                              // the experiment's sample / recording id
  std::vector<std::string> args;               // the verb's options, paths absolute, without --out
  std::vector<std::filesystem::path> inputs;   // files and folders it reads (absolute)
  const char* verb() const { return kind == Kind::kSample ? "sample" : "recording"; }
  const char* folder() const { return kind == Kind::kSample ? "samples" : "recordings"; }
};

struct Specimen {
  std::string id;                     // [A-Za-z0-9_.-], unique: names its result folder
  std::filesystem::path experiment;   // the specimen's experiment manifest (absolute)
  // Its calibration's inputs: the manifest, and the samples and recordings it names that
  // are not imported (those are the imports' outputs).
  std::vector<std::filesystem::path> inputs;
  std::vector<Import> imports;        // empty: the experiment's files are used as they are
  std::string experiment_text;        // the manifest as read (for resolved_experiment)
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
// the study file's folder); InputError naming the file and field. A specimen with
// imports has its manifest checked as far as it can be before they run: its TOML, the
// sample and recording ids the imports name, and every file it names that is not imported.
StudyManifest read_study(const std::filesystem::path& path);

// Where the workflow imports `imp` of a specimen whose imports go to `import_dir`.
std::filesystem::path imported_file(const std::filesystem::path& import_dir, const Import& imp);

// The specimen's experiment manifest as the workflow calibrates it: every imported
// sample's and recording's path replaced by imported_file(import_dir, …), every other
// path absolute. TOML text (comments are not kept).
std::string resolved_experiment(const Specimen& sp, const std::filesystem::path& import_dir);

}  // namespace burrbench::study
