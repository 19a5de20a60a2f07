// Protocols: parsing with key-path errors, and the sampled path against a flat slab
// (positions, speeds, depths measured from the bone surface, spindle speed).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/protocol.hpp"

using burrbench::InputError;
using namespace burrbench::model;
namespace ds = burrbench::data_schema;

namespace {
// 4×4×3 mm block, 0.1 mm voxels, cells k = 0..19 bone: top face at z = 2.0 mm.
ds::SampleVolume slab() {
  ds::SampleVolume s;
  s.dims = {40, 40, 30};
  s.voxel_mm = 0.1;
  s.origin_mm = {0.05, 0.05, 0.05};
  s.labels.assign(s.voxel_count(), 0);
  s.fraction.assign(s.voxel_count(), 0.f);
  for (std::size_t z = 0; z < 20; ++z)
    for (std::size_t y = 0; y < 40; ++y)
      for (std::size_t x = 0; x < 40; ++x) {
        s.labels[s.index(x, y, z)] = 1;
        s.fraction[s.index(x, y, z)] = 1.f;
      }
  return s;
}

std::string header(const std::string& start = "[2.0, 2.0, 3.5]") {
  return "format = \"burrbench.protocol\"\nformat_version = \"1.0\"\nsample_rate_hz = 1000\n"
         "spindle_rpm = 30000\n[burr]\nradius_mm = 1.0\naxis = [0, 0, 2]\nspin_sign = -1\n"
         "[start]\npoint_mm = " +
         start + "\napproach = [0, 0, -1]\n";
}

std::string error_of(const std::string& text) {
  try {
    parse_protocol(text, "p.toml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}
}  // namespace

TEST(Protocol, SurfaceIsWhereTheLeadingPointMeetsBone) {
  const auto s = slab();
  // Leading point starts at z = 2.5, the bone's top face is z = 2.0.
  EXPECT_NEAR(distance_to_surface(s, {2.0, 2.0, 3.5}, {0, 0, -1}, 1.0, "p"), 0.5, 1e-12);
  // Oblique approach: the leading point travels 0.5/cos θ to reach the face.
  const glm::dvec3 a = glm::normalize(glm::dvec3(0.3, 0, -1));
  const double s0 = distance_to_surface(s, {1.0, 2.0, 3.5}, a, 1.0, "p");
  EXPECT_NEAR((3.5 + a.z * 1.0) + s0 * a.z, 2.0, 1e-12);
  EXPECT_THROW(distance_to_surface(s, {2.0, 2.0, 2.5}, {0, 0, -1}, 1.0, "p"),
               InputError);  // in bone
  EXPECT_THROW(distance_to_surface(s, {2.0, 2.0, 3.5}, {0, 0, 1}, 1.0, "p"), InputError);  // away
  EXPECT_THROW(distance_to_surface(s, {9.0, 2.0, 3.5}, {0, 0, -1}, 1.0, "p"),
               InputError);  // beside
}

TEST(Protocol, PlungeDwellRetractPath) {
  const auto p =
      parse_protocol(header() +
                         "[[moves]]\ntype = \"plunge\"\ndepth_mm = 0.25\nfeed_mm_s = 0.5\n"
                         "[[moves]]\ntype = \"dwell\"\nduration_s = 0.2\nspindle_rpm = 10000\n"
                         "[[moves]]\ntype = \"retract\"\nspeed_mm_s = 2.0\n",
                     "p.toml");
  EXPECT_EQ(p.spin_sign, -1);
  EXPECT_DOUBLE_EQ(p.burr_axis_vol.z, 1.0);  // normalised
  const auto path = sample_protocol(p, slab());
  // surface at centre z = 2.0 + R = 3.0; plunge 0.75 mm at 0.5 → 1.5 s, dwell 0.2 s,
  // retract 0.75 mm at 2 → 0.375 s.
  EXPECT_NEAR(path.surface_vol_mm.z, 3.0, 1e-12);
  EXPECT_NEAR(path.duration_s, 1.5 + 0.2 + 0.375, 1e-12);
  ASSERT_EQ(path.t_s.size(), 2076u);
  for (std::size_t k = 0; k < path.t_s.size(); ++k) {
    EXPECT_DOUBLE_EQ(path.t_s[k], double(k) / 1000.0);
    EXPECT_DOUBLE_EQ(path.centre_vol_mm[k].x, 2.0);
    EXPECT_NEAR(path.depth_mm[k], 3.0 - path.centre_vol_mm[k].z, 1e-12);
  }
  // feed during the plunge: 0.5 mm/s
  EXPECT_NEAR((path.centre_vol_mm[100].z - path.centre_vol_mm[1100].z) / 1.0, 0.5, 1e-12);
  EXPECT_NEAR(path.depth_mm[1500], 0.25, 1e-12);
  EXPECT_NEAR(path.depth_mm[1600], 0.25, 1e-12);  // dwelling
  EXPECT_DOUBLE_EQ(path.spindle_rpm[1499], 30000.0);
  EXPECT_DOUBLE_EQ(path.spindle_rpm[1500], 10000.0);  // boundary sample: the later move
  EXPECT_DOUBLE_EQ(path.spindle_rpm[2075], 10000.0);  // sticky
  EXPECT_EQ(path.move[1499], 0);
  EXPECT_EQ(path.move[1600], 1);
  EXPECT_EQ(path.move[2000], 2);
  EXPECT_NEAR(path.centre_vol_mm.back().z, 3.5, 1e-12);  // back at the start height
  const auto w = path.omega_vol_rad_s(p);
  EXPECT_NEAR(w[0].z, -2 * M_PI * 30000.0 / 60.0, 1e-9);  // spin_sign −1
}

TEST(Protocol, SweepKeepsDepthAndSpeedPolishReturns) {
  const auto p = parse_protocol(
      header("[1.0, 2.0, 3.2]") +
          "[[moves]]\ntype = \"plunge\"\ndepth_mm = 0.2\nfeed_mm_s = 1.0\n"
          "[[moves]]\ntype = \"sweep\"\ndirection = [1, 0, 0.5]\nlength_mm = 1.0\nspeed_mm_s = "
          "2.0\n"
          "[[moves]]\ntype = \"polish\"\ndirection = [0, -1, 0]\nlength_mm = 0.5\nstrokes = 3\n"
          "speed_mm_s = 10.0\ndepth_mm = 0.1\nfeed_mm_s = 0.5\n",
      "p.toml");
  EXPECT_NEAR(glm::length(p.moves[1].direction - glm::dvec3(1, 0, 0)), 0, 1e-12);  // made lateral
  const auto path = sample_protocol(p, slab());
  // plunge 0.4 s; sweep 0.5 s; axial 0.1 mm at 0.5 → 0.2 s; polish 6 × 0.05 s.
  EXPECT_NEAR(path.duration_s, 0.4 + 0.5 + 0.2 + 0.3, 1e-12);
  for (std::size_t k = 400; k <= 900; ++k) {
    EXPECT_NEAR(path.depth_mm[k], 0.2, 1e-12);
    EXPECT_NEAR(path.centre_vol_mm[k].x, 1.0 + 2.0 * (double(k) / 1000.0 - 0.4), 1e-12);
  }
  for (std::size_t k = 1100; k < path.t_s.size(); ++k) EXPECT_NEAR(path.depth_mm[k], 0.1, 1e-12);
  // stroke: out 0.5 mm along −y and back, every 0.1 s; far end at t = 1.15 s
  EXPECT_NEAR(path.centre_vol_mm[1150].y, 1.5, 1e-12);
  EXPECT_NEAR(path.centre_vol_mm[1200].y, 2.0, 1e-12);
  EXPECT_NEAR(path.centre_vol_mm[1350].y, 1.5, 1e-12);
  EXPECT_NEAR(path.centre_vol_mm.back().y, 2.0, 1e-12);
  EXPECT_NEAR(path.centre_vol_mm[1125].y - path.centre_vol_mm[1124].y, -0.01, 1e-12);  // 10 mm/s
}

TEST(Protocol, BadProtocolsNameTheKey) {
  EXPECT_NE(error_of(header() + "[[moves]]\ntype = \"plunge\"\nfeed_mm_s = 1\n")
                .find("p.toml: moves[0].depth_mm"),
            std::string::npos);
  EXPECT_NE(error_of(header() + "[[moves]]\ntype = \"drill\"\n").find("moves[0].type"),
            std::string::npos);
  EXPECT_NE(error_of(header() + "[[moves]]\ntype = \"dwell\"\nduration_s = 1\nspeed = 3\n")
                .find("moves[0].speed"),
            std::string::npos);
  EXPECT_NE(error_of(header() + "[[moves]]\ntype = \"sweep\"\ndirection = [0,0,1]\nlength_mm = 1\n"
                                "speed_mm_s = 1\n")
                .find("moves[0].direction"),
            std::string::npos);
  EXPECT_NE(error_of(header() + "[[moves]]\ntype = \"polish\"\ndirection = [1,0,0]\nlength_mm = 1\n"
                                "speed_mm_s = 1\nstrokes = 0\n")
                .find("moves[0].strokes"),
            std::string::npos);
  EXPECT_NE(error_of(header() + "[[moves]]\ntype = \"dwell\"\nduration_s = -1\n")
                .find("moves[0].duration_s"),
            std::string::npos);
  EXPECT_NE(error_of(header()).find("moves"), std::string::npos);
  EXPECT_NE(error_of("format = \"burrbench.params\"\n").find("p.toml: format"), std::string::npos);
  EXPECT_NE(error_of("format = \n").find("valid TOML"), std::string::npos);
  std::string bad_sign = header();
  bad_sign.replace(bad_sign.find("spin_sign = -1"), 14, "spin_sign = 2");
  EXPECT_NE(
      error_of(bad_sign + "[[moves]]\ntype = \"dwell\"\nduration_s = 1\n").find("burr.spin_sign"),
      std::string::npos);
  EXPECT_THROW(read_protocol("/nonexistent/p.toml"), InputError);
  // A path far too long is refused before allocating it.
  std::string bomb = header();
  for (int i = 0; i < 200; ++i)
    bomb +=
        "[[moves]]\ntype = \"polish\"\ndirection = [1,0,0]\nlength_mm = 1\nspeed_mm_s = 1\nstrokes "
        "= 100000\n";
  EXPECT_THROW(sample_protocol(parse_protocol(bomb, "p.toml"), slab()), InputError);
  const auto slow =
      parse_protocol(header() + "[[moves]]\ntype = \"dwell\"\nduration_s = 1e6\n", "p.toml");
  EXPECT_THROW(sample_protocol(slow, slab()), InputError);  // 1e9 samples
}

TEST(Protocol, ShippedExamplesParseAndSample) {
  ds::SampleVolume s;  // the examples' geometry: bone top at z = 3 mm over 8×8 mm
  s.dims = {80, 80, 35};
  s.voxel_mm = 0.1;
  s.origin_mm = {0.05, 0.05, 0.05};
  s.labels.assign(s.voxel_count(), 0);
  s.fraction.assign(s.voxel_count(), 0.f);
  for (std::size_t i = 0; i < 80 * 80 * 30; ++i) s.labels[i] = 1, s.fraction[i] = 1.f;
  for (const char* name : {"plunge", "sweep", "polish"}) {
    const auto p = read_protocol(std::filesystem::path(BURRBENCH_SOURCE_DIR) /
                                 "examples/protocols" / (std::string(name) + ".toml"));
    const auto path = sample_protocol(p, s);
    EXPECT_NEAR(path.surface_vol_mm.z, 4.0, 1e-12) << name;
    EXPECT_GT(path.t_s.size(), 1000u) << name;
    double deepest = -1e9;
    for (double d : path.depth_mm) deepest = std::max(deepest, d);
    EXPECT_GT(deepest, 0.09) << name;
    EXPECT_LT(deepest, 0.26) << name;
  }
}
