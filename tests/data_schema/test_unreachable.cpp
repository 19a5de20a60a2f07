// BURRBENCH_UNREACHABLE (error.hpp) after an exhaustive enum switch: a value outside the
// enum ends the process with the place it happened, in every build, instead of a "?" or
// −1 passed on (or undefined behaviour). Enums read from files are parsed from names and
// refused there (exit 2), so only a programming error can get here.
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "burrbench/data_schema/import/volume.hpp"
#include "burrbench/data_schema/inspect.hpp"

namespace ds = burrbench::data_schema;

TEST(Unreachable, AValueOutsideTheEnumAbortsNamingThePlace) {
  GTEST_FLAG_SET(death_test_style, "threadsafe");
  EXPECT_DEATH(ds::format_name(static_cast<ds::FileFormat>(99)),
               R"(burrbench: internal error: unreachable code reached \(.*inspect\.cpp:[0-9]+\))");
  EXPECT_DEATH(ds::import::byte_size(static_cast<ds::import::VoxelType>(99)), "volume_decode\\.cpp");
}

TEST(Unreachable, EveryEnumeratorHasItsOwnName) {
  std::set<std::string> formats;
  for (auto f : {ds::FileFormat::kRecording, ds::FileFormat::kSample, ds::FileFormat::kParams,
                 ds::FileFormat::kManifest, ds::FileFormat::kFit, ds::FileFormat::kPrediction})
    formats.insert(ds::format_name(f));
  EXPECT_EQ(formats.size(), 6u);
  std::set<std::string> types;
  for (auto t : {ds::import::VoxelType::kUint8, ds::import::VoxelType::kInt16, ds::import::VoxelType::kUint16,
                 ds::import::VoxelType::kFloat32})
    types.insert(ds::import::to_string(t));
  EXPECT_EQ(types, (std::set<std::string>{"uint8", "int16", "uint16", "float32"}));
}
