// The pre-fit at held geometry (Objective::prefit): FixedGeometryModel predicts a replay at
// other C1's and μ's from one replay's per-class terms, and the pre-fit built on it reports
// the replayed cost of the point it ends at.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <unistd.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "burrbench/calibration/fixed_geometry_model.hpp"
#include "burrbench/calibration/objective.hpp"
#include "burrbench/calibration/replay_model.hpp"
#include "burrbench/model/experiment.hpp"
#include "reference_fixture.hpp"

namespace bc = burrbench::calibration;
namespace ds = burrbench::data_schema;
namespace fs = std::filesystem;

namespace {

// The reference experiment with the moment and spindle channels, made once for the file.
class FixedGeometry : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / fmt::format("bb_fixed_geometry_{}", ::getpid()));
    fs::remove_all(*dir_);
    bc::testing::ReferenceSpec s;
    s.time_scale = 0.5;
    s.wrench = true;
    bc::testing::make_reference_experiment(*dir_, s, bc::testing::burrbench_cli());
    exp_ = new burrbench::model::Experiment(burrbench::model::load_experiment(*dir_ / "experiment_wrench.toml"));
  }
  static void TearDownTestSuite() {
    delete exp_;
    fs::remove_all(*dir_);
    delete dir_;
  }
  static fs::path* dir_;
  static burrbench::model::Experiment* exp_;
};
fs::path* FixedGeometry::dir_ = nullptr;
burrbench::model::Experiment* FixedGeometry::exp_ = nullptr;

bc::EvalPoint point(double c1_1, double mu_1, double c1_2, double mu_2, bool geometry_terms) {
  bc::EvalPoint at;
  at.physics.alpha[1] = 150, at.physics.c1[1] = c1_1, at.physics.mu[1] = mu_1;
  at.physics.alpha[2] = 60, at.physics.c1[2] = c1_2, at.physics.mu[2] = mu_2;
  at.lag_ms = 4;
  at.geometry_terms = geometry_terms;
  return at;
}

double max_norm(const std::vector<glm::dvec3>& v) {
  double m = 0;
  for (const auto& x : v) m = std::max(m, glm::length(x));
  return m;
}

double max_abs(const std::vector<double>& v) {
  double m = 0;
  for (const double x : v) m = std::max(m, std::abs(x));
  return m;
}

// Largest |a − b| against the larger of the two's largest entry.
double rel_diff(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b) {
  double d = 0;
  for (std::size_t j = 0; j < a.size(); ++j) d = std::max(d, glm::length(a[j] - b[j]));
  return d / std::max({max_norm(a), max_norm(b), 1e-300});
}

double rel_diff(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0;
  for (std::size_t j = 0; j < a.size(); ++j) d = std::max(d, std::abs(a[j] - b[j]));
  return d / std::max({max_abs(a), max_abs(b), 1e-300});
}

const std::vector<bc::Column> kColumns{{bc::ColumnKind::kLogC1, 1},
                                       {bc::ColumnKind::kLogMu, 1},
                                       {bc::ColumnKind::kLogC1, 2},
                                       {bc::ColumnKind::kLogMu, 2}};

}  // namespace

