// Tare files: what `rig tare` writes reads back exactly; a damaged one is refused with
// the file and the key, never read as a silent zero.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <vector>
#include <array>
#include <cmath>
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

// The tare's statistics from its one-pass sums against a direct two-pass computation over
// the same samples: the mean, the stddev, the drift between the halves and its size in
// standard errors (the noise about each half's own mean). A steady sensor with white
// noise stays under the warning; a force that rises by 20 % of its noise per 100 samples
// is flagged.
TEST(TareStatistics, OnePassSumsAgreeWithATwoPassComputation) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (const double slope : {0.0, 4e-5}) {  // N per sample on x (the others scaled)
    for (const std::size_t n : {std::size_t(3), std::size_t(101), std::size_t(400)}) {
      std::vector<std::array<double, 6>> w(n);
      TareSums sums(n);
      for (std::size_t i = 0; i < n; ++i) {
        for (std::size_t k = 0; k < 6; ++k)
          w[i][k] = 10.0 * double(k + 1) + slope * double(k + 1) * double(i) + noise(rng);
        sums.add(w[i]);
      }
      Tare t;
      sums.finish(t);
      ASSERT_EQ(t.samples, n);
      const std::size_t n1 = (n + 1) / 2, n2 = n - n1;
      double sigmas = 0;
      for (std::size_t k = 0; k < 6; ++k) {
        double mean = 0, m1 = 0, m2 = 0;
        for (std::size_t i = 0; i < n; ++i) (i < n1 ? m1 : m2) += w[i][k];
        mean = (m1 + m2) / double(n);
        m1 /= double(n1);
        m2 /= double(n2);
        double ss = 0, within = 0;
        for (std::size_t i = 0; i < n; ++i) {
          ss += (w[i][k] - mean) * (w[i][k] - mean);
          within += (w[i][k] - (i < n1 ? m1 : m2)) * (w[i][k] - (i < n1 ? m1 : m2));
        }
        EXPECT_NEAR(t.bias[k], mean, 1e-12) << k;
        EXPECT_NEAR(t.stddev[k], std::sqrt(ss / double(n)), 1e-7) << k;
        EXPECT_NEAR(t.drift[k], m2 - m1, 1e-12) << k;
        if (k < 3)
          sigmas = std::max(sigmas, std::abs(m2 - m1) / std::sqrt(within / double(n - 2) * (1.0 / double(n1) + 1.0 / double(n2))));
      }
      EXPECT_NEAR(t.drift_sigmas, sigmas, 1e-6 * sigmas) << "n " << n << " slope " << slope;
      if (n == 400) {
        if (slope == 0) {
          EXPECT_LT(t.drift_sigmas, kTareDriftSigmas);
        } else {
          EXPECT_GT(t.drift_sigmas, kTareDriftSigmas);
        }
      }
    }
  }
}
