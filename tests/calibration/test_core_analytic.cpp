// Solver, covariance and identifiability machinery on a closed-form problem with known
// truth (analytic_model.hpp), independent of the voxel replay.
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <iostream>
#include <mutex>

#include <gtest/gtest.h>

#include "analytic_model.hpp"
#include "burrbench/data_schema/cancel.hpp"
#include "burrbench/calibration/multistart.hpp"
#include "burrbench/calibration/objective.hpp"
#include "burrbench/calibration/profile.hpp"
#include "burrbench/calibration/uncertainty.hpp"

namespace bc = burrbench::calibration;
namespace ds = burrbench::data_schema;

namespace {

ds::ClassFitSpec spec(double a, double c, double m) {
  ds::ClassFitSpec s;
  s.alpha = {a, 1.0, 1000.0, false};
  s.c1 = {c, 0.1, 1000.0, false};
  s.mu = {m, 0.01, 2.0, false};
  return s;
}

struct Setup {
  std::vector<bc::testing::AnalyticModel> models;
  std::unique_ptr<bc::Layout> layout;
  bc::EvalPoint truth;
  bc::SampleWeights w;
};

Setup make(bool touch2, bool erode, unsigned seed, double rho = 0) {
  Setup s;
  s.truth.physics.alpha[1] = 20; s.truth.physics.c1[1] = 10; s.truth.physics.mu[1] = 0.4;
  s.truth.physics.alpha[2] = 8;  s.truth.physics.c1[2] = 3;  s.truth.physics.mu[2] = 0.25;
  s.truth.lag_ms = 4;
  for (int r = 0; r < 2; ++r) s.models.emplace_back("rec" + std::to_string(r), 500, touch2, erode);
  for (int r = 0; r < 2; ++r)
    s.models[std::size_t(r)].synthesise(s.truth, glm::dvec3(0.1 * r, -0.05, 0.2), 0.02, seed + unsigned(r), rho);
  ds::NuisanceSpec nz;
  nz.bias = true;
  nz.lag = true;
  s.layout = std::make_unique<bc::Layout>(
      std::vector<std::pair<std::uint8_t, std::pair<std::string, ds::ClassFitSpec>>>{
          {1, {"compact", spec(30, 5, 0.3)}}, {2, {"trabecular", spec(30, 5, 0.3)}}},
      std::vector<std::pair<std::string, double>>{{"rec0", 0.0}, {"rec1", 0.0}}, nz, 0.5);
  for (auto& m : s.models) s.w.emplace_back(m.size(), 1.0);
  return s;
}

std::vector<const bc::RecordingModel*> ptrs(const Setup& s) {
  std::vector<const bc::RecordingModel*> p;
  for (const auto& m : s.models) p.push_back(&m);
  return p;
}

// σ = 0.02 N as synthesised; `plain`: least squares without the robust loss.
bc::ObjectiveSettings settings(bool plain = false) {
  bc::ObjectiveSettings set;
  if (plain) set.loss = ds::LossKind::kNone;
  set.sigma_N = 0.02;
  return set;
}

double truth_of(const Setup& s, int label, const char* name) {
  return s.truth.physics.at(name[0] == 'a' ? bc::PhysKind::kAlpha
                            : name[0] == 'c' ? bc::PhysKind::kC1
                                             : bc::PhysKind::kMu,
                            std::uint8_t(label));
}

const ds::FitParameter& param(const bc::UncertaintyReport& r, int label, const char* name) {
  for (const auto& p : r.parameters)
    if (p.class_id == label && p.name == name) return p;
  throw std::runtime_error("no parameter");
}

}  // namespace

TEST(CalibrationCore, RecoversAnalyticTruthWithIntervalsCoveringIt) {
  auto s = make(true, true, 7);
  bc::Objective obj(*s.layout, ptrs(s), settings(true));
  auto fit = obj.solve(s.layout->initial(), s.w, {});
  ASSERT_TRUE(fit.usable) << fit.termination;
  auto ev = obj.evaluate(fit.x, s.w);
  auto rep = bc::assess_uncertainty(obj, fit.x, s.w, ev);
  EXPECT_NEAR(rep.residual_variance, 1.0, 0.15);
  for (int k : {1, 2})
    for (const char* n : {"alpha", "c1", "mu"}) {
      const auto& p = param(rep, k, n);
      ASSERT_TRUE(p.identifiable) << n << ": " << p.reason;
      const double truth = truth_of(s, k, n);
      EXPECT_NEAR(p.estimate / truth, 1.0, n[0] == 'a' ? 0.15 : 0.05) << k << " " << n;
      // 95 % intervals: truth inside (loosely: 4 SE to keep the test deterministic-robust)
      EXPECT_LT(std::abs(p.estimate - truth), 4 * p.std_error + 1e-12) << k << " " << n;
      EXPECT_LT(p.ci95_low, p.estimate);
      EXPECT_GT(p.ci95_high, p.estimate);
    }
  for (const auto& n : rep.nuisance)
    if (n.name == "lag") {
      EXPECT_NEAR(n.estimate, 4.0, 4 * n.std_error + 1e-9);
    }
  EXPECT_EQ(rep.correlation.names.size(), rep.covariance.names.size());
}

