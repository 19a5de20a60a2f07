// One way to write a file: whole or not at all, the target untouched on any failure, no
// temporary left behind (issue 12).
#include <signal.h>
#include <sys/resource.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "burrbench/data_schema/atomic_file.hpp"

namespace fs = std::filesystem;
using namespace burrbench::data_schema;

namespace {
fs::path fresh_dir(const std::string& name) {
  const auto d = fs::temp_directory_path() / ("burrbench_atomic_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}
std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
std::size_t entries(const fs::path& d) {
  return static_cast<std::size_t>(std::distance(fs::directory_iterator(d), fs::directory_iterator()));
}
}  // namespace

TEST(AtomicFile, WritesTheWholeFileAndLeavesNoTemporary) {
  const auto d = fresh_dir("whole");
  const std::string big(3 << 20, 'x');  // several internal flushes
  AtomicFile f(d / "out.csv");
  f << "header\n" << big;
  EXPECT_FALSE(fs::exists(d / "out.csv"));  // nothing under the final name before commit
  f.commit();
  EXPECT_EQ(slurp(d / "out.csv"), "header\n" + big);
  EXPECT_EQ(entries(d), 1u);
  fs::remove_all(d);
}

TEST(AtomicFile, AnAbandonedWriteLeavesTheOldFileAndNoTemporary) {
  const auto d = fresh_dir("abandon");
  write_file_atomic(d / "fit.json", "old");
  {
    AtomicFile f(d / "fit.json");
    f << "half of a new";
  }  // an exception in the caller, say
  EXPECT_EQ(slurp(d / "fit.json"), "old");
  EXPECT_EQ(entries(d), 1u);
  fs::remove_all(d);
}

TEST(AtomicFile, AFileSizeLimitIsAnErrorNamingTheFileNotATruncatedFile) {
  // What a full disk does to a writer, reproduced without a mount: RLIMIT_FSIZE.
  const auto d = fresh_dir("limit");
  write_file_atomic(d / "residuals.csv", "the previous run's residuals\n");
  const auto old_handler = ::signal(SIGXFSZ, SIG_IGN);
  rlimit old{};
  ::getrlimit(RLIMIT_FSIZE, &old);
  rlimit lim = old;
  lim.rlim_cur = 64 << 10;
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &lim), 0);
  std::string message;
  try {
    AtomicFile f(d / "residuals.csv");
    f << std::string(1 << 20, 'r');
    f.commit();
  } catch (const std::runtime_error& e) {
    message = e.what();
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  ::signal(SIGXFSZ, old_handler);
  EXPECT_NE(message.find((d / "residuals.csv").string() + ": write failed"), std::string::npos) << message;
  EXPECT_NE(message.find("nothing was written there"), std::string::npos) << message;
  EXPECT_EQ(slurp(d / "residuals.csv"), "the previous run's residuals\n");
  EXPECT_EQ(entries(d), 1u);
  fs::remove_all(d);
}

TEST(AtomicFile, AnUnwritableFolderIsAnErrorNamingTheTarget) {
  try {
    write_file_atomic("/nonexistent-folder-burrbench/x.json", "{}");
    FAIL() << "no error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-folder-burrbench/x.json: cannot create"), std::string::npos)
        << e.what();
  }
}
