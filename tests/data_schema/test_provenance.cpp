// Inputs hashed when read, and the check a command makes before it writes its outputs: a
// file changed or removed since is named, an unchanged one passes.
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/provenance.hpp"
#include "temp_dir.hpp"

namespace {

void write(const std::filesystem::path& p, const std::string& text) { std::ofstream(p, std::ios::binary) << text; }

}  // namespace

TEST(Provenance, CheckUnchangedNamesAFileChangedOrRemovedSinceItWasRead) {
  burrbench::test::TempDir dir;
  const auto a = dir / "a.toml", b = dir / "b.h5";
  write(a, "first");
  write(b, "second");
  // "abc" → the SHA-256 every implementation gives (FIPS 180-2, appendix B.1).
  write(dir / "abc", "abc");
  EXPECT_EQ(burrbench::sha256_before_read(dir / "abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(burrbench::sha256_before_read(dir / "missing"), "");  // its reader will say why

  const std::vector<burrbench::InputFile> read{{a.string(), burrbench::sha256_before_read(a)},
                                               {b.string(), burrbench::sha256_before_read(b)}};
  EXPECT_NO_THROW(burrbench::check_unchanged(read, "calibrate"));
  const auto p = burrbench::make_provenance_hashed(read);
  EXPECT_EQ(p.inputs.size(), 2u);
  EXPECT_EQ(p.inputs[1].sha256, read[1].sha256);

  write(b, "second, replaced");
  try {
    burrbench::check_unchanged(read, "calibrate");
    ADD_FAILURE() << "a changed file passed";
  } catch (const burrbench::InputError& e) {
    EXPECT_EQ(e.file(), b.string());
    EXPECT_EQ(e.field(), "file");
    EXPECT_EQ(e.expected().rfind("unchanged while calibrate ran (SHA-256 " + read[1].sha256.substr(0, 12), 0), 0u)
        << e.expected();
    EXPECT_EQ(e.got(), "changed (now " + burrbench::sha256_file(b).substr(0, 12) + "…)");
  }
  std::filesystem::remove(b);
  try {
    burrbench::check_unchanged(read, "replay");
    ADD_FAILURE() << "a removed file passed";
  } catch (const burrbench::InputError& e) {
    EXPECT_EQ(e.file(), b.string());
    EXPECT_EQ(e.got(), "removed");
  }
}