// The multistart's rule for abandoning a local solve, on cost sequences of the reference
// experiment's default calibration (best pre-fit cost 42244, 12 local iterations).
TEST(CalibrationCore, HopelessStartsAreThoseThatCannotReachTheBestPrefit) {
  const double ref = 42244;
  // Stalled far above: 0.6 % over two iterations, 9 iterations left.
  EXPECT_TRUE(bc::hopeless_start({55226, 53489, 53247, 53156}, 12, ref));
  EXPECT_TRUE(bc::hopeless_start({66248, 66217, 66216, 66214}, 12, ref));
  // The best start itself (it starts at the reference) and a fast descent below it.
  EXPECT_FALSE(bc::hopeless_start({42244, 41697, 41020, 39548}, 12, ref));
  EXPECT_FALSE(bc::hopeless_start({54664, 27372, 26436, 26428}, 12, ref));
  // Above, but descending 10 % per iteration: it could still get below the reference.
  EXPECT_FALSE(bc::hopeless_start({60000, 54000, 48600, 43740}, 12, ref));
  // 1.9 % per iteration: enough with 9 iterations left, not with 1.
  EXPECT_FALSE(bc::hopeless_start({60000, 54000, 53000, 52000}, 12, ref));
  EXPECT_TRUE(bc::hopeless_start({60000, 54000, 53000, 52000}, 4, ref));
  // Too early to judge (fewer than 3 iterations), or no reference.
  EXPECT_FALSE(bc::hopeless_start({66248, 66217, 66216}, 12, ref));
  EXPECT_FALSE(bc::hopeless_start({66248, 66217, 66216, 66214}, 12, INFINITY));
}

// "Reached by k of N", and why the others were not: only a start whose local solve
// converged above the best is another minimum; one that stopped short is not, nor is a
// start screened at its pre-fit or one that could not be evaluated.
TEST(CalibrationCore, TheSearchTallyTellsOtherMinimaFromStartsThatStoppedShort) {
  using E = bc::StartEnd::Ending;
  auto end = [](double cost, E how, bool usable = true) {
    bc::StartEnd e;
    e.cost = cost;
    e.ending = how;
    e.usable = usable;
    return e;
  };
  const std::vector<bc::StartEnd> ends{end(100.0, E::kConverged), end(101.5, E::kStopped),
                                       end(100.9, E::kScreened),  end(250.0, E::kConverged),
                                       end(260.0, E::kConverged), end(300.0, E::kStopped),
                                       end(400.0, E::kScreened),  end(90.0, E::kConverged, false)};
  const auto t = bc::tally(ends, 100.0, 2.0);
  EXPECT_EQ(t.reached, 3);  // within 2 of 100, whatever their ending; the unusable one is not
  EXPECT_EQ(t.higher_optima, 2);
  EXPECT_EQ(t.stopped_short, 1);
  const auto tight = bc::tally(ends, 100.0, 0.5);
  EXPECT_EQ(tight.reached, 1);
  EXPECT_EQ(tight.stopped_short, 2);
  // With the optimum's intervals: an end above it inside them ended in its neighbourhood,
  // whatever its ending; outside any one of them it is counted by its ending.
  std::vector<bc::StartEnd> placed = ends;
  const std::vector<double> at{0.0, 1.0}, in{0.05, 0.9}, out{0.05, 1.5};
  for (std::size_t k = 0; k < placed.size(); ++k) placed[k].end = k == 1 || k == 3 ? in : k == 0 ? at : out;
  const std::vector<std::pair<double, double>> box{{-0.1, 0.1}, {0.8, 1.2}};
  const auto boxed = bc::tally(placed, 100.0, 0.5, box);
  EXPECT_EQ(boxed.reached, 1);
  EXPECT_EQ(boxed.near, 2);  // the stopped one at 101.5 and the converged one at 250
  EXPECT_EQ(boxed.higher_optima, 1);
  EXPECT_EQ(boxed.stopped_short, 1);
  EXPECT_EQ(bc::lone_optimum_warning(boxed, 8, 4), "") << "found twice: once reached, once inside its intervals";
  placed[1].end = out;
  placed[3].end = out;
  const auto apart = bc::tally(placed, 100.0, 0.5, box);
  EXPECT_EQ(apart.near, 0);
  EXPECT_EQ(apart.higher_optima, 2);
  EXPECT_EQ(apart.stopped_short, 2);
  EXPECT_STREQ(bc::to_string(E::kStopped), "stopped");
  // Reached more than once, or only one start solved: no warning.
  EXPECT_EQ(bc::lone_optimum_warning(t, 8, 4), "");
  EXPECT_EQ(bc::lone_optimum_warning(tight, 8, 1), "");
  const std::string w = bc::lone_optimum_warning(tight, 8, 4);
  EXPECT_NE(w.find("reached by only 1 of 8 starts; 2 other start(s) converged to higher minima"), std::string::npos) << w;
  EXPECT_NE(w.find("; 2 other start(s) stopped above it before converging"), std::string::npos) << w;
  bc::SearchTally only_stopped{1, 0, 0, 3};
  const std::string w2 = bc::lone_optimum_warning(only_stopped, 4, 4);
  EXPECT_EQ(w2.find("higher minima"), std::string::npos) << w2;
  EXPECT_NE(w2.find("reached by only 1 of 4 starts; 3 other start(s) stopped"), std::string::npos) << w2;
}

