// Inputs hashed as they are read, and the check a command makes before it writes its
// outputs: a file changed or removed since is named, an unchanged one passes.
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "temp_dir.hpp"

namespace {

void write(const std::filesystem::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw burrbench::InputError(p.string(), "file", "a readable file", "missing");
  return {std::istreambuf_iterator<char>(in), {}};
}

// check_unchanged's refusal, if any.
std::optional<burrbench::InputError> refusal(const std::vector<burrbench::InputFile>& read) {
  try {
    burrbench::check_unchanged(read, "calibrate");
  } catch (const burrbench::InputError& e) {
    return e;
  }
  return std::nullopt;
}

}  // namespace

TEST(Provenance, AFileIsHashedAsReadAndAChangeOrRemovalSinceIsNamed) {
  burrbench::test::TempDir dir;
  const auto a = dir / "a.toml", b = dir / "abc.h5";
  write(a, "first");
  write(b, "abc");
  std::vector<burrbench::InputFile> read;
  EXPECT_EQ(burrbench::read_hashed(a, read, read_text), "first");
  EXPECT_EQ(burrbench::read_hashed(b, read, read_text), "abc");
  ASSERT_EQ(read.size(), 2u);
  EXPECT_EQ(read[0].path, a.string());
  // "abc" → the SHA-256 every implementation gives (FIPS 180-2, appendix B.1).
  EXPECT_EQ(read[1].sha256, "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  // A missing file: the reader's own error, not the hash's.
  try {
    burrbench::read_hashed(dir / "missing", read, read_text);
    ADD_FAILURE() << "a missing file was read";
  } catch (const burrbench::InputError& e) {
    EXPECT_EQ(e.expected(), "a readable file");
  }
  EXPECT_EQ(read.size(), 2u);

  EXPECT_FALSE(refusal(read).has_value());
  write(b, "abd");  // another export of it, as read now
  auto e = refusal(read);
  ASSERT_TRUE(e.has_value()) << "a changed file passed";
  EXPECT_EQ(e->file(), b.string());
  EXPECT_EQ(e->field(), "file");
  EXPECT_EQ(e->expected().rfind("unchanged while calibrate ran (SHA-256 ba7816bf8f01… when read)", 0), 0u)
      << e->expected();
  EXPECT_EQ(e->got(), "changed (now " + burrbench::sha256_file(b).substr(0, 12) + "…)");
  std::filesystem::remove(b);
  e = refusal(read);
  ASSERT_TRUE(e.has_value()) << "a removed file passed";
  EXPECT_EQ(e->file(), b.string());
  EXPECT_EQ(e->got(), "removed");
  // make_provenance_hashed keeps the hashes it is given (those of the files as read).
  EXPECT_EQ(burrbench::make_provenance_hashed(read).inputs[1].sha256, read[1].sha256);
}
