// Tare files: what `rig tare` writes reads back exactly; a damaged one is refused with
// the file and the key, never read as a silent zero.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/rig/tools.hpp"

using namespace burrbench::rig;
namespace fs = std::filesystem;

namespace {
fs::path temp_path(const std::string& name) {
  return fs::temp_directory_path() / ("bb_tare_" + std::to_string(::getpid()) + "_" + name);
}

Tare sample_tare() {
  Tare t;
  t.device = "ft_sensor";
  t.bias = {0.5, -1.25, 3.0, 10.0, -20.5, 0.125};
  t.stddev = {0.01, 0.02, 0.03, 0.1, 0.2, 0.3};
  t.samples = 200;
  t.t_ns = 123456789012;
  t.wall_ns = 1700000000123456789;
  t.rig_sha256 = std::string(64, 'a');
  return t;
}

std::string error_of(const fs::path& p) {
  try {
    read_tare(p);
  } catch (const burrbench::InputError& e) {
    return e.what();
  }
  return "(no error)";
}
}  // namespace

TEST(TareFile, RoundTrips) {
  const auto p = temp_path("ok.toml");
  const Tare t = sample_tare();
  write_tare(p, t);
  const Tare r = read_tare(p);
  EXPECT_EQ(r.device, t.device);
  EXPECT_EQ(r.bias, t.bias);
  EXPECT_EQ(r.stddev, t.stddev);
  EXPECT_EQ(r.samples, t.samples);
  EXPECT_EQ(r.t_ns, t.t_ns);
  EXPECT_EQ(r.wall_ns, t.wall_ns);
  EXPECT_EQ(r.rig_sha256, t.rig_sha256);
  fs::remove(p);
}

TEST(TareFile, DefectsNameFileAndKey) {
  const auto p = temp_path("bad.toml");
  write_tare(p, sample_tare());
  std::string text;
  {
    std::ifstream in(p);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  struct Case {
    std::string from, to, message;
  };
  const Case cases[] = {
      {"bias = [", "bias = [ 9, ", "bias: expected an array of 6 numbers, got 7 elements"},
      {"t_monotonic_ns = ", "t_monotonic_ns = 1.5\nx_ns = ",
       "t_monotonic_ns: expected an integer, got a float"},
      {"t_wall_ns = ", "t_wall_ns = \"later\"\nx_ns = ",
       "t_wall_ns: expected an integer, got a string"},
      {"device = ", "colour = \"red\"\ndevice = ",
       "colour: expected a known key (see docs/rig.md), got unknown key"},
      {"burrbench.tare", "burrbench.rig",
       "format: expected \"burrbench.tare\", got \"burrbench.rig\""},
  };
  for (const auto& c : cases) {
    std::string bad = text;
    const auto at = bad.find(c.from);
    ASSERT_NE(at, std::string::npos) << c.from;
    bad.replace(at, c.from.size(), c.to);
    { std::ofstream(p) << bad; }
    EXPECT_EQ(error_of(p), p.string() + ": " + c.message) << bad;
  }
  fs::remove(p);
}