// Abandoning hopeless local solves saves their iterations and never changes the best end.
TEST(CalibrationCore, AbandoningHopelessStartsKeepsTheBestOptimum) {
  auto s = make(true, true, 5);
  bc::Objective obj(*s.layout, ptrs(s), settings());
  const auto starts = bc::latin_hypercube_starts(*s.layout, s.layout->initial(), 12, 9);
  bc::MultistartOptions mo;
  mo.iterations = 12;
  bc::MultistartOptions keep = mo;
  keep.abandon_hopeless = false;
  const auto a = bc::multistart(obj, starts, s.w, mo, 1e-6);
  const auto b = bc::multistart(obj, starts, s.w, keep, 1e-6);
  ASSERT_FALSE(a.ends.empty());
  EXPECT_DOUBLE_EQ(a.ends.front().cost, b.ends.front().cost);
  EXPECT_EQ(a.ends.front().index, b.ends.front().index);
  EXPECT_EQ(a.reached_best, b.reached_best);
  double lowest_prefit = INFINITY;
  for (const auto& e : a.ends) lowest_prefit = std::min(lowest_prefit, e.prefit_cost);
  std::uint64_t it_a = 0, it_b = 0;
  int abandoned = 0;
  for (const auto& e : a.ends) {
    it_a += e.iterations;
    EXPECT_EQ(e.ending == bc::StartEnd::Ending::kConverged, e.termination.rfind("CONVERGENCE", 0) == 0)
        << e.termination;
    if (e.termination.rfind("abandoned", 0) != 0) continue;
    EXPECT_EQ(e.ending, bc::StartEnd::Ending::kStopped);
    ++abandoned;
    EXPECT_GT(e.cost, lowest_prefit) << e.index;
  }
  for (const auto& e : b.ends) it_b += e.iterations;
  std::cout << abandoned << " of " << a.ends.size() << " starts abandoned; iterations " << it_a
            << " instead of " << it_b << "\n";
  EXPECT_LE(it_a, it_b);
}

// A Jacobian costs a (sensitivity) replay. Ceres asks for a point more than once (the
// prefetch, then its own evaluation); the objective must replay it once. And a trial point
// of the bounds' projected line search costs only a plain prediction: the Jacobian comes
// once the step is accepted, so every derivative prediction but the start's is at a point
// already tried without derivatives (cubic interpolation took one at every trial point).
TEST(CalibrationCore, NoDerivativeReplayIsRepeatedAtOnePoint) {
  auto s = make(true, true, 3);
  bc::Objective obj(*s.layout, ptrs(s), settings());
  auto fit = obj.solve(s.layout->initial(), s.w, {});
  ASSERT_TRUE(fit.usable);
  EXPECT_GT(fit.iterations, 3u);
  for (const auto& m : s.models) {
    EXPECT_GT(m.column_calls, 3u) << m.id();
    EXPECT_EQ(m.repeated_column_calls, 0u) << m.id() << ": " << m.column_calls << " derivative predictions";
    EXPECT_LE(m.columns_at_untried_points, 1u) << m.id() << ": " << m.column_calls << " derivative predictions";
  }
}

// Each recording's prediction waits (at most 2 s) until every recording of the evaluation
// has started its own: met only when they are all queued at once. Left to Ceres's two
// threads, at most two ran together and a long recording could run alone at the end.
class GatedModel final : public bc::RecordingModel {
 public:
  struct Gate {
    std::mutex mu;
    std::condition_variable cv;
    std::size_t inside = 0, max_inside = 0, waits_timed_out = 0, generation = 0;
    std::size_t n = 0;
  };
  GatedModel(const bc::testing::AnalyticModel& m, Gate& g) : m_(m), g_(g) {}
  const std::string& id() const override { return m_.id(); }
  std::size_t size() const override { return m_.size(); }
  const std::vector<double>& t_s() const override { return m_.t_s(); }
  const std::vector<glm::dvec3>& measured_sensor_N() const override { return m_.measured_sensor_N(); }
  void predict(const bc::EvalPoint& at, const std::vector<bc::Column>& cols, bc::Prediction& out) const override {
    {
      std::unique_lock lk(g_.mu);
      const std::size_t gen = g_.generation;
      g_.max_inside = std::max(g_.max_inside, ++g_.inside);
      if (g_.inside == g_.n) {
        g_.inside = 0;
        ++g_.generation;
        g_.cv.notify_all();
      } else if (!g_.cv.wait_for(lk, std::chrono::seconds(2), [&] { return g_.generation != gen; })) {
        ++g_.waits_timed_out;
        g_.inside = 0;
        ++g_.generation;
        g_.cv.notify_all();
      }
    }
    m_.predict(at, cols, out);
  }