// Without erosion the geometry of every replay is the scan's: predicting from one replay's
// terms at other C1's and μ's must give what replaying there gives, on every channel, also
// where both classes share the contact (the sweep across their boundary).
TEST_F(FixedGeometry, PredictsAnotherReplayExactlyWhenTheGeometryCannotMove) {
  bc::ReplayPool pool(exp_->samples, 2);
  burrbench::model::ReplayOptions no_erosion;
  no_erosion.erosion = false;
  const auto it = std::find_if(exp_->recordings.begin(), exp_->recordings.end(),
                               [](const auto& r) { return r.id == "sweep"; });
  ASSERT_NE(it, exp_->recordings.end());
  const auto& rec = *it;
  bc::ReplayRecordingModel m(rec, pool, no_erosion);
  m.set_channels({true, true}, "experiment_wrench.toml");

  bc::Prediction at_replay;
  m.predict(point(16, 0.4, 6, 0.3, false), {}, at_replay);
  ASSERT_NE(at_replay.fixed, nullptr);
  ASSERT_EQ(at_replay.fixed->labels, (std::vector<std::uint8_t>{1, 2}));
  std::size_t shared = 0;  // samples with both classes in contact
  for (const auto mask : at_replay.class_mask) shared += mask == 0b110;
  EXPECT_GT(shared, 20u);
  const bc::FixedGeometryModel held(m, at_replay);

  bc::Prediction replayed, predicted;
  const auto elsewhere = point(27, 0.15, 2.5, 0.9, false);
  m.predict(elsewhere, kColumns, replayed);
  held.predict(elsewhere, kColumns, predicted);
  EXPECT_EQ(predicted.replays, 0u);
  EXPECT_GT(max_norm(replayed.force_sensor_N), 1.0);
  EXPECT_LT(rel_diff(predicted.force_sensor_N, replayed.force_sensor_N), 1e-12);
  EXPECT_LT(rel_diff(predicted.torque_sensor_Nmm, replayed.torque_sensor_Nmm), 1e-12);
  EXPECT_LT(rel_diff(predicted.spindle_Nmm, replayed.spindle_Nmm), 1e-12);
  EXPECT_EQ(predicted.buried, replayed.buried);
  // Its columns against the replay model's fixed-geometry partials (a second
  // implementation), and against its own central differences.
  ASSERT_EQ(predicted.columns.size(), kColumns.size());
  for (std::size_t c = 0; c < kColumns.size(); ++c) {
    SCOPED_TRACE(c);
    EXPECT_GT(max_norm(replayed.columns[c]), 1e-3);
    EXPECT_LT(rel_diff(predicted.columns[c], replayed.columns[c]), 1e-10);
    EXPECT_LT(rel_diff(predicted.torque_columns[c], replayed.torque_columns[c]), 1e-10);
    EXPECT_LT(rel_diff(predicted.spindle_columns[c], replayed.spindle_columns[c]), 1e-10);
    const double h = 1e-5;
    bc::Prediction up, down;
    auto moved = [&](double s) {
      auto at = elsewhere;
      const auto k = kColumns[c].label;
      double& v = kColumns[c].kind == bc::ColumnKind::kLogC1 ? at.physics.c1[k] : at.physics.mu[k];
      v *= std::exp(s * h);
      return at;
    };
    held.predict(moved(+1), {}, up);
    held.predict(moved(-1), {}, down);
    std::vector<glm::dvec3> fd(up.force_sensor_N.size());
    for (std::size_t j = 0; j < fd.size(); ++j) fd[j] = (up.force_sensor_N[j] - down.force_sensor_N[j]) / (2 * h);
    EXPECT_LT(rel_diff(predicted.columns[c], fd), 1e-8);
  }
}

