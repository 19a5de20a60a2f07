// Deeply nested inputs are refused before a parser recurses (issue 12): an 80 KB TOML key
// nested 40 000 deep or JSON nested 10⁵ deep used to overflow the stack (signal 11) in
// toml++ and nlohmann::json, taking every reader with them.
#include <functional>
#include <string>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/nesting.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::InputError;
using burrbench::test::TempDir;

namespace {

std::string repeat(const std::string& s, int n) {
  std::string out;
  for (int i = 0; i < n; ++i) out += s;
  return out;
}

void expect_too_deep(const std::function<void()>& f, const std::string& file) {
  try {
    f();
    ADD_FAILURE() << "accepted";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(file), std::string::npos) << m;
    EXPECT_NE(m.find("nested at most 64 deep"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

}  // namespace

TEST(Nesting, DeepTomlIsRefusedBeforeParsing) {
  TempDir dir;
  const auto key = dir / "key.toml";  // the 80 KB dotted key of the finding
  burrbench::test::write_text(key, "format = \"burrbench.params\"\n" + repeat("a.", 40000) + "a = 1\n");
  expect_too_deep([&] { bb::read_params(key); }, key.string());
  const auto arr = dir / "arr.toml";
  burrbench::test::write_text(arr, "x = " + repeat("[", 100000) + repeat("]", 100000) + "\n");
  expect_too_deep([&] { bb::parse_toml_file(arr); }, arr.string());
  const auto tab = dir / "tab.toml";
  burrbench::test::write_text(tab, "x = " + repeat("{a=", 100000) + "1" + repeat("}", 100000) + "\n");
  expect_too_deep([&] { bb::parse_toml_file(tab); }, tab.string());
}

TEST(Nesting, OrdinaryTomlIsNotMistakenForDeep) {
  // Brackets and dots inside strings and comments, floats, times and a 64-part key pass.
  const std::string text = "s = \"" + repeat("[{.", 100) + "\"\nl = '" + repeat("[", 100) +
                           "'\nm = \"\"\"\n" + repeat("[", 100) + "\n\"\"\"\n# " + repeat("[.", 100) +
                           "\nf = [1.5, 2.5e3, 1979-05-27T07:32:00.999]\n" + repeat("k.", 64) + "k = 1\n";
  const auto t = bb::parse_toml_text(text, "ok.toml");
  EXPECT_TRUE(t.contains("s") && t.contains("m") && t.contains("k"));
  expect_too_deep([&] { bb::parse_toml_text(repeat("k.", 65) + "k = 1\n", "deep.toml"); }, "deep.toml");
}

TEST(Nesting, DeepJsonFitIsRefusedBeforeParsing) {
  TempDir dir;
  const auto f = dir / "fit.json";
  burrbench::test::write_text(f, repeat("[", 100000) + repeat("]", 100000));
  expect_too_deep([&] { bb::read_fit(f); }, f.string());
  // Brackets inside strings (escaped quotes included) do not count.
  EXPECT_NO_THROW(bb::check_json_nesting("{\"a\": \"" + repeat("[\\\"{", 200) + "\"}", "ok.json"));
}