 private:
  const bc::testing::AnalyticModel& m_;
  Gate& g_;
};

// Four gated recordings: the two of `make` and two more over the same data.
struct GatedScene {
  Setup s = make(true, true, 5);
  std::unique_ptr<bc::Layout> layout;
  bc::SampleWeights w;
  GatedModel::Gate gate;
  std::vector<GatedModel> gated;
  std::vector<const bc::RecordingModel*> models;
  GatedScene() {
    std::vector<std::pair<std::string, double>> ids;
    for (int r = 0; r < 4; ++r) ids.emplace_back("rec" + std::to_string(r), 0.0);
    s.models.emplace_back("rec2", 500, true, true);
    s.models.emplace_back("rec3", 300, true, true);
    for (int r = 2; r < 4; ++r)
      s.models[std::size_t(r)].synthesise(s.truth, glm::dvec3(0.1, -0.05, 0.2), 0.02, 40u + unsigned(r));
    ds::NuisanceSpec nz;
    nz.bias = true;
    nz.lag = true;
    layout = std::make_unique<bc::Layout>(
        std::vector<std::pair<std::uint8_t, std::pair<std::string, ds::ClassFitSpec>>>{
            {1, {"compact", spec(30, 5, 0.3)}}, {2, {"trabecular", spec(30, 5, 0.3)}}},
        ids, nz, 0.5);
    for (const auto& m : s.models) w.emplace_back(m.size(), 1.0);
    gate.n = 4;
    gated.reserve(s.models.size());
    for (const auto& m : s.models) gated.emplace_back(m, gate);
    for (const auto& g : gated) models.push_back(&g);
  }
};

TEST(CalibrationCore, EveryRecordingOfAnEvaluationIsPredictedAtOnce) {
  GatedScene g;
  const bc::Layout& layout = *g.layout;
  auto& gate = g.gate;
  const auto& w = g.w;
  const auto& p = g.models;
  bc::Objective obj(layout, p, settings());
  bc::SolveOptions o;
  o.threads = 2;
  o.max_iterations = 4;
  const auto fit = obj.solve(layout.initial(), w, o);
  ASSERT_TRUE(fit.usable) << fit.termination;
  EXPECT_EQ(gate.max_inside, 4u);
  EXPECT_EQ(gate.waits_timed_out, 0u);
  // Prefetched predictions are the ones Ceres would have asked for: a solve that evaluates
  // one recording at a time (one thread, no prefetch) ends at the same point.
  gate.n = 1;
  bc::SolveOptions one = o;
  one.threads = 1;
  const auto alone = obj.solve(layout.initial(), w, one);
  // (Ceres sums in another order on one thread: equal to rounding, 2e-9 here.)
  ASSERT_EQ(alone.x.size(), fit.x.size());
  for (std::size_t i = 0; i < fit.x.size(); ++i) EXPECT_NEAR(alone.x[i], fit.x[i], 1e-7 * std::max(1.0, std::abs(fit.x[i]))) << i;
  EXPECT_EQ(alone.iterations, fit.iterations);
}

// A lone start's pre-fit gets both threads: its recordings are predicted at once, as in
// the local solve that follows (one thread each only while pre-fits run side by side).
TEST(CalibrationCore, ALoneStartIsPreFittedOnEveryThread) {
  GatedScene g;
  bc::Objective obj(*g.layout, g.models, settings());
  bc::MultistartOptions mo;
  mo.prefit.fallback_iterations = 3;
  mo.iterations = 3;
  const auto out = bc::multistart(obj, {g.layout->initial()}, g.w, mo, 1e-6);
  ASSERT_EQ(out.ends.size(), 1u);
  EXPECT_TRUE(out.ends.front().usable) << out.ends.front().termination;
  EXPECT_EQ(g.gate.max_inside, 4u);
  EXPECT_EQ(g.gate.waits_timed_out, 0u);
}

// A prediction that fails mid-solve (a cancelled replay, or any error) on one of Ceres's
// evaluation threads: nothing catches an exception there (std::terminate ended the
// process). The solve stops and rethrows it on the caller's thread, one thread or two.
class FailingModel final : public bc::RecordingModel {
 public:
  FailingModel(const bc::testing::AnalyticModel& m, std::atomic<int>& left) : m_(m), left_(left) {}
  const std::string& id() const override { return m_.id(); }
  std::size_t size() const override { return m_.size(); }
  const std::vector<double>& t_s() const override { return m_.t_s(); }
  const std::vector<glm::dvec3>& measured_sensor_N() const override { return m_.measured_sensor_N(); }
  void predict(const bc::EvalPoint& at, const std::vector<bc::Column>& cols, bc::Prediction& out) const override {
    if (--left_ < 0) throw burrbench::Cancelled();
    m_.predict(at, cols, out);
  }

 private:
  const bc::testing::AnalyticModel& m_;
  std::atomic<int>& left_;
};

