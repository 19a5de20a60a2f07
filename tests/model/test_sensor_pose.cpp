// The sensor's mounting from static loads (sensor_pose.hpp) against loads synthesised
// from a known rotation and origin: exact data recover them, hung weights alone leave the
// origin along gravity open (and say so), noise costs what it should.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <glm/gtc/matrix_transform.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/sensor_pose.hpp"

namespace bm = burrbench::model;

namespace {

const glm::dmat3 kQ = glm::dmat3(glm::rotate(glm::dmat4(1.0), 2.2, glm::normalize(glm::dvec3(0.3, -1, 0.7))));
const glm::dvec3 kO{12, -7, 30};

bm::StaticLoad load(glm::dvec3 f_rig, glm::dvec3 a_rig) {
  return {f_rig, a_rig, glm::transpose(kQ) * f_rig, glm::transpose(kQ) * glm::cross(a_rig - kO, f_rig)};
}

double angle_deg(const glm::dmat3& A, const glm::dmat3& B) {
  const glm::dmat3 D = glm::transpose(A) * B;
  return std::acos(std::clamp((D[0][0] + D[1][1] + D[2][2] - 1) / 2, -1.0, 1.0)) * 180 / M_PI;
}

std::vector<bm::StaticLoad> weights_and_a_pull() {
  const glm::dvec3 g{0, 0, -9.80665};
  return {load(0.5 * g, {50, 0, 80}), load(0.2 * g, {0, 40, 80}), load(1.0 * g, {-30, -20, 60}),
          load({5, 0, 0}, {0, 0, 70})};
}

}  // namespace

TEST(SensorPose, ExactLoadsRecoverRotationAndOrigin) {
  const auto fit = bm::estimate_sensor_pose(weights_and_a_pull(), "loads.toml");
  EXPECT_LT(angle_deg(fit.rotation_sensor_to_rig, kQ), 1e-7);
  EXPECT_NEAR(glm::length(fit.origin_rig_mm - kO), 0, 1e-6);
  EXPECT_EQ(fit.unobservable_rig, glm::dvec3(0));
  EXPECT_LT(fit.force_rms_N, 1e-9);
  EXPECT_LT(fit.moment_rms_Nmm, 1e-6);
}

TEST(SensorPose, HungWeightsAloneLeaveTheOriginAlongGravityOpen) {
  auto loads = weights_and_a_pull();
  loads.pop_back();  // no sideways pull: every load is vertical
  const auto fit = bm::estimate_sensor_pose(loads, "loads.toml");
  EXPECT_LT(angle_deg(fit.rotation_sensor_to_rig, kQ), 1e-7);  // the moments fix the rotation
  EXPECT_NEAR(std::abs(fit.unobservable_rig.z), 1.0, 1e-9);
  EXPECT_NEAR(fit.origin_rig_mm.x, kO.x, 1e-6);
  EXPECT_NEAR(fit.origin_rig_mm.y, kO.y, 1e-6);
  EXPECT_NEAR(fit.origin_rig_mm.z, 0.0, 1e-6);  // least norm along the open direction
  EXPECT_LT(fit.moment_rms_Nmm, 1e-6);          // the data cannot tell: they fit exactly
}

TEST(SensorPose, NoiseCostsWhatItShould) {
  // 0.01 N and 0.5 N·mm of noise per component (a good six-axis sensor's averaged tare):
  // the rotation within 0.2°, the origin within 0.5 mm, residuals at the noise.
  std::mt19937_64 rng(3);
  std::normal_distribution<double> nf(0, 0.01), nm(0, 0.5);
  double worst_angle = 0, worst_origin = 0;
  for (int trial = 0; trial < 20; ++trial) {
    auto loads = weights_and_a_pull();
    loads.push_back(load({0, -4, 0}, {20, 30, 70}));
    for (auto& l : loads) {
      l.force_sensor_N += glm::dvec3(nf(rng), nf(rng), nf(rng));
      l.moment_sensor_Nmm += glm::dvec3(nm(rng), nm(rng), nm(rng));
    }
    const auto fit = bm::estimate_sensor_pose(loads, "loads.toml");
    worst_angle = std::max(worst_angle, angle_deg(fit.rotation_sensor_to_rig, kQ));
    worst_origin = std::max(worst_origin, glm::length(fit.origin_rig_mm - kO));
    EXPECT_LT(fit.force_rms_N, 0.05);
    EXPECT_LT(fit.moment_rms_Nmm, 2.0);
  }
  EXPECT_LT(worst_angle, 0.2);
  EXPECT_LT(worst_origin, 0.5);
  std::printf("  noise: worst rotation error %.3f deg, origin %.3f mm over 20 trials\n", worst_angle, worst_origin);
}

TEST(SensorPose, TooFewOrDegenerateLoadsAreRefused) {
  auto loads = weights_and_a_pull();
  EXPECT_THROW(bm::estimate_sensor_pose({loads[0]}, "l.toml"), burrbench::InputError);
  auto zero = loads;
  zero[1].force_rig_N = glm::dvec3(0);
  EXPECT_THROW(bm::estimate_sensor_pose(zero, "l.toml"), burrbench::InputError);
  auto nan = loads;
  nan[2].moment_sensor_Nmm.x = NAN;
  EXPECT_THROW(bm::estimate_sensor_pose(nan, "l.toml"), burrbench::InputError);
  // Two vertical loads on one vertical line: readings along one axis, rotation undetermined.
  const glm::dvec3 g{0, 0, -9.80665};
  EXPECT_THROW(bm::estimate_sensor_pose({load(g, kO + glm::dvec3(0, 0, 10)), load(2.0 * g, kO)}, "l.toml"),
               burrbench::InputError);
}
