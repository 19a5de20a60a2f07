// Registration rig → volume: recovery of a known transform, RMS error, bad fiducials.
#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>
#include <random>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/registration.hpp"

using burrbench::InputError;
using namespace burrbench::model;

namespace {
glm::dmat3 rotation(double angle_rad, glm::dvec3 axis) {
  return glm::dmat3(glm::rotate(glm::dmat4(1.0), angle_rad, glm::normalize(axis)));
}
}  // namespace

TEST(Registration, RecoversKnownTransformExactly) {
  const glm::dmat3 R = rotation(1.1, {0.3, -0.5, 0.8});
  const glm::dvec3 t{12.5, -3.0, 40.0};
  std::vector<glm::dvec3> rig{{0, 0, 0}, {10, 0, 0}, {0, 15, 0}, {0, 0, 7}, {5, 5, 5}};
  std::vector<glm::dvec3> vol;
  for (auto& p : rig) vol.push_back(R * p + t);
  const auto fit = fit_rigid(rig, vol);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(fit.transform.R[i][j], R[i][j], 1e-12);
  EXPECT_NEAR(glm::length(fit.transform.t - t), 0.0, 1e-10);
  EXPECT_LT(fit.rms_mm, 1e-10);
  // inverse maps volume back to rig
  EXPECT_NEAR(glm::length(fit.transform.inverse().apply(vol[4]) - rig[4]), 0.0, 1e-10);
}

TEST(Registration, NoisyFiducialsRmsMatchesNoise) {
  const glm::dmat3 R = rotation(-2.3, {1, 1, 0});
  const glm::dvec3 t{-1, 2, 3};
  std::mt19937_64 gen(7);
  std::normal_distribution<double> noise(0.0, 0.05);  // 50 µm per coordinate
  std::uniform_real_distribution<double> u(-20, 20);
  std::vector<glm::dvec3> rig, vol;
  for (int i = 0; i < 40; ++i) {
    glm::dvec3 p{u(gen), u(gen), u(gen)};
    rig.push_back(p);
    vol.push_back(R * p + t + glm::dvec3{noise(gen), noise(gen), noise(gen)});
  }
  const auto fit = fit_rigid(rig, vol);
  // Rotation error well below the noise over a 20 mm lever, translation within noise.
  double angle_err = std::acos(std::clamp(
      (glm::dot(glm::dvec3(1, 0, 0), glm::transpose(R) * fit.transform.R * glm::dvec3(1, 0, 0))),
      -1.0, 1.0));
  EXPECT_LT(angle_err, 0.005);
  EXPECT_LT(glm::length(fit.transform.t - t), 0.05);
  // RMS of 3-D residuals ≈ σ√3·√((n−6)/n) (6 fitted dof): within 20 %.
  const double expected = 0.05 * std::sqrt(3.0) * std::sqrt((40.0 - 6.0) / 40.0);
  EXPECT_NEAR(fit.rms_mm, expected, 0.2 * expected);
  EXPECT_EQ(fit.residual_mm.size(), 40u);
  EXPECT_GE(fit.max_mm, fit.rms_mm);
}

TEST(Registration, HandlesHalfTurnAndThreePoints) {
  const glm::dmat3 R = rotation(M_PI, {0, 0, 1});  // 180°: quaternion scalar part 0
  std::vector<glm::dvec3> rig{{1, 0, 0}, {0, 2, 0}, {0, 0, 3}};
  std::vector<glm::dvec3> vol;
  for (auto& p : rig) vol.push_back(R * p);
  const auto fit = fit_rigid(rig, vol);
  EXPECT_LT(fit.rms_mm, 1e-10);
  EXPECT_NEAR(glm::determinant(fit.transform.R), 1.0, 1e-12);
}