TEST(CalibrationCore, APredictionThatFailsMidSolveIsRethrownByTheSolve) {
  GatedScene g;  // four recordings, for the prefetch on both threads
  for (const int threads : {1, 2}) {
    for (const int after : {0, 9}) {  // at the start point, and a few evaluations in
      std::atomic<int> left{after};
      std::vector<FailingModel> failing;
      failing.reserve(g.s.models.size());
      std::vector<const bc::RecordingModel*> models;
      for (const auto& m : g.s.models) failing.emplace_back(m, left);
      for (const auto& f : failing) models.push_back(&f);
      bc::Objective obj(*g.layout, models, settings());
      bc::SolveOptions o;
      o.threads = threads;
      o.max_iterations = 20;
      EXPECT_THROW(obj.solve(g.layout->initial(), g.w, o), burrbench::Cancelled) << threads << " threads, after " << after;
      // The same solve with predictions that do not fail ends normally.
      left = 1 << 30;
      EXPECT_TRUE(obj.solve(g.layout->initial(), g.w, o).usable);
    }
  }
}

// Correlated residuals (AR(1), ρ = 0.8: about 9× fewer independent samples than counted)
// make white-noise intervals far too narrow; the AR(1) inflation restores their coverage.
TEST(CalibrationCore, CorrelatedNoiseWidensIntervalsToTheirCoverage) {
  int hits_white = 0, hits_ar1 = 0, total = 0;
  double rho_sum = 0;
  const int seeds = 10;
  for (int seed = 1; seed <= seeds; ++seed) {
    auto s = make(true, true, unsigned(100 + 7 * seed), 0.8);
    bc::Objective obj(*s.layout, ptrs(s), settings(true));
    auto fit = obj.solve(s.layout->initial(), s.w, {});
    ASSERT_TRUE(fit.usable) << fit.termination;
    const auto ev = obj.evaluate(fit.x, s.w);
    rho_sum += ev.residual_lag1;
    const double kappa = bc::ar1_inflation(ev.residual_lag1);
    const auto white = bc::assess_uncertainty(obj, fit.x, s.w, ev, bc::contact_checks(obj, fit.x, s.w, ev), true, 1.0);
    const auto ar1 = bc::assess_uncertainty(obj, fit.x, s.w, ev, bc::contact_checks(obj, fit.x, s.w, ev), true, kappa);
    EXPECT_DOUBLE_EQ(ar1.inflation, kappa);
    for (int k : {1, 2})
      for (const char* n : {"alpha", "c1", "mu"}) {
        const double truth = truth_of(s, k, n);
        auto holds = [&](const ds::FitParameter& p) {
          return p.identifiable && p.ci95_low <= truth && truth <= p.ci95_high;
        };
        hits_white += holds(param(white, k, n));
        hits_ar1 += holds(param(ar1, k, n));
        ++total;
        // Same estimate, the interval wider by √κ.
        const auto& pw = param(white, k, n);
        const auto& pa = param(ar1, k, n);
        if (white.held == ar1.held && pw.identifiable) {  // (in ln θ the width scales exactly)
          EXPECT_NEAR(std::log(pa.ci95_high / pa.ci95_low) / std::log(pw.ci95_high / pw.ci95_low),
                      std::sqrt(kappa), 1e-6 * std::sqrt(kappa)) << k << " " << n;
        }
      }
  }
  std::cout << "AR(1) rho 0.8: mean estimated rho " << rho_sum / seeds << "; covariance intervals holding the truth: white "
            << hits_white << "/" << total << ", widened " << hits_ar1 << "/" << total << "\n";
  EXPECT_NEAR(rho_sum / seeds, 0.8, 0.05);
  EXPECT_GE(hits_ar1, int(0.85 * total)) << hits_ar1 << "/" << total << " (white: " << hits_white << ")";
  EXPECT_LE(hits_white, int(0.75 * total)) << hits_white << "/" << total;
  // White noise: the factor stays near 1.
  auto s = make(true, true, 7);
  bc::Objective obj(*s.layout, ptrs(s), settings());
  auto fit = obj.solve(s.layout->initial(), s.w, {});
  const auto ev = obj.evaluate(fit.x, s.w);
  EXPECT_LT(std::abs(ev.residual_lag1), 0.05);
  EXPECT_LT(bc::ar1_inflation(ev.residual_lag1), 1.1);
  EXPECT_DOUBLE_EQ(bc::ar1_inflation(-0.5), 1.0);
  EXPECT_DOUBLE_EQ(bc::ar1_inflation(0.99), bc::ar1_inflation(0.95));
}

TEST(CalibrationCore, UntouchedClassIsNotIdentifiable) {
  auto s = make(false, true, 11);
  bc::Objective obj(*s.layout, ptrs(s), settings());
  auto fit = obj.solve(s.layout->initial(), s.w, {});
  auto rep = bc::assess_uncertainty(obj, fit.x, s.w, obj.evaluate(fit.x, s.w));
  for (const char* n : {"alpha", "c1", "mu"}) {
    EXPECT_FALSE(param(rep, 2, n).identifiable) << n;
    EXPECT_NE(param(rep, 2, n).reason.find("never in contact"), std::string::npos);
    EXPECT_TRUE(std::isnan(param(rep, 2, n).estimate));
    EXPECT_TRUE(param(rep, 1, n).identifiable) << n << ": " << param(rep, 1, n).reason;
  }
  EXPECT_NEAR(param(rep, 1, "c1").estimate, 10.0, 0.5);
}

