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

// Stored once by main(); "" in library use (e.g. tests).
void set_invocation(int argc, const char* const* argv);
const std::string& invocation();

// A Provenance for "now" with the given input files hashed.
Provenance make_provenance(const std::vector<std::filesystem::path>& inputs);

}  // namespace burrbench
