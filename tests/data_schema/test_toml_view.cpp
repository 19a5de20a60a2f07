// The strict TOML reader every burrbench input goes through (manifest, params, CSV map,
// rig map, protocol, criteria): what its messages say is what a user reads on exit 2.
#include <gtest/gtest.h>

#include <string>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace ds = burrbench::data_schema;
using burrbench::InputError;

namespace {

// The message of the InputError `read` throws on the document `text` (file "T.toml").
template <class F>
std::string error_of(const std::string& text, F read) {
  const toml::table t = ds::parse_toml_text(text, "T.toml");
  const ds::TomlView v(t, "T.toml");
  try {
    read(v);
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(TomlView, UnknownKeyIsNamedWithItsPath) {
  const std::string doc = "name = \"x\"\n[burr]\nradius_mm = 1\ncolour = \"red\"\n";
  // done(): a key no getter consumed.
  EXPECT_EQ(error_of(doc,
                     [](const ds::TomlView& v) {
                       v.str("name");
                       const auto b = v.table("burr");
                       b.num("radius_mm");
                       b.done();
                     }),
            "T.toml: burr.colour: expected a known key (see docs/formats.md), got unknown key");
  // allow(): the same message; the docs page is inherited by sub-views.
  const toml::table t = ds::parse_toml_text(doc, "T.toml");
  const ds::TomlView root(t, "T.toml", "", "docs/rig.md");
  try {
    root.table("burr").allow({"radius_mm"});
    FAIL() << "colour accepted";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(),
                 "T.toml: burr.colour: expected a known key (see docs/rig.md), got unknown key");
  }
  EXPECT_NO_THROW(root.table("burr").allow({"radius_mm", "colour"}));
  // Every key consumed: done() accepts.
  EXPECT_EQ(error_of(doc,
                     [](const ds::TomlView& v) {
                       v.use("name");
                       const auto b = v.table("burr");
                       b.num("radius_mm");
                       b.str("colour");
                       b.done();
                       v.done();
                     }),
            "(no error)");
}

TEST(TomlView, WrongTypeNamesExpectedAndGot) {
  const std::string doc = "a = \"1.5\"\nb = 2.5\nc = [1, 2]\nd = nan\ne = 300\nf = [1, \"x\"]\n";
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.num("a"); }),
            "T.toml: a: expected a number, got a string");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.str("b"); }),
            "T.toml: b: expected a string, got a float");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.integer("b"); }),
            "T.toml: b: expected an integer, got a float");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.table("b"); }),
            "T.toml: b: expected a table, got a float");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.vec3("c"); }),
            "T.toml: c: expected an array of 3 numbers, got 2 elements");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.num("d"); }),
            "T.toml: d: expected a finite number, got nan");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.integer("e", 0, 255); }),
            "T.toml: e: expected an integer in [0, 255], got 300");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.positive("a"); }),
            "T.toml: a: expected a number, got a string");
  EXPECT_EQ(error_of("g = -1\n", [](const ds::TomlView& v) { v.positive("g"); }),
            "T.toml: g: expected a number > 0, got -1");
  EXPECT_EQ(error_of(doc, [](const ds::TomlView& v) { v.integers("f", 0, 9, 4); }),
            "T.toml: f[1]: expected an integer in [0, 9], got a string");
  EXPECT_EQ(
      error_of("m = [[1, 0, 0], [0, 1, 0]]\n", [](const ds::TomlView& v) { v.mat3_rows("m"); }),
      "T.toml: m: expected a 3×3 array of rows, got 2 rows");
  // fail(): the caller's own check, in the same shape.
  EXPECT_EQ(error_of("[x]\ny = 1\n",
                     [](const ds::TomlView& v) { v.table("x").fail("y", "a thing", "another"); }),
            "T.toml: x.y: expected a thing, got another");
}

TEST(TomlView, MissingKeysAndDefaults) {
  EXPECT_EQ(error_of("", [](const ds::TomlView& v) { v.str("format"); }),
            "T.toml: format: expected a string, got missing");
  EXPECT_EQ(error_of("", [](const ds::TomlView& v) { v.positive("rate_hz"); }),
            "T.toml: rate_hz: expected a number > 0, got missing");
  EXPECT_EQ(error_of("", [](const ds::TomlView& v) { v.integer("slave", 1, 247); }),
            "T.toml: slave: expected an integer in [1, 247], got missing");

  const toml::table t = ds::parse_toml_text("port = 5020\nmode = \"fifo\"\nscale = 2\n", "T.toml");
  const ds::TomlView v(t, "T.toml");
  // Present values win over defaults; absent ones take them; both count as consumed.
  EXPECT_EQ(v.integer_or("port", 1, 65535, 502), 5020);
  EXPECT_EQ(v.integer_or("slave", 0, 255, 1), 1);
  EXPECT_EQ(v.str_or("mode", "latest"), "fifo");
  EXPECT_EQ(v.str_or("function", "holding"), "holding");
  EXPECT_DOUBLE_EQ(v.num_or("scale", 1.0), 2.0);
  EXPECT_DOUBLE_EQ(v.num_or("offset", 0.5), 0.5);
  EXPECT_FALSE(v.opt_num("min"));
  EXPECT_FALSE(v.opt_table("calibration"));
  EXPECT_TRUE(v.tables("channels").empty());
  EXPECT_NO_THROW(v.done());
  // A default never hides a present value of the wrong kind.
  EXPECT_EQ(error_of("port = \"502\"\n",
                     [](const ds::TomlView& w) { w.integer_or("port", 1, 65535, 502); }),
            "T.toml: port: expected an integer in [1, 65535], got a string");
}

TEST(TomlView, ArraysOfTablesGiveIndexedPaths) {
  const std::string doc =
      "[[devices]]\nname = \"a\"\n[[devices]]\nname = \"b\"\n"
      "  [[devices.channels]]\n  registers = [1, 2]\n"
      "  [[devices.channels]]\n  registers = [3]\n  scale = \"x\"\n";
  EXPECT_EQ(error_of(doc,
                     [](const ds::TomlView& v) {
                       for (const auto& d : v.tables("devices")) {
                         d.str("name");
                         for (const auto& c : d.tables("channels")) {
                           c.integers("registers", 0, 65535, 64);
                           c.num_or("scale", 1.0);
                         }
                       }
                     }),
            "T.toml: devices[1].channels[1].scale: expected a number, got a string");
  EXPECT_EQ(error_of(doc,
                     [](const ds::TomlView& v) {
                       const auto devs = v.tables("devices");
                       ASSERT_EQ(devs.size(), 2u);
                       EXPECT_EQ(devs[1].path(), "devices[1]");
                       devs[1].tables("channels")[0].done();
                     }),
            "T.toml: devices[1].channels[0].registers: expected a known key (see docs/formats.md), "
            "got unknown key");
  EXPECT_EQ(error_of("devices = [1, 2]\n", [](const ds::TomlView& v) { v.tables("devices"); }),
            "T.toml: devices[0]: expected a table, got an integer");
  EXPECT_EQ(error_of("devices = 3\n", [](const ds::TomlView& v) { v.tables("devices"); }),
            "T.toml: devices: expected an array of tables ([[devices]]), got an integer");
  // Values inside nested arrays: registers[1] of the second channel.
  EXPECT_EQ(error_of("[[c]]\nr = [1]\n[[c]]\nr = [1, 70000]\n",
                     [](const ds::TomlView& v) {
                       for (const auto& c : v.tables("c")) c.integers("r", 0, 65535, 64);
                     }),
            "T.toml: c[1].r[1]: expected an integer in [0, 65535], got 70000");
}