TEST(CalibrationCore, AlphaWithoutErosionIsNotIdentifiable) {
  auto s = make(true, false, 13);
  bc::Objective obj(*s.layout, ptrs(s), settings());
  auto fit = obj.solve(s.layout->initial(), s.w, {});
  auto rep = bc::assess_uncertainty(obj, fit.x, s.w, obj.evaluate(fit.x, s.w));
  for (int k : {1, 2}) {
    EXPECT_FALSE(param(rep, k, "alpha").identifiable);
    EXPECT_FALSE(param(rep, k, "alpha").reason.empty());
    EXPECT_TRUE(param(rep, k, "c1").identifiable) << param(rep, k, "c1").reason;
    EXPECT_TRUE(param(rep, k, "mu").identifiable) << param(rep, k, "mu").reason;
  }
}

namespace {
// A solve run to convergence: the reference optimum (and brute-force profile points) the
// profile tests compare against.
bc::SolveOptions to_convergence() {
  bc::SolveOptions o;
  o.max_iterations = 200;
  o.function_tolerance = 1e-12;
  return o;
}

// Both classes touched and eroding (make), fitted to convergence from the layout's start.
struct Converged {
  Setup s;
  bc::Objective obj;
  bc::SolveOutcome fit;
  Converged(unsigned seed, bool plain)
      : s(make(true, true, seed)),
        obj(*s.layout, ptrs(s), settings(plain)),
        fit(obj.solve(s.layout->initial(), s.w, to_convergence())) {}
};
// dᵀ S⁻¹ d for S (m×m, row-major, positive definite) by Gaussian elimination with pivoting.
double mahalanobis2(std::vector<double> S, const std::vector<double>& d) {
  const std::size_t m = d.size();
  std::vector<double> y = d;
  for (std::size_t c = 0; c < m; ++c) {
    std::size_t p = c;
    for (std::size_t r = c + 1; r < m; ++r)
      if (std::abs(S[r * m + c]) > std::abs(S[p * m + c])) p = r;
    for (std::size_t j = 0; j < m; ++j) std::swap(S[c * m + j], S[p * m + j]);
    std::swap(y[c], y[p]);
    for (std::size_t r = c + 1; r < m; ++r) {
      const double f = S[r * m + c] / S[c * m + c];
      for (std::size_t j = c; j < m; ++j) S[r * m + j] -= f * S[c * m + j];
      y[r] -= f * y[c];
    }
  }
  for (std::size_t c = m; c-- > 0;) {
    for (std::size_t j = c + 1; j < m; ++j) y[c] -= S[c * m + j] * y[j];
    y[c] /= S[c * m + c];
  }
  double q = 0;
  for (std::size_t a = 0; a < m; ++a) q += d[a] * y[a];
  return q;
}

// The converged analytic fit with its covariance and the χ² profile threshold.
struct AtOptimum {
  Converged c;
  bc::CovarianceOutcome cov;
  double threshold;
  explicit AtOptimum(unsigned seed)
      : c(seed, true), cov(c.obj.covariance(c.fit.x, c.s.w, {})),
        threshold(0.5 * bc::kChi2_1_95 * cov.residual_variance) {}
};
}  // namespace

// refine runs its second pass (a fresh trust region) only after the first took a step: a
// solve that took none ended where it began, and a second pass would repeat it exactly.
// Ceres marks its iteration 0 successful too; steps_taken must not count it.
TEST(CalibrationCore, ASolveCountsTheStepsItTookNotItsStart) {
  Converged c(3, false);
  const auto& [s, obj, fit] = c;
  ASSERT_TRUE(fit.usable);
  EXPECT_GT(fit.steps_taken, 3u);
  EXPECT_LE(fit.steps_taken, fit.iterations);
  const auto again = obj.solve(fit.x, s.w, {});  // converged far beyond its tolerance
  ASSERT_TRUE(again.usable);
  EXPECT_EQ(again.steps_taken, 0u) << again.termination;
  EXPECT_EQ(again.x, fit.x);
  EXPECT_EQ(again.final_cost, again.initial_cost);
}