// With erosion the pre-fit moves each α with its class's C1·μ so that the geometry stays:
// it ends far below its start's cost within 3 replays per recording, and the cost it
// reports is the replayed cost of its end point, not the held-geometry prediction's.
TEST_F(FixedGeometry, PreFitReportsTheReplayedCostOfItsEndWithinThreeReplays) {
  bc::ReplayPool pool(exp_->samples, 2);
  std::vector<std::unique_ptr<bc::ReplayRecordingModel>> models;
  std::vector<const bc::RecordingModel*> ptrs;
  std::vector<std::pair<std::string, double>> ids;
  bc::SampleWeights w;
  for (const auto& rec : exp_->recordings) {
    models.push_back(std::make_unique<bc::ReplayRecordingModel>(rec, pool));
    ptrs.push_back(models.back().get());
    ids.emplace_back(rec.id, 0.0);
    w.emplace_back(rec.t_s.size(), 1.0);
  }
  auto spec = [](double a, double c, double m) {
    ds::ClassFitSpec s;
    s.alpha = {a, 1.0, 1e5, false};
    s.c1 = {c, 1e-2, 1e4, false};
    s.mu = {m, 1e-2, 3.0, false};
    return s;
  };
  ds::NuisanceSpec nz;
  nz.bias = true;
  nz.lag = true;
  // Compact C1 and μ a factor 3 off the truth (16, 0.4), trabecular's (6, 0.3) the other way.
  const bc::Layout layout({{1, {"compact", spec(150, 48, 0.13)}}, {2, {"trabecular", spec(60, 2, 0.9)}}},
                          ids, nz, 0.5);
  const bc::Objective obj(layout, ptrs, {});
  std::vector<double> start = layout.initial();
  for (const auto& r : layout.recordings()) start[std::size_t(r.lag)] = 4;
  const auto before = obj.replays();
  const auto out = obj.prefit(start, w, {});
  const auto spent = obj.replays() - before;
  ASSERT_TRUE(out.usable) << out.termination;
  EXPECT_LE(spent, 3 * ptrs.size()) << out.termination;
  EXPECT_LT(out.final_cost, out.initial_cost / 5) << out.termination;
  const double replayed = obj.evaluate(out.x, w).cost;
  EXPECT_NEAR(out.final_cost, replayed, 1e-9 * replayed);
  // α_k moved with C1_k·μ_k; the lags stayed.
  const auto a = layout.physics_values(start.data()), b = layout.physics_values(out.x.data());
  for (const std::size_t k : {1, 2}) {
    SCOPED_TRACE(k);
    EXPECT_NE(b.c1[k], a.c1[k]);
    EXPECT_NEAR(b.alpha[k] / a.alpha[k], (b.c1[k] * b.mu[k]) / (a.c1[k] * a.mu[k]), 1e-9 * b.alpha[k] / a.alpha[k]);
  }
  for (const auto& r : layout.recordings()) EXPECT_EQ(out.x[std::size_t(r.lag)], start[std::size_t(r.lag)]);
}

// The identity the pre-fit rests on, with erosion: a voxel of class k loses bone at a rate
// ∝ μ_k·|F_e|/α_k, so moving α_k by the factor C1_k·μ_k moved keeps the geometry of a
// recording in one class, and the held-geometry prediction there equals a replay. Without
// the α move the eroded shape differs and so does the force.
TEST_F(FixedGeometry, MovingAlphaWithC1TimesMuKeepsTheErodedGeometry) {
  bc::ReplayPool pool(exp_->samples, 2);
  const auto it = std::find_if(exp_->recordings.begin(), exp_->recordings.end(),
                               [](const auto& r) { return r.id == "polish"; });
  ASSERT_NE(it, exp_->recordings.end());
  bc::ReplayRecordingModel m(*it, pool);
  m.set_channels({true, true}, "experiment_wrench.toml");
  bc::Prediction at_replay;
  m.predict(point(16, 0.4, 6, 0.3, false), {}, at_replay);
  ASSERT_NE(at_replay.fixed, nullptr);
  ASSERT_EQ(at_replay.fixed->labels, (std::vector<std::uint8_t>{1}));  // compact only
  EXPECT_GT(at_replay.removed_mm3[1], 0.0);
  const bc::FixedGeometryModel held(m, at_replay);

  auto elsewhere = point(16 * 2.0, 0.4 * 0.7, 6, 0.3, false);
  bc::Prediction predicted, followed, kept;
  held.predict(elsewhere, {}, predicted);
  elsewhere.physics.alpha[1] *= 2.0 * 0.7;  // α with C1·μ
  m.predict(elsewhere, {}, followed);
  EXPECT_NEAR(followed.removed_mm3[1], at_replay.removed_mm3[1], 1e-9 * at_replay.removed_mm3[1]);
  EXPECT_LT(rel_diff(predicted.force_sensor_N, followed.force_sensor_N), 1e-9);  // 1.5e-13 measured
  EXPECT_LT(rel_diff(predicted.torque_sensor_Nmm, followed.torque_sensor_Nmm), 1e-9);
  EXPECT_LT(rel_diff(predicted.spindle_Nmm, followed.spindle_Nmm), 1e-9);
  // α left where it was: 1.4× the erosion rate, more bone removed, another force.
  elsewhere.physics.alpha[1] = 150;
  m.predict(elsewhere, {}, kept);
  EXPECT_GT(kept.removed_mm3[1], 1.01 * at_replay.removed_mm3[1]);
  EXPECT_GT(rel_diff(predicted.force_sensor_N, kept.force_sensor_N), 1e-2);  // 4.9 % measured
}
