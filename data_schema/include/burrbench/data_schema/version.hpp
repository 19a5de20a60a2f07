#pragma once
namespace burrbench {
// "burrbench <git describe>", written at build time (cmake/write_version.cmake).
const char* software_version();
}  // namespace burrbench