// The profile's crossings against a brute-force profile: on each side, ln θ is bisected
// for a cost rise of exactly the threshold, every other parameter re-optimised to
// convergence at each trial. The walk's points (one per side where the covariance
// predicts the crossing, closed by a short extrapolation) must land on it.
TEST(CalibrationCore, ProfileCrossingsMatchABruteForceProfile) {
  const AtOptimum o(6);
  const auto& [s, obj, fit] = o.c;
  ASSERT_TRUE(fit.usable);
  const auto& cov = o.cov;
  ASSERT_TRUE(cov.ok);
  const double thr = o.threshold;
  const std::size_t n = cov.indices.size();
  int single = 0, sides = 0;
  for (const auto& p : s.layout->physics()) {
    if (p.index < 0 || p.label != 1) continue;
    const auto i = std::size_t(p.index);
    std::size_t at = 0;
    while (cov.indices[at] != i) ++at;
    bc::ProfileOptions po;
    po.first_step = 1.96 * std::sqrt(cov.cov[at * n + at]);
    const auto prof = bc::profile_parameter(obj, fit.x, fit.final_cost, s.w, i, thr, {}, po);
    // Brute force: Δ(h) with everything else re-optimised from the optimum.
    auto delta = [&](double h) {
      std::vector<double> x = fit.x;
      x[i] += h;
      bc::SolveOptions o = to_convergence();
      o.hold.assign(x.size(), false);
      o.hold[i] = true;
      const auto r = obj.solve(x, s.w, o);
      return r.final_cost - fit.final_cost;
    };
    for (const auto* side : {&prof.lower, &prof.upper}) {
      const double sign = side == &prof.lower ? -1.0 : 1.0;
      ASSERT_TRUE(side->closed) << p.label << " " << int(p.kind);
      double lo = 0, hi = po.first_step;
      while (delta(sign * hi) < thr) hi *= 2;
      for (int k = 0; k < 30; ++k) {
        const double mid = 0.5 * (lo + hi);
        (delta(sign * mid) < thr ? lo : hi) = mid;
      }
      const double brute = fit.x[i] + sign * 0.5 * (lo + hi);
      const double half = std::abs(brute - fit.x[i]);
      std::cout << "class " << int(p.label) << " kind " << int(p.kind) << (sign < 0 ? " lower" : " upper")
                << ": crossing " << side->crossing << ", brute force " << brute << " (" << side->points.size()
                << " points)\n";
      EXPECT_NEAR(side->crossing, brute, 0.01 * half) << "class " << int(p.label) << " kind " << int(p.kind);
      ++sides;
      single += side->points.size() == 1;
    }
  }
  std::cout << single << " of " << sides << " sides closed with one point\n";
  EXPECT_EQ(single, sides) << "where the covariance predicts the crossing, a side costs one point";
}

// On a smooth cost the texture probes (refits from the optimum's 95 % ellipsoid, stopped as
// a profile point stops) come back to the optimum: no allowance, the threshold is the χ²'s
// (docs/calibration.md "Profiles on a textured cost"). Probed from a point 5 SE off the
// optimum, they all end below it: the cue that restarts the refinement.
TEST(CalibrationCore, TextureProbesComeBackToASmoothOptimum) {
  const AtOptimum o(6);
  const auto& [s, obj, fit] = o.c;
  ASSERT_TRUE(fit.usable);
  const auto& cov = o.cov;
  ASSERT_TRUE(cov.ok);
  const double thr = o.threshold;
  const auto t = bc::probe_texture(obj, fit.x, fit.final_cost, s.w, {}, cov, thr, 2);
  ASSERT_EQ(t.excess.size(), bc::kTextureProbes);
  // Each start on the 95 % ellipsoid: Mahalanobis² 4 against the covariance (solved here by
  // elimination, not by the eigen-decomposition the probes are built from), no two alike.
  const std::size_t m = cov.indices.size();
  for (std::size_t k = 0; k < t.starts.size(); ++k) {
    std::vector<double> d(m);
    for (std::size_t a = 0; a < m; ++a) d[a] = t.starts[k][cov.indices[a]] - fit.x[cov.indices[a]];
    EXPECT_NEAR(mahalanobis2(cov.cov, d), 4.0, 1e-6) << "probe " << k;
    for (std::size_t j = 0; j < k; ++j) EXPECT_NE(t.starts[j], t.starts[k]) << "probes " << j << " and " << k;
  }
  for (const double d : t.excess) {
    std::cout << "probe excess " << d << " (threshold " << thr << ")\n";
    EXPECT_LT(std::abs(d), 0.05 * thr);
  }
  EXPECT_LT(t.allowance, 0.05 * thr);
  std::vector<double> off = fit.x;
  const std::size_t i = std::size_t(s.layout->physics().front().index);
  off[i] += 5 * std::sqrt(cov.cov[cov.position(i) * (cov.indices.size() + 1)]);
  const double cost_off = obj.evaluate(off, s.w).cost;
  const auto t_off = bc::probe_texture(obj, off, cost_off, s.w, {}, cov, thr, 2);
  for (const double d : t_off.excess) EXPECT_LT(d, -thr) << "a probe from off the optimum ends below it";
  EXPECT_EQ(t_off.allowance, 0.0);
  EXPECT_LT(t_off.cheapest_cost, cost_off - thr);
  EXPECT_NEAR(t_off.cheapest_cost, fit.final_cost, 0.05 * thr);
}

