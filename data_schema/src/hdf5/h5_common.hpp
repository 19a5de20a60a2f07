#pragma once
// Root header (format name + version) and the /provenance group, shared by the recording
// and sample files.
#include <string>

#include "burrbench/data_schema/provenance.hpp"
#include "hdf5/h5.hpp"

namespace burrbench::data_schema::h5 {

void write_header(Writer& w, const char* format, int major, int minor, const Provenance& p);
// Checks /@format == format and the major version; returns the stored version string.
std::string check_header(const Reader& r, const char* format, int major);
Provenance read_provenance(const Reader& r);
// Inputs lists (path + sha256) stored as two parallel string datasets under `group`.
void write_files(Writer& w, const std::string& group, const std::vector<InputFile>& files);
std::vector<InputFile> read_files(const Reader& r, const std::string& group);

}  // namespace burrbench::data_schema::h5