TEST(Registration, RejectsTooFewOrCollinearOrMismatched) {
  std::vector<glm::dvec3> two{{0, 0, 0}, {1, 0, 0}};
  EXPECT_THROW(fit_rigid(two, two, "m.toml"), InputError);
  std::vector<glm::dvec3> line{{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {5, 5, 5}};
  try {
    fit_rigid(line, line, "m.toml", "recordings[0].registration");
    FAIL() << "collinear fiducials accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("m.toml: recordings[0].registration"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("collinear"), std::string::npos);
  }
  std::vector<glm::dvec3> three{{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  EXPECT_THROW(fit_rigid(three, line, "m.toml"), InputError);
}

TEST(Registration, CheckRotationRejectsReflectionAndScale) {
  EXPECT_NO_THROW(check_rotation(rotation(0.4, {1, 2, 3}), "f", "r"));
  glm::dmat3 mirror(1.0);
  mirror[2][2] = -1;
  EXPECT_THROW(check_rotation(mirror, "f", "r"), InputError);
  EXPECT_THROW(check_rotation(glm::dmat3(1.01), "f", "r"), InputError);
}

// Fitzpatrick's predicted TRE against Monte Carlo: perturb four fiducials by an isotropic
// FLE, fit, measure the error at targets near and far from the fiducials' centroid.
TEST(Registration, PredictedTreMatchesMonteCarlo) {
  const glm::dmat3 R = rotation(0.65, {0.2, 0.9, -0.4});  // 37° about a tilted axis
  const glm::dvec3 t{3.0, -7.0, 30.0};
  const std::vector<glm::dvec3> rig{{0, 0, 0}, {12, 1, 0}, {2, 10, 1}, {3, 4, 8}};
  std::vector<glm::dvec3> vol;
  for (const auto& p : rig) vol.push_back(R * p + t);
  const double fle = 0.005;  // 5 µm RMS (3-D)
  std::mt19937_64 gen(11);
  std::normal_distribution<double> n(0.0, fle / std::sqrt(3.0));
  const std::vector<glm::dvec3> targets_rig{{4, 4, 2}, {20, 15, -5}, {-10, 0, 12}};
  std::vector<double> ss(targets_rig.size(), 0.0);
  const int trials = 4000;
  for (int k = 0; k < trials; ++k) {
    std::vector<glm::dvec3> noisy = vol;
    for (auto& p : noisy) p += glm::dvec3(n(gen), n(gen), n(gen));
    const auto fit = fit_rigid(rig, noisy);
    for (std::size_t i = 0; i < targets_rig.size(); ++i) {
      const glm::dvec3 e = fit.transform.apply(targets_rig[i]) - (R * targets_rig[i] + t);
      ss[i] += glm::dot(e, e);
    }
  }
  for (std::size_t i = 0; i < targets_rig.size(); ++i) {
    const double measured = std::sqrt(ss[i] / trials);
    const double predicted = predicted_tre_mm(vol, fle, R * targets_rig[i] + t);
    EXPECT_NEAR(predicted / measured, 1.0, 0.08) << "target " << i << ": " << predicted << " vs " << measured;
  }
}

// Two exchanged rows give an absurd RMS: refused with one line naming the worst fiducial
// and the swapped pair; a fit within the limit passes.
TEST(Registration, SwappedFiducialsAreRefusedAndNamed) {
  const glm::dmat3 R = rotation(0.65, {0.2, 0.9, -0.4});
  const glm::dvec3 t{3.0, -7.0, 30.0};
  const std::vector<glm::dvec3> rig{{0, 0, 0}, {12, 1, 0}, {2, 10, 1}, {3, 4, 8}};
  std::vector<glm::dvec3> vol;
  for (const auto& p : rig) vol.push_back(R * p + t + glm::dvec3(0.002, -0.001, 0.001));
  const auto good = fit_rigid(rig, vol);
  EXPECT_NO_THROW(check_fiducial_fit(good, rig, vol, 3 * 0.005, "m.toml", "fid"));
  std::swap(vol[1], vol[2]);
  const auto bad = fit_rigid(rig, vol);
  try {
    check_fiducial_fit(bad, rig, vol, 3 * 0.005, "m.toml", "recordings[0].registration.fiducials_vol_mm");
    FAIL() << "swapped fiducials accepted (RMS " << bad.rms_mm << " mm)";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("m.toml"), std::string::npos) << m;
    EXPECT_NE(m.find("rows 1 and 2 look swapped"), std::string::npos) << m;
    EXPECT_NE(m.find("worst fiducial"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}
