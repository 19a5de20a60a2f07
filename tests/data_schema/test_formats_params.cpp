// Parameter set (TOML): round trip (incl. α = ∞), units in the header, strict keys.
#include <cmath>

#include "burrbench/data_schema/parameter_set.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::test::expect_input_error;
using burrbench::test::TempDir;

namespace {
const char* kParams = R"(format = "burrbench.params"
format_version = "1.0"
[classes.compact]
id = 1
alpha_N_per_mm2 = 25.0
c1_N_per_mm2 = 10.0
mu = 0.3
[classes.trabecular]
id = 2
alpha_N_per_mm2 = "inf"
c1_N_per_mm2 = 2
mu = 0.0
)";

void expect_bad(const TempDir& dir, const std::string& from, const std::string& to,
                std::initializer_list<std::string> frags) {
  std::string text = kParams;
  const auto pos = text.find(from);
  ASSERT_NE(pos, std::string::npos) << from;
  text.replace(pos, from.size(), to);
  burrbench::test::write_text(dir / "P.toml", text);
  burrbench::test::expect_rejected_unchanged(dir / "P.toml", [&] { bb::read_params(dir / "P.toml"); }, frags);
}
}  // namespace

TEST(FormatsParams, RoundTripIsExactAndKeepsUnits) {
  TempDir dir;
  bb::ParameterSet a;
  a.classes[1] = {"compact", 1.0 / 3.0, 12.345678901234567, 0.1};
  a.classes[2] = {"trabecular", INFINITY, 4.5, 0.0};
  a.classes[7] = {"implant", 1e9, 1e-3, 1.25};
  a.notes = "fit of 2026-11-22";
  a.provenance = burrbench::make_provenance({});
  bb::write_params(dir / "p.toml", a);
  const std::string text = burrbench::test::file_bytes(dir / "p.toml");
  EXPECT_NE(text.find("# Units: alpha_N_per_mm2 and c1_N_per_mm2 in N/mm^2"), std::string::npos);
  const auto b = bb::read_params(dir / "p.toml");
  ASSERT_EQ(b.classes.size(), 3u);
  for (const auto& [id, c] : a.classes) {
    EXPECT_EQ(b.classes.at(id).name, c.name);
    EXPECT_EQ(b.classes.at(id).alpha_N_per_mm2, c.alpha_N_per_mm2);
    EXPECT_EQ(b.classes.at(id).c1_N_per_mm2, c.c1_N_per_mm2);
    EXPECT_EQ(b.classes.at(id).mu, c.mu);
  }
  EXPECT_EQ(b.notes, a.notes);
  EXPECT_EQ(b.provenance.software_version, a.provenance.software_version);
  EXPECT_EQ(b.provenance.created_utc, a.provenance.created_utc);
  EXPECT_EQ(b.by_name("implant")->mu, 1.25);
}

TEST(FormatsParams, HandWrittenFileWithInfString) {
  TempDir dir;
  burrbench::test::write_text(dir / "P.toml", kParams);
  const auto p = bb::read_params(dir / "P.toml");
  EXPECT_TRUE(std::isinf(p.classes.at(2).alpha_N_per_mm2));
  EXPECT_EQ(p.classes.at(2).c1_N_per_mm2, 2.0);  // integer accepted as a number
  EXPECT_EQ(p.classes.at(1).name, "compact");
}

TEST(FormatsParams, BadValuesAndKeysAreRejected) {
  TempDir dir;
  expect_bad(dir, "c1_N_per_mm2 = 10.0", "c1_N_per_mm2 = 0.0",
             {"P.toml: classes.compact.c1_N_per_mm2: expected a finite C1 > 0 N/mm², at most 1e+06, got 0"});
  // A typo that would turn into NaN forces in a replay (issue 12).
  expect_bad(dir, "c1_N_per_mm2 = 10.0", "c1_N_per_mm2 = 1e200", {"classes.compact.c1_N_per_mm2", "at most 1e+06"});
  expect_bad(dir, "mu = 0.3", "mu = 30", {"classes.compact.mu", "at most 10"});
  expect_bad(dir, "alpha_N_per_mm2 = 25.0", "alpha_N_per_mm2 = 1e300", {"classes.compact.alpha_N_per_mm2", "at most 1e+12"});
  expect_bad(dir, "c1_N_per_mm2 = 10.0", "c1_N_per_mm2 = -1.0", {"classes.compact.c1_N_per_mm2"});
  expect_bad(dir, "mu = 0.3", "mu = -0.3", {"classes.compact.mu: expected a finite mu >= 0"});
  expect_bad(dir, "mu = 0.3", "mu = nan", {"classes.compact.mu", "finite"});
  expect_bad(dir, "alpha_N_per_mm2 = 25.0", "alpha_N_per_mm2 = -inf", {"classes.compact.alpha_N_per_mm2"});
  expect_bad(dir, "alpha_N_per_mm2 = 25.0", "alpha_N_per_mm2 = 0", {"classes.compact.alpha_N_per_mm2", "alpha > 0"});
  expect_bad(dir, "mu = 0.3", "mu = 0.3\nfriction = 1", {"P.toml: classes.compact.friction: expected a known key"});
  expect_bad(dir, "format_version = \"1.0\"", "format_version = \"1.0\"\nauthor = \"x\"", {"P.toml: author: expected a known key"});
  expect_bad(dir, "format_version = \"1.0\"", "format_version = \"3.1\"", {"format_version", "unknown major version"});
  expect_bad(dir, "id = 2", "id = 1", {"classes.trabecular.id", "unique class ids"});
  expect_bad(dir, "id = 2", "id = 300", {"classes.trabecular.id", "1..255"});
  expect_bad(dir, "id = 2\n", "", {"classes.trabecular.id: expected an integer, got missing"});
  expect_bad(dir, "mu = 0.3", "mu = 0.3 0.4", {"P.toml: line", "valid TOML"});
}

TEST(FormatsParams, CorruptedFilesOnlyEverRaiseInputError) {
  TempDir dir;
  const std::string base = kParams;
  const int rejected = burrbench::test::count_rejected_corruptions(
      base, dir / "c.toml", 300, 99, 3, true, [](const auto& p) { bb::read_params(p); });
  EXPECT_GT(rejected, 150);
}
