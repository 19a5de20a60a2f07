#pragma once
// What every output file records: schema version (by the writer), software version,
// the command line and the SHA-256 of every input file.
#include <filesystem>
#include <string>
#include <vector>

namespace burrbench {

struct InputFile {
  std::string path;
  std::string sha256;  // lowercase hex
};

struct Provenance {
  std::string software_version;  // software_version() at write time
  std::string command_line;      // invocation(), shell-quoted
  std::string created_utc;       // ISO 8601, e.g. 2026-11-22T02:00:00Z
  std::vector<InputFile> inputs;
};

// Lowercase hex SHA-256 of a file's bytes; InputError if it cannot be read.
std::string sha256_file(const std::filesystem::path& path);
std::string sha256_bytes(const void* data, std::size_t size);
// The SHA-256 of a file about to be read, or "" when it cannot be hashed: its reader then
// says what is wrong (a file that reads yet could not be hashed: hash it after the read).
std::string sha256_before_read(const std::filesystem::path& path);

// `read(path)`, with the file hashed just before it is read: appends to `hashed` the
// InputFile that outputs record (the file as read) and check_unchanged compares with.
template <class Read>
auto read_hashed(const std::filesystem::path& path, std::vector<InputFile>& hashed, Read&& read) {
  std::string sha = sha256_before_read(path);
  auto value = read(path);
  hashed.push_back({path.string(), sha.empty() ? sha256_file(path) : std::move(sha)});
  return value;
}

// Stored once by main(); "" in library use (e.g. tests).
void set_invocation(int argc, const char* const* argv);
const std::string& invocation();

// A Provenance for "now" with the given input files hashed.
Provenance make_provenance(const std::vector<std::filesystem::path>& inputs);
// A Provenance for "now" with inputs hashed before (when they were read).
Provenance make_provenance_hashed(std::vector<InputFile> hashed_inputs);

// A command's outputs describe its inputs as it read them: before they are committed it
// hashes each input again, and one that changed meanwhile (a file replaced by another
// program while a calibration ran) is an InputError naming it — rather than outputs whose
// SHA-256s name files the results did not come from. `command` names the work ("calibrate").
void check_unchanged(const std::vector<InputFile>& inputs, const std::string& command);

}  // namespace burrbench
