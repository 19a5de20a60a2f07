// Several output files of one command appear all together or not at all: a failure on one
// leaves no other written, an overwrite is undone when a later rename fails, and nothing
// hidden is left behind.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/output_files.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace burrbench::data_schema;
using burrbench::InputError;
using burrbench::test::TempDir;

namespace {
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
std::vector<std::string> names(const fs::path& d) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(d)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}
void write_text(const fs::path& p, const std::string& text) { write_file_atomic(p, text); }
}  // namespace

TEST(OutputFiles, CommitWritesEveryFileAndLeavesNothingHidden) {
  TempDir d("bb-output-files");
  OutputFiles out;
  out.write(d / "a.h5", [](const fs::path& p) { write_text(p, "first"); });
  EXPECT_FALSE(fs::exists(d / "a.h5")) << "staged, not yet written";
  out.write(d / "b.csv", [](const fs::path& p) { write_text(p, "second"); });
  out.commit();
  EXPECT_EQ(slurp(d / "a.h5"), "first");
  EXPECT_EQ(slurp(d / "b.csv"), "second");
  EXPECT_EQ(names(d), (std::vector<std::string>{"a.h5", "b.csv"}));
}

TEST(OutputFiles, AFailureOnTheSecondFileLeavesTheFirstUnwrittenAndNamesTheTarget) {
  TempDir d("bb-output-files");
  {
    OutputFiles out;
    out.write(d / "a.h5", [](const fs::path& p) { write_text(p, "first"); });
    try {
      out.write(d / "b.csv", [](const fs::path& p) {
        throw std::runtime_error(p.string() + ": write failed (No space left on device); nothing was written there");
      });
      FAIL() << "the writer's failure must pass";
    } catch (const std::runtime_error& e) {
      EXPECT_EQ(std::string(e.what()),
                (d / "b.csv").string() + ": write failed (No space left on device); nothing was written there");
    }
  }
  EXPECT_EQ(names(d), std::vector<std::string>{}) << "neither file, nor a staged one";
}

TEST(OutputFiles, BadInputKeepsItsType) {
  TempDir d("bb-output-files");
  OutputFiles out;
  EXPECT_THROW(out.write(d / "a.h5", [](const fs::path& p) { throw InputError(p.string(), "x", "y"); }), InputError);
}

TEST(OutputFiles, AFailedRenamePutsBackTheFilesItReplacedAndRemovesTheOnesItMade) {
  TempDir d("bb-output-files");
  write_text(d / "old.h5", "the user's file");
  fs::create_directory(d / "c.csv");  // a rename of a file onto a folder fails (EISDIR)
  fs::create_directory(d / "c.csv" / "inside");
  {
    OutputFiles out;
    out.write(d / "old.h5", [](const fs::path& p) { write_text(p, "replacement"); });
    out.write(d / "new.json", [](const fs::path& p) { write_text(p, "new"); });
    out.write(d / "c.csv", [](const fs::path& p) { write_text(p, "never"); });
    try {
      out.commit();
      FAIL() << "renaming onto a folder must fail";
    } catch (const std::runtime_error& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find((d / "c.csv").string() + ": cannot rename the finished file onto it"), std::string::npos)
          << what;
      EXPECT_NE(what.find("no output was written"), std::string::npos) << what;
    }
  }
  EXPECT_EQ(slurp(d / "old.h5"), "the user's file");
  EXPECT_TRUE(fs::is_directory(d / "c.csv" / "inside"));
  EXPECT_EQ(names(d), (std::vector<std::string>{"c.csv", "old.h5"})) << "new.json removed, nothing hidden left";
}

TEST(OutputFiles, ReplacesExistingFilesOnCommit) {
  TempDir d("bb-output-files");
  write_text(d / "a.h5", "old");
  OutputFiles out;
  out.write(d / "a.h5", [](const fs::path& p) { write_text(p, "new"); });
  EXPECT_EQ(slurp(d / "a.h5"), "old") << "until commit";
  out.commit();
  EXPECT_EQ(slurp(d / "a.h5"), "new");
  EXPECT_EQ(names(d), std::vector<std::string>{"a.h5"});
}
