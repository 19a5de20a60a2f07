// ReplayRecordingModel remembers its last predictions: a solve that starts where the one
// before ended (refine after the search, the covariance at the optimum) gets the Jacobian
// there without replaying it, identical to a fresh replay.
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "burrbench/calibration/replay_model.hpp"
#include "burrbench/model/experiment.hpp"
#include "reference_fixture.hpp"

namespace bc = burrbench::calibration;
namespace fs = std::filesystem;

namespace {

std::string cli() { return burrbench::calibration::testing::burrbench_cli(); }

bc::EvalPoint point(double c1_compact) {
  bc::EvalPoint at;
  at.physics.alpha[1] = 150, at.physics.c1[1] = c1_compact, at.physics.mu[1] = 0.4;
  at.physics.alpha[2] = 60, at.physics.c1[2] = 6, at.physics.mu[2] = 0.3;
  at.lag_ms = 4;
  return at;
}

void expect_same(const bc::Prediction& a, const bc::Prediction& b) {
  ASSERT_EQ(a.force_sensor_N.size(), b.force_sensor_N.size());
  for (std::size_t j = 0; j < a.force_sensor_N.size(); ++j) ASSERT_EQ(a.force_sensor_N[j], b.force_sensor_N[j]) << j;
  EXPECT_EQ(a.buried, b.buried);
  EXPECT_EQ(a.class_mask, b.class_mask);
  EXPECT_EQ(a.removed_mm3, b.removed_mm3);
  ASSERT_EQ(a.columns.size(), b.columns.size());
  for (std::size_t c = 0; c < a.columns.size(); ++c) EXPECT_EQ(a.columns[c], b.columns[c]) << c;
}

// The reference experiment at time scale 0.5, made afresh in DIR.
burrbench::model::Experiment short_reference(const fs::path& dir) {
  fs::remove_all(dir);
  bc::testing::ReferenceSpec s;
  s.time_scale = 0.5;
  return burrbench::model::load_experiment(bc::testing::make_reference_experiment(dir, s, cli()));
}

}  // namespace

TEST(ReplayMemory, AJacobianAtAPointAlreadyReplayedIsNotReplayedAgain) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("bb_replay_memory_{}", ::getpid());
  const auto exp = short_reference(dir);
  bc::ReplayPool pool(exp.samples, 2);
  const auto& rec = exp.recordings.front();
  bc::ReplayRecordingModel m(rec, pool);
  m.set_derivatives(bc::Derivatives::kSensitivities);
  const std::vector<bc::Column> cols{{bc::ColumnKind::kLogAlpha, 1},
                                     {bc::ColumnKind::kLogC1, 1},
                                     {bc::ColumnKind::kLagMs, 0}};
  bc::Prediction first, again, values, other;
  m.predict(point(16), cols, first);
  EXPECT_GT(first.replays, 0u);
  m.predict(point(16), cols, again);
  EXPECT_EQ(again.replays, 0u);
  EXPECT_EQ(m.remembered(), 1u);
  expect_same(first, again);
  // The values alone come from the remembered Jacobian too, without its columns.
  m.predict(point(16), {}, values);
  EXPECT_EQ(values.replays, 0u);
  EXPECT_TRUE(values.columns.empty());
  ASSERT_EQ(values.force_sensor_N, first.force_sensor_N);
  // Another point, or other columns, is replayed.
  m.predict(point(16.5), cols, other);
  EXPECT_GT(other.replays, 0u);
  m.predict(point(16), {cols[0]}, other);
  EXPECT_GT(other.replays, 0u);
  EXPECT_EQ(m.remembered(), 2u);
  // Values at other points (a solve's trial points) do not push out a Jacobian: four
  // values are kept beside the last two Jacobians, the oldest value going first.
  for (double c1 : {17.0, 17.5, 18.0, 18.5}) {
    m.predict(point(c1), {}, other);
    EXPECT_GT(other.replays, 0u) << c1;
  }
  m.predict(point(16), {cols[0]}, other);
  EXPECT_EQ(other.replays, 0u) << "values pushed out the last Jacobian";
  m.predict(point(16.5), cols, other);
  EXPECT_EQ(other.replays, 0u) << "values pushed out the Jacobian before it";
  m.predict(point(17.0), {}, other);
  EXPECT_EQ(other.replays, 0u);
  m.predict(point(19.0), {}, other);
  m.predict(point(17.0), {}, other);
  EXPECT_GT(other.replays, 0u) << "a fifth value kept";
  // Changing how derivatives are taken forgets: the next prediction is a fresh replay, and
  // equal to the first (a replay is deterministic).
  m.set_derivatives(bc::Derivatives::kFiniteDifferences);
  m.set_derivatives(bc::Derivatives::kSensitivities);
  bc::Prediction fresh;
  m.predict(point(16), cols, fresh);
  EXPECT_GT(fresh.replays, 0u);
  expect_same(first, fresh);
  fs::remove_all(dir);
}

// The pool tallies what its replays cost, by kind, for the plain-replay equivalents that
// fit.json and the summary report (docs/calibration.md "Derivatives"): every replay run
// counts once in its kind, with its samples; a remembered prediction costs none; a
// sensitivity replay does a plain replay's work and its tangents, so it costs more CPU
// per sample.
TEST(ReplayMemory, ThePoolTalliesItsReplaysByKind) {
  const fs::path dir = fs::temp_directory_path() / fmt::format("bb_replay_work_{}", ::getpid());
  const auto exp = short_reference(dir);
  bc::ReplayPool pool(exp.samples, 2);
  const auto& rec = exp.recordings.front();
  bc::ReplayRecordingModel m(rec, pool);
  const std::vector<bc::Column> cols{{bc::ColumnKind::kLogAlpha, 1}, {bc::ColumnKind::kLagMs, 0}};
  bc::Prediction p;
  m.set_derivatives(bc::Derivatives::kSensitivities);
  for (double c1 : {16.0, 16.0, 16.5}) m.predict(point(c1), cols, p);  // the second is remembered
  for (double c1 : {17.0, 17.5}) m.predict(point(c1), {}, p);
  const std::uint64_t n = m.size();
  auto w = pool.work_done();
  EXPECT_EQ(w.sensitivity.replays, 2u);
  EXPECT_EQ(w.sensitivity.samples, 2 * n);
  EXPECT_EQ(w.plain.replays, 2u);
  EXPECT_EQ(w.plain.samples, 2 * n);
  EXPECT_GT(w.plain.cpu_s, 0);
  EXPECT_GT(w.sensitivity_cost(), 1.0) << w.sensitivity.cpu_s << " s against " << w.plain.cpu_s << " s";
  // The differences: the base and a pair per column that needs one (ln α, lag), all plain.
  m.set_derivatives(bc::Derivatives::kFiniteDifferences);
  m.predict(point(18), cols, p);
  EXPECT_EQ(p.replays, 5u);
  w = pool.work_done();
  EXPECT_EQ(w.plain.replays, 7u);
  EXPECT_EQ(w.sensitivity.replays, 2u);
  // A pool that replayed only with sensitivities has nothing to weigh them against.
  bc::ReplayPool alone(exp.samples, 1);
  bc::ReplayRecordingModel a(rec, alone);
  a.set_derivatives(bc::Derivatives::kSensitivities);
  a.predict(point(16), cols, p);
  EXPECT_TRUE(std::isnan(alone.work_done().sensitivity_cost()));
  if (!HasFailure()) fs::remove_all(dir);
}