// A profile started from a point that is not the optimum (compact C1 moved off it) finds
// a cheaper point at once. With a shared flag the walk reports it and stops: the fit
// restarts from there (assess), so the rest of the profile, and every other profile
// sharing the flag, would be thrown away. Without the flag the walk goes on.
TEST(CalibrationCore, ACheaperProfilePointStopsEveryProfileSharingTheFlag) {
  Converged c(6, true);
  const auto& [s, obj, fit] = c;
  ASSERT_TRUE(fit.usable);
  std::size_t alpha = 0, c1 = 0;
  for (const auto& p : s.layout->physics())
    if (p.index >= 0 && p.label == 1) (p.kind == bc::PhysKind::kAlpha ? alpha : c1) = std::size_t(p.index);
  std::vector<double> off = fit.x;
  off[c1] += 0.05;
  const double cost_off = obj.evaluate(off, s.w).cost;
  const double thr = 0.5 * bc::kChi2_1_95;
  ASSERT_GT(cost_off - fit.final_cost, 10 * thr) << "the moved point must be clearly above the optimum";

  bc::ProfileOptions free_walk;
  const auto full = bc::profile_parameter(obj, off, cost_off, s.w, alpha, thr, {}, free_walk);
  ASSERT_TRUE(full.found_lower);
  EXPECT_LT(full.lower_cost, cost_off - 0.25 * thr);

  std::atomic<bool> cheaper{false};
  bc::ProfileOptions shared;
  shared.cheaper_found = &cheaper;
  const auto stopped = bc::profile_parameter(obj, off, cost_off, s.w, alpha, thr, {}, shared);
  EXPECT_TRUE(cheaper.load());
  ASSERT_TRUE(stopped.found_lower);
  EXPECT_LT(stopped.lower_cost, cost_off - 0.25 * thr);
  const std::size_t n_full = full.lower.points.size() + full.upper.points.size();
  const std::size_t n_stopped = stopped.lower.points.size() + stopped.upper.points.size();
  EXPECT_EQ(n_stopped, 1u) << "the walk stops at the first cheaper point";
  EXPECT_GT(n_full, n_stopped);
  // Another profile sharing the flag (as the other worker's) stops before its first point.
  const auto other = bc::profile_parameter(obj, off, cost_off, s.w, c1, thr, {}, shared);
  EXPECT_EQ(other.lower.points.size() + other.upper.points.size(), 0u);
}

// The covariance's gradient (Jᵀr, which step_past_bounds weighs against the bounds) is the
// cost's: central differences of evaluate() at a point off the optimum, entry by entry.
TEST(CalibrationCore, TheCovariancesGradientIsTheCostsCentralDifferences) {
  const auto s = make(true, true, 4);
  const bc::Objective obj(*s.layout, ptrs(s), settings(true));
  std::vector<double> x = s.layout->initial();
  const auto cov = obj.covariance(x, s.w, {});
  ASSERT_TRUE(cov.ok);
  ASSERT_EQ(cov.gradient.size(), cov.indices.size());
  for (std::size_t a = 0; a < cov.indices.size(); ++a) {
    const std::size_t i = cov.indices[a];
    const double h = 1e-5 * std::max(1.0, std::abs(x[i]));
    std::vector<double> up = x, down = x;
    up[i] += h;
    down[i] -= h;
    const double cd = (obj.evaluate(up, s.w).cost - obj.evaluate(down, s.w).cost) / (2 * h);
    EXPECT_NEAR(cov.gradient[a], cd, 1e-5 * std::max(1.0, std::abs(cd))) << s.layout->name(i);
  }
}

// conditional_variance (the covariance rules' half-width of a constant with the entries at
// their bounds held) is the covariance computed with those entries held, from the free one.
TEST(CalibrationCore, TheConditionalVarianceIsTheCovarianceWithTheOthersHeld) {
  Converged c(5, true);
  const auto& [s, obj, fit] = c;
  ASSERT_TRUE(fit.usable);
  const auto free = obj.covariance(fit.x, s.w, {});
  ASSERT_TRUE(free.ok);
  std::size_t alpha = 0, mu = 0, c1 = 0;
  for (const auto& p : s.layout->physics())
    if (p.label == 1) (p.kind == bc::PhysKind::kAlpha ? alpha : p.kind == bc::PhysKind::kMu ? mu : c1) = std::size_t(p.index);
  const std::size_t lag = std::size_t(s.layout->recordings()[0].lag);
  for (const std::vector<std::size_t>& held : {std::vector<std::size_t>{alpha}, {alpha, lag}}) {
    std::vector<bool> hold(fit.x.size(), false);
    for (std::size_t j : held) hold[j] = true;
    const auto cond = obj.covariance(fit.x, s.w, hold);
    ASSERT_TRUE(cond.ok);
    for (std::size_t i : {mu, c1}) {
      const std::size_t a = cond.position(i), m = cond.indices.size();
      ASSERT_LT(a, m);
      // Both share the residual variance (the held entries count as parameters in its dof).
      EXPECT_NEAR(bc::conditional_variance(free, i, held) / free.residual_variance,
                  cond.cov[a * m + a] / cond.residual_variance, 1e-6 * cond.cov[a * m + a] / cond.residual_variance)
          << s.layout->name(i) << " with " << held.size() << " held";
    }
  }
  EXPECT_TRUE(std::isnan(bc::conditional_variance(free, 999, {alpha})));
}
