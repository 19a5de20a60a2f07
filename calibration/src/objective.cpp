#include "burrbench/calibration/objective.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <mutex>
#include <thread>

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <Eigen/Dense>

#include "burrbench/data_schema/error.hpp"

namespace burrbench::calibration {
namespace {

using data_schema::LossKind;

// ρ(s) and ρ'(s) of the robust loss, s = r², scale c (σ units); ρ(s) = s for small s.
struct Robust {
  LossKind kind;
  double c2;
  double rho(double s) const {
    switch (kind) {
      case LossKind::kNone: return s;
      case LossKind::kHuber: return s <= c2 ? s : 2 * std::sqrt(c2 * s) - c2;
      case LossKind::kCauchy: return c2 * std::log1p(s / c2);
    }
    BURRBENCH_UNREACHABLE();
  }
  double drho(double s) const {
    switch (kind) {
      case LossKind::kNone: return 1;
      case LossKind::kHuber: return s <= c2 ? 1 : std::sqrt(c2 / s);
      case LossKind::kCauchy: return 1 / (1 + s / c2);
    }
    BURRBENCH_UNREACHABLE();
  }
};

// Residual weight of one sample: its external weight, scaled down (or to 0) when buried.
double sample_weight(const ObjectiveSettings& s, double w, bool buried) {
  if (!buried || w == 0) return w;
  return s.buried == data_schema::BuriedPolicy::kExclude ? 0.0 : w * s.buried_weight;
}

// One recording's additive nuisances at x (0 where not fitted).
struct Offsets {
  glm::dvec3 bias{0}, torque_bias{0};
  double idle = 0, viscous = 0;
  double spindle_lag_ms = 0;
};
Offsets offsets_at(const RecordingNuisance& nz, const double* x) {
  Offsets o;
  auto v3 = [&](int at) { return glm::dvec3(x[at], x[at + 1], x[at + 2]); };
  if (nz.bias >= 0) o.bias = v3(nz.bias);
  if (nz.torque_bias >= 0) o.torque_bias = v3(nz.torque_bias);
  if (nz.spindle >= 0) {
    o.idle = x[nz.spindle];
    o.viscous = x[nz.spindle + 1];
  }
  if (nz.spindle_lag >= 0) o.spindle_lag_ms = x[nz.spindle_lag];
  return o;
}

// A predicted series at t_j − lag, linear between the samples (held at the ends), and its
// slope there (per s). The drive's own lag shifts the predicted load, which is smooth,
// rather than the measured one, whose slope is its noise. On a sample (a lag of 0, where
// every fit starts) the slope is the central difference: a one-sided one, or none, would
// leave the lag's gradient zero at its start and the lag where it started.
struct Shifted {
  std::size_t i = 0;        // t_s[i] ≤ t < t_s[i + 1]
  double u = 0;             // the weight of t_s[i + 1]
  double dt = 0;            // t_s[i + 1] − t_s[i] (0 at the ends)
  std::size_t s0 = 0, s1 = 0;  // the slope's samples
  double sdt = 0;           // t_s[s1] − t_s[s0] (0: no slope)
  template <class V>
  double value(const V& v) const { return dt > 0 ? (1 - u) * v[i] + u * v[i + 1] : v[i]; }
  template <class V>
  double slope(const V& v) const { return sdt > 0 ? (v[s1] - v[s0]) / sdt : 0.0; }
};
Shifted shifted(const std::vector<double>& t_s, std::size_t j, double lag_ms) {
  Shifted s;
  s.i = j;
  const std::size_t n = t_s.size();
  if (n < 2) return s;
  const double t = t_s[j] - 1e-3 * lag_ms;
  if (t <= t_s.front()) { s.i = 0; return s; }
  if (t >= t_s.back()) { s.i = n - 1; return s; }
  const auto it = std::upper_bound(t_s.begin(), t_s.end(), t);
  s.i = std::size_t(it - t_s.begin()) - 1;
  s.dt = t_s[s.i + 1] - t_s[s.i];
  s.u = (t - t_s[s.i]) / s.dt;
  s.s0 = s.i;
  s.s1 = s.i + 1;
  if (s.u == 0 && s.i > 0) s.s0 = s.i - 1;  // on a sample: central
  s.sdt = t_s[s.s1] - t_s[s.s0];
  return s;
}

// The raw residuals of sample j (before the weight and the robust loss), rows in the
// order force x y z, moment x y z, spindle (the channels the layout fits).
void raw_residuals(const ObjectiveSettings& s, const Channels& ch, const RecordingModel& m,
                   const Prediction& p, const Offsets& o, std::size_t j, double* r) {
  const auto& meas = m.measured_sensor_N();
  for (int a = 0; a < 3; ++a) r[a] = (p.force_sensor_N[j][a] + o.bias[a] - meas[j][a]) / s.sigma_N;
  int k = 3;
  if (ch.torque) {
    const auto& mt = m.measured_torque_Nmm();
    for (int a = 0; a < 3; ++a)
      r[k++] = (p.torque_sensor_Nmm[j][a] + o.torque_bias[a] - mt[j][a]) / s.sigma_torque_Nmm;
  }
  if (ch.spindle) {
    const Shifted at = shifted(m.t_s(), j, o.spindle_lag_ms);
    r[k] = (at.value(p.spindle_Nmm) + o.idle + o.viscous * m.spindle_krpm()[j] - m.measured_spindle_Nmm()[j]) /
           s.sigma_spindle_Nmm;
  }
}

// The point a recording is evaluated at: physics, its lag, depth offset and pose.
EvalPoint eval_point(const Layout& L, const double* x, std::size_t rec, bool geometry_terms) {
  const auto& nz = L.recordings()[rec];
  EvalPoint at{L.physics_values(x), nz.lag >= 0 ? x[nz.lag] : nz.lag_fixed_ms,
               nz.depth >= 0 ? x[nz.depth] : 0.0, geometry_terms};
  if (nz.pose >= 0) {
    at.has_pose = true;
    for (int k = 0; k < 6; ++k) at.pose[std::size_t(k)] = x[nz.pose + k];
    at.pose_centre_vol_mm = L.mountings()[std::size_t(nz.mounting)].centre_vol_mm;
  }
  return at;
}

// The Gaussian prior of a mounting's pose correction: r = L·x_pose, ½|r|² = ½ xᵀ(info)x.
class PriorCost final : public ceres::SizedCostFunction<6, 6> {
 public:
  explicit PriorCost(const std::array<double, 36>& sqrt_info) : L_(sqrt_info) {}
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    for (int i = 0; i < 6; ++i) {
      r[i] = 0;
      for (int j = 0; j < 6; ++j) r[i] += L_[std::size_t(6 * i + j)] * p[0][j];
    }
    if (jac && jac[0])
      for (int i = 0; i < 36; ++i) jac[0][i] = L_[std::size_t(i)];
    return true;
  }

 private:
  std::array<double, 36> L_;
};

double prior_cost(const Layout& L, const std::vector<double>& x) {
  double c = 0;
  for (const auto& m : L.mountings())
    for (int i = 0; i < 6; ++i) {
      double r = 0;
      for (int j = 0; j < 6; ++j) r += m.sqrt_information[std::size_t(6 * i + j)] * x[std::size_t(m.offset + j)];
      c += 0.5 * r * r;
    }
  return c;
}

// One residual block per recording: 3 residuals per force sample, parameter blocks =
// the free physics entries followed by this recording's free nuisances.
class RecordingCost final : public ceres::CostFunction {
 public:
  RecordingCost(const Objective& obj, std::size_t rec, const std::vector<double>& weights,
                std::atomic<std::uint64_t>& replays, bool geometry_terms, double* user_x)
      : obj_(obj), rec_(rec), w_(weights), replays_(replays), geometry_terms_(geometry_terms), user_x_(user_x) {
    const auto& L = obj.layout();
    for (const auto& p : L.physics())
      if (p.index >= 0) {
        blocks_.push_back({std::size_t(p.index), 1});
        cols_.push_back({p.kind == PhysKind::kAlpha ? ColumnKind::kLogAlpha
                         : p.kind == PhysKind::kC1  ? ColumnKind::kLogC1
                                                    : ColumnKind::kLogMu,
                         p.label});
      }
    const auto& n = L.recordings()[rec];
    if (n.bias >= 0) { bias_block_ = int(blocks_.size()); blocks_.push_back({std::size_t(n.bias), 3}); cols_.push_back({}); }
    if (n.lag >= 0) { blocks_.push_back({std::size_t(n.lag), 1}); cols_.push_back({ColumnKind::kLagMs, 0}); }
    if (n.depth >= 0) { blocks_.push_back({std::size_t(n.depth), 1}); cols_.push_back({ColumnKind::kDepthMm, 0}); }
    if (n.pose >= 0) { pose_block_ = int(blocks_.size()); blocks_.push_back({std::size_t(n.pose), 6}); cols_.push_back({ColumnKind::kPose, 0}); }
    if (n.torque_bias >= 0) { tbias_block_ = int(blocks_.size()); blocks_.push_back({std::size_t(n.torque_bias), 3}); cols_.push_back({}); }
    if (n.spindle >= 0) { spindle_block_ = int(blocks_.size()); blocks_.push_back({std::size_t(n.spindle), 2}); cols_.push_back({}); }
    if (n.spindle_lag >= 0) { slag_block_ = int(blocks_.size()); blocks_.push_back({std::size_t(n.spindle_lag), 1}); cols_.push_back({}); }
    for (const auto& b : blocks_) mutable_parameter_block_sizes()->push_back(int(b.size));
    rows_ = std::size_t(L.channels().rows_per_sample());
    set_num_residuals(int(rows_ * obj.models()[rec]->size()));
  }
  const std::vector<Layout::Block>& blocks() const { return blocks_; }
  // Called once the problem's constant blocks are set: Ceres asks for a Jacobian of the
  // others only, which fixes the columns a prefetch predicts.
  void note_constant_blocks(const ceres::Problem& problem) {
    free_.assign(blocks_.size(), false);
    for (std::size_t b = 0; b < blocks_.size(); ++b)
      free_[b] = !problem.IsParameterBlockConstant(user_x_ + blocks_[b].offset);
  }
  // Predicts at the user's parameter values (where Ceres put the point it is about to
  // evaluate, EvaluationCallback) into the cache that Evaluate then reads.
  void prefetch(bool jacobians) const {
    std::vector<const double*> params;
    for (const auto& b : blocks_) params.push_back(user_x_ + b.offset);
    prediction(params.data(), jacobians ? free_ : std::vector<bool>(blocks_.size(), false), nullptr);
  }

  // An error here (a cancelled replay, or any other) must not escape on one of Ceres's
  // threads, where nothing catches it (std::terminate). It is kept, the solve aborts at its
  // next iteration (IterationWatch), and every call into Ceres is followed by
  // rethrow_error(), so nothing Ceres computed from here on is used. The evaluation
  // answers zeros rather than false: a failed evaluation at the start point makes Ceres
  // print "Terminating: Residual and Jacobian evaluation failed" on stderr (glog).
  bool Evaluate(double const* const* params, double* residuals, double** jac) const override {
    try {
      return evaluate(params, residuals, jac);
    } catch (...) {
      {
        std::lock_guard lk(error_mu_);
        if (!error_) error_ = std::current_exception();
        failed_ = true;
      }
      std::fill_n(residuals, num_residuals(), 0.0);
      for (std::size_t b = 0; jac && b < blocks_.size(); ++b)
        if (jac[b]) std::fill_n(jac[b], std::size_t(num_residuals()) * blocks_[b].size, 0.0);
      return true;
    }
  }
  bool failed() const { return failed_.load(); }
  void rethrow_error() const {
    std::lock_guard lk(error_mu_);
    if (error_) std::rethrow_exception(error_);
  }

 private:
  bool evaluate(double const* const* params, double* residuals, double** jac) const {
    // Rebuild a full x from the blocks (entries of other recordings are irrelevant here).
    const auto& L = obj_.layout();
    std::vector<double> x(L.size(), 0.0);
    for (std::size_t b = 0; b < blocks_.size(); ++b)
      for (std::size_t k = 0; k < blocks_[b].size; ++k) x[blocks_[b].offset + k] = params[b][k];
    const auto& nz = L.recordings()[rec_];
    std::vector<int> col_of_block(blocks_.size(), -1);
    std::vector<bool> with_jac(blocks_.size(), false);
    for (std::size_t b = 0; jac && b < blocks_.size(); ++b) with_jac[b] = jac[b] != nullptr;
    const Prediction& pred = prediction(params, with_jac, &col_of_block);
    const auto* model = obj_.models()[rec_];
    const auto& s = obj_.settings();
    const Channels& ch = L.channels();
    const Offsets off = offsets_at(nz, x.data());
    const Robust robust{s.loss, s.loss_scale * s.loss_scale};
    const std::size_t n = model->size(), R = rows_;
    std::array<double, 7> raw{};
    for (std::size_t j = 0; j < n; ++j) {
      const double w = sample_weight(s, w_[j], pred.buried[j] != 0);
      const double sw = std::sqrt(w);
      raw_residuals(s, ch, *model, pred, off, j, raw.data());
      const Shifted sp_at = ch.spindle ? shifted(model->t_s(), j, off.spindle_lag_ms) : Shifted{};
      for (std::size_t a = 0; a < R; ++a) {
        const std::size_t row = R * j + a;
        const double r = raw[a];
        const double sq = r * r;
        const double rt = std::copysign(std::sqrt(robust.rho(sq)), r);
        residuals[row] = sw * rt;
        if (!jac) continue;
        // Which channel this row is, and its σ.
        const int chan = a < 3 ? 0 : (ch.torque && a < 6) ? 1 : 2;
        const int axis = chan == 0 ? int(a) : chan == 1 ? int(a) - 3 : 0;
        const double sigma = chan == 0 ? s.sigma_N : chan == 1 ? s.sigma_torque_Nmm : s.sigma_spindle_Nmm;
        // d r̃/d r = ρ'(r²)·r / r̃ (→ 1 as r → 0).
        const double g = sw * (rt != 0 ? robust.drho(sq) * r / rt : 1.0) / sigma;
        auto column = [&](std::size_t c) {  // d(prediction of this row)/d(column c)
          return chan == 0 ? pred.columns[c][j][axis]
                 : chan == 1 ? pred.torque_columns[c][j][axis]
                             : sp_at.value(pred.spindle_columns[c]);
        };
        for (std::size_t b = 0; b < blocks_.size(); ++b) {
          if (!jac[b]) continue;
          const std::size_t bs = blocks_[b].size;
          double* J = jac[b] + row * bs;
          if (int(b) == bias_block_) {
            for (std::size_t k = 0; k < 3; ++k) J[k] = (chan == 0 && int(k) == axis) ? g : 0.0;
          } else if (int(b) == tbias_block_) {
            for (std::size_t k = 0; k < 3; ++k) J[k] = (chan == 1 && int(k) == axis) ? g : 0.0;
          } else if (int(b) == spindle_block_) {
            J[0] = chan == 2 ? g : 0.0;
            J[1] = chan == 2 ? g * model->spindle_krpm()[j] : 0.0;
          } else if (int(b) == slag_block_) {
            J[0] = chan == 2 ? -1e-3 * g * sp_at.slope(pred.spindle_Nmm) : 0.0;
          } else if (int(b) == pose_block_) {
            for (std::size_t k = 0; k < 6; ++k) J[k] = g * column(std::size_t(col_of_block[b]) + k);
          } else {
            J[0] = g * column(std::size_t(col_of_block[b]));
          }
        }
      }
    }
    return true;
  }

  // The prediction at `params` with a column for every block that `with_jac` marks
  // (col_of_block: each block's first column, or −1). Ceres evaluates a point more than
  // once (the prefetch, then Evaluate; the residuals only, then with the Jacobian). A
  // replay is deterministic, so the last prediction is reused when the point matches and
  // it has the columns asked for (a prediction with columns also answers one without).
  const Prediction& prediction(double const* const* params, const std::vector<bool>& with_jac,
                               std::vector<int>* col_of_block) const {
    const auto& L = obj_.layout();
    std::vector<Column> want;
    for (std::size_t b = 0; b < blocks_.size(); ++b)
      if (with_jac[b] && int(b) != bias_block_ && int(b) != tbias_block_ && int(b) != spindle_block_ &&
          int(b) != slag_block_) {
        if (col_of_block) (*col_of_block)[b] = int(want.size());
        if (int(b) == pose_block_)
          for (std::uint8_t k = 0; k < 6; ++k) want.push_back({ColumnKind::kPose, k});
        else
          want.push_back(cols_[b]);
      }
    std::vector<double> key;
    for (std::size_t b = 0; b < blocks_.size(); ++b) key.insert(key.end(), params[b], params[b] + blocks_[b].size);
    const bool hit = cache_.valid && cache_.x == key && (want.empty() || cache_.want == want);
    if (!hit) {
      cache_.valid = false;  // until the prediction is whole (predict may throw)
      std::vector<double> x(L.size(), 0.0);
      for (std::size_t b = 0; b < blocks_.size(); ++b)
        for (std::size_t k = 0; k < blocks_[b].size; ++k) x[blocks_[b].offset + k] = params[b][k];
      cache_.pred = Prediction{};
      obj_.models()[rec_]->predict(eval_point(L, x.data(), rec_, geometry_terms_), want, cache_.pred);
      replays_ += cache_.pred.replays;
      cache_.x = std::move(key);
      cache_.want = std::move(want);
      cache_.valid = true;
    }
    return cache_.pred;
  }

  const Objective& obj_;
  std::size_t rec_;
  const std::vector<double>& w_;
  std::atomic<std::uint64_t>& replays_;
  bool geometry_terms_;
  double* user_x_;           // the problem's parameter memory (blocks point into it)
  std::vector<bool> free_;   // per block: not constant (Ceres asks for its Jacobian)
  std::vector<Layout::Block> blocks_;
  std::vector<Column> cols_;
  int bias_block_ = -1, pose_block_ = -1, tbias_block_ = -1, spindle_block_ = -1, slag_block_ = -1;
  std::size_t rows_ = 3;  // residuals per sample
  mutable std::mutex error_mu_;
  mutable std::exception_ptr error_;  // the first error of an evaluation
  mutable std::atomic<bool> failed_{false};
  // The last evaluation (Ceres evaluates one residual block on one thread at a time).
  struct Cache {
    bool valid = false;
    std::vector<double> x;
    std::vector<Column> want;
    Prediction pred;
  };
  mutable Cache cache_;
};

// Before Ceres evaluates the recordings at a point, every recording's prediction is
// queued on the replay pool at once, so the pool runs the longest first and both workers
// stay busy. Left to Ceres, its threads (two at most in the Debian build) take the
// recordings in a fixed split: on the reference experiment one took the sweep (46 % of the
// samples) and both plunges while the other idled after the polishes.
class Prefetch final : public ceres::EvaluationCallback {
 public:
  std::vector<RecordingCost*> costs;
  bool enabled = true;  // false: a solve asked to use one thread evaluates one recording at a time
  void PrepareForEvaluation(bool jacobians, bool new_point) override {
    if (!enabled || costs.size() < 2 || (!new_point && !jacobians)) return;
    std::vector<std::thread> threads;
    for (RecordingCost* c : costs)  // longest first (build): it reaches the pool first
      threads.emplace_back([c, jacobians] {
        try {
          c->prefetch(jacobians);
        } catch (...) {
          // Left for the recording's own Evaluate to raise again, where Ceres expects it.
        }
      });
    for (auto& t : threads) t.join();
  }
};

struct BuiltProblem {
  Prefetch prefetch;  // outlives `problem`, which refers to it
  ceres::Problem problem;
  std::vector<double*> block_ptrs;  // per layout block
  BuiltProblem() : problem([this] {
    ceres::Problem::Options o;
    o.evaluation_callback = &prefetch;
    return o;
  }()) {}
  bool failed() const {
    return std::any_of(prefetch.costs.begin(), prefetch.costs.end(), [](const RecordingCost* c) { return c->failed(); });
  }
  // After Ceres has returned: an evaluation's error, as if it had been thrown here.
  void rethrow_error() const {
    for (const RecordingCost* c : prefetch.costs) c->rethrow_error();
  }
};

void build(const Objective& obj, std::vector<double>& x, const SampleWeights& w,
           const std::vector<bool>& hold, std::atomic<std::uint64_t>& replays, BuiltProblem& bp,
           bool geometry_terms = true) {
  const auto& L = obj.layout();
  for (std::size_t r = 0; r < obj.models().size(); ++r) {
    auto* cost = new RecordingCost(obj, r, w[r], replays, geometry_terms, x.data());
    bp.prefetch.costs.push_back(cost);
    std::vector<double*> ptrs;
    for (const auto& b : cost->blocks()) ptrs.push_back(x.data() + b.offset);
    bp.problem.AddResidualBlock(cost, nullptr, ptrs);
  }
  for (const auto& m : L.mountings()) {
    double* p = x.data() + m.offset;
    if (bp.problem.HasParameterBlock(p)) bp.problem.AddResidualBlock(new PriorCost(m.sqrt_information), nullptr, p);
  }
  for (const auto& b : L.blocks()) {
    double* p = x.data() + b.offset;
    if (!bp.problem.HasParameterBlock(p)) continue;  // e.g. no recording
    bp.block_ptrs.push_back(p);
    bool held = !hold.empty() && hold[b.offset];
    if (held) {
      bp.problem.SetParameterBlockConstant(p);
      continue;
    }
    for (std::size_t k = 0; k < b.size; ++k) {
      const std::size_t i = b.offset + k;
      if (std::isfinite(L.lower(i))) bp.problem.SetParameterLowerBound(p, int(k), L.lower(i));
      if (std::isfinite(L.upper(i))) bp.problem.SetParameterUpperBound(p, int(k), L.upper(i));
    }
  }
  for (auto* cost : bp.prefetch.costs) cost->note_constant_blocks(bp.problem);
  std::stable_sort(bp.prefetch.costs.begin(), bp.prefetch.costs.end(),
                   [](const RecordingCost* a, const RecordingCost* b) { return a->num_residuals() > b->num_residuals(); });
}

// Per iteration: the progress line, and SolveOptions::stop_early on the costs so far.
class IterationWatch final : public ceres::IterationCallback {
 public:
  IterationWatch(Progress* p, int max_it, const SolveOptions& o, const BuiltProblem& bp)
      : p_(p), max_(max_it), o_(o), bp_(bp) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (bp_.failed()) return ceres::SOLVER_ABORT;  // the error is rethrown after Solve
    // No fraction: iterations over the limit would read as the share of the work done,
    // and most solves converge well before their limit; the count says both.
    if (p_)
      p_->update(-1, fmt::format("iter {:3d}/{}  cost {:.6g}  step {:.3g}  elapsed {:.1f} s", s.iteration, max_,
                                 s.cost, s.step_norm, s.cumulative_time_in_seconds));
    costs_.push_back(s.cost);
    if (o_.stop_early && o_.stop_early(costs_)) {
      stopped = true;
      return ceres::SOLVER_TERMINATE_SUCCESSFULLY;
    }
    return ceres::SOLVER_CONTINUE;
  }
  bool stopped = false;

 private:
  Progress* p_;
  int max_;
  const SolveOptions& o_;
  const BuiltProblem& bp_;
  std::vector<double> costs_;
};

}  // namespace

Objective::Objective(const Layout& layout, std::vector<const RecordingModel*> models,
                     ObjectiveSettings settings)
    : layout_(layout), models_(std::move(models)), settings_(settings) {
  BURRBENCH_CHECK(models_.size() == layout_.recordings().size(), "one model per recording");
  BURRBENCH_CHECK(settings_.sigma_N > 0 && std::isfinite(settings_.sigma_N), "sigma must be > 0");
}

std::uint64_t Objective::replays() const { return replays_.load(); }

SolveOutcome Objective::solve(const std::vector<double>& x0, const SampleWeights& w,
                              const SolveOptions& options) const {
  const auto t0 = std::chrono::steady_clock::now();
  SolveOutcome out;
  out.x = inside_bounds(x0);
  BuiltProblem bp;
  build(*this, out.x, w, options.hold, replays_, bp, options.geometry_terms);
  bp.prefetch.enabled = options.threads > 1;
  ceres::Solver::Options so;
  so.linear_solver_type = options.normal_equations ? ceres::DENSE_NORMAL_CHOLESKY : ceres::DENSE_QR;
  so.max_num_iterations = options.max_iterations;
  so.num_threads = std::max(1, options.threads);
  so.function_tolerance = options.function_tolerance;
  so.gradient_tolerance = 1e-10;
  so.parameter_tolerance = 1e-8;
  // The bounds make the trust-region solver run a projected line search on each step. Its
  // default cubic interpolation takes the gradient at the trial point, i.e. a whole
  // Jacobian (a sensitivity replay, or every difference replay) for a point the step may
  // reject; quadratic interpolation needs only the trial's cost (Ceres's Armijo search
  // knows the gradient at the step's start). Reference experiment, back to back: default
  // calibration with 16 starts 54.3 → 37.1 s, estimates within 6·10⁻⁴ (docs/calibration.md).
  so.line_search_interpolation_type = ceres::QUADRATIC;
  so.minimizer_progress_to_stdout = false;
  IterationWatch cb(options.progress, options.max_iterations, options, bp);
  so.callbacks.push_back(&cb);
  ceres::Solver::Summary summary;
  ceres::Solve(so, &bp.problem, &summary);
  bp.rethrow_error();
  out.iterations = std::uint64_t(summary.iterations.size());
  // Ceres marks iteration 0 (the start) successful too.
  out.steps_taken = std::uint64_t(std::count_if(summary.iterations.begin(), summary.iterations.end(),
                                                [](const ceres::IterationSummary& it) {
                                                  return it.iteration > 0 && it.step_is_successful;
                                                }));
  out.initial_cost = summary.initial_cost;
  out.final_cost = summary.final_cost;
  out.termination = ceres::TerminationTypeToString(summary.termination_type) +
                    std::string(": ") + summary.message;
  out.usable = summary.IsSolutionUsable();
  out.stopped_early = cb.stopped;
  out.converged = summary.termination_type == ceres::CONVERGENCE;
  out.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

std::vector<double> Objective::inside_bounds(std::vector<double> x) const {
  for (std::size_t i = 0; i < x.size(); ++i) {
    const double lo = layout_.lower(i), hi = layout_.upper(i);
    if (std::isfinite(lo) && std::isfinite(hi)) {
      const double eps = 1e-6 * (hi - lo);
      x[i] = std::clamp(x[i], lo + eps, hi - eps);
    }
  }
  return x;
}

std::vector<Prediction> Objective::predict_all(const std::vector<double>& x, int only,
                                               bool geometry_terms) const {
  std::vector<Prediction> out(models_.size());
  // Predict every recording concurrently: each call queues its replay on the shared pool.
  std::vector<std::thread> threads;
  std::vector<std::exception_ptr> errors(models_.size());
  for (std::size_t r = 0; r < models_.size(); ++r) {
    if (only >= 0 && std::size_t(only) != r) continue;
    threads.emplace_back([&, r] {
      try {
        models_[r]->predict(eval_point(layout_, x.data(), r, geometry_terms), {}, out[r]);
      } catch (...) {
        errors[r] = std::current_exception();
      }
    });
  }
  for (auto& t : threads) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
  for (const auto& p : out) replays_ += p.replays;
  return out;
}

Evaluation Objective::evaluate(const std::vector<double>& x, const SampleWeights& w,
                               int only) const {
  Evaluation ev;
  ev.predictions = predict_all(x, only, true);
  const Robust robust{settings_.loss, settings_.loss_scale * settings_.loss_scale};
  if (only < 0) ev.cost += prior_cost(layout_, x);
  double lag_num = 0, lag_den = 0;
  for (std::size_t r = 0; r < models_.size(); ++r) {
    if (only >= 0 && std::size_t(only) != r) continue;
    const auto& pred = ev.predictions[r];
    const Offsets off = offsets_at(layout_.recordings()[r], x.data());
    const Channels& ch = layout_.channels();
    const std::size_t R = std::size_t(ch.rows_per_sample());
    std::array<double, 7> prev{}, cur{};
    bool has_prev = false;  // the previous sample was used (lag-1 pairs never span a gap)
    for (std::size_t j = 0; j < models_[r]->size(); ++j) {
      if (w[r][j] == 0) {
        ++ev.samples_excluded;
        has_prev = false;
        continue;
      }
      if (pred.buried[j]) ++ev.samples_buried;
      const double sw = sample_weight(settings_, w[r][j], pred.buried[j] != 0);
      if (sw == 0) {
        has_prev = false;
        continue;
      }
      ++ev.samples_used;
      ev.residuals_used += R;
      raw_residuals(settings_, ch, *models_[r], pred, off, j, cur.data());
      for (std::size_t a = 0; a < R; ++a) {
        ev.cost += 0.5 * sw * robust.rho(cur[a] * cur[a]);
        cur[a] *= std::sqrt(sw);
        if (has_prev) lag_num += prev[a] * cur[a];
        lag_den += cur[a] * cur[a];
      }
      prev = cur;
      has_prev = true;
    }
  }
  ev.residual_lag1 = lag_den > 0 ? lag_num / lag_den : 0.0;
  return ev;
}

double ar1_inflation(double rho) {
  const double r = std::clamp(std::isfinite(rho) ? rho : 0.0, 0.0, 0.95);
  return (1 + r) / (1 - r);
}

CovarianceOutcome Objective::covariance(const std::vector<double>& x_in, const SampleWeights& w,
                                        const std::vector<bool>& hold, double inflation) const {
  CovarianceOutcome out;
  out.inflation = inflation;
  std::vector<double> x = x_in;
  BuiltProblem bp;
  build(*this, x, w, hold, replays_, bp);
  // Covered entries and their blocks.
  std::vector<double*> blocks;
  for (const auto& b : layout_.blocks()) {
    double* p = x.data() + b.offset;
    if (!bp.problem.HasParameterBlock(p) || bp.problem.IsParameterBlockConstant(p)) continue;
    blocks.push_back(p);
    for (std::size_t k = 0; k < b.size; ++k) out.indices.push_back(b.offset + k);
  }
  const std::size_t m = out.indices.size();
  if (m == 0) return out;
  // Jacobian at x (one evaluation) for the residual variance and the null-space analysis.
  double cost = 0;
  ceres::CRSMatrix J;
  ceres::Problem::EvaluateOptions eo;
  eo.parameter_blocks.assign(blocks.begin(), blocks.end());
  eo.apply_loss_function = true;
  eo.num_threads = 2;
  std::vector<double> res;
  bp.problem.Evaluate(eo, &cost, &res, &out.gradient, &J);
  bp.rethrow_error();
  std::uint64_t used = 0;
  for (double r : res) used += (r != 0);
  const double dof = double(used) - double(m);
  out.residual_variance = dof > 0 ? 2 * cost / dof : 1.0;
  Eigen::MatrixXd H = Eigen::MatrixXd::Zero(Eigen::Index(m), Eigen::Index(m));
  for (int row = 0; row < J.num_rows; ++row)
    for (int a = J.rows[std::size_t(row)]; a < J.rows[std::size_t(row) + 1]; ++a)
      for (int b = J.rows[std::size_t(row)]; b < J.rows[std::size_t(row) + 1]; ++b)
        H(J.cols[std::size_t(a)], J.cols[std::size_t(b)]) += J.values[std::size_t(a)] * J.values[std::size_t(b)];
  if (layout_.channels().rows_per_sample() > 3) {
    // Rows come per recording block, rows_per_sample per sample with the force first,
    // then the registration priors (kept in both).
    const std::size_t per = std::size_t(layout_.channels().rows_per_sample());
    std::vector<std::uint8_t> force_row(std::size_t(J.num_rows), 1);
    std::size_t row = 0;
    for (const auto* model : models_)
      for (std::size_t k = 0; k < per * model->size(); ++k, ++row) {
        BURRBENCH_CHECK(row < force_row.size(), "Jacobian rows: one block of rows_per_sample rows per sample");
        force_row[row] = k % per < 3;
      }
    Eigen::MatrixXd Hf = Eigen::MatrixXd::Zero(Eigen::Index(m), Eigen::Index(m));
    for (int r = 0; r < J.num_rows; ++r) {
      if (!force_row[std::size_t(r)]) continue;
      for (int a = J.rows[std::size_t(r)]; a < J.rows[std::size_t(r) + 1]; ++a)
        for (int b = J.rows[std::size_t(r)]; b < J.rows[std::size_t(r) + 1]; ++b)
          Hf(J.cols[std::size_t(a)], J.cols[std::size_t(b)]) += J.values[std::size_t(a)] * J.values[std::size_t(b)];
    }
    out.info.assign(H.data(), H.data() + m * m);  // symmetric: storage order does not matter
    out.info_force.assign(Hf.data(), Hf.data() + m * m);
  }
  Eigen::VectorXd d = H.diagonal();
  out.info_diag.assign(d.data(), d.data() + m);
  Eigen::VectorXd s = d.unaryExpr([](double v) { return v > 0 ? 1 / std::sqrt(v) : 0.0; });
  Eigen::MatrixXd Hn = s.asDiagonal() * H * s.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(Hn);
  for (Eigen::Index j = 0; j < Eigen::Index(m); ++j) {
    out.eig_values.push_back(es.eigenvalues()(j));
    const Eigen::VectorXd v = es.eigenvectors().col(j);
    out.eig_vectors.emplace_back(v.data(), v.data() + m);
  }
  // The covariance proper: Ceres, dense SVD, rank deficiency tolerated (pseudo-inverse).
  ceres::Covariance::Options co;
  co.algorithm_type = ceres::DENSE_SVD;
  co.null_space_rank = -1;
  co.min_reciprocal_condition_number = 1e-14;
  co.num_threads = 2;
  co.apply_loss_function = true;
  ceres::Covariance cov(co);
  std::vector<std::pair<const double*, const double*>> pairs;
  for (std::size_t a = 0; a < blocks.size(); ++a)
    for (std::size_t b = a; b < blocks.size(); ++b) pairs.emplace_back(blocks[a], blocks[b]);
  const bool computed = cov.Compute(pairs, &bp.problem);
  bp.rethrow_error();
  if (!computed) return out;
  out.cov.assign(m * m, 0.0);
  const std::vector<const double*> cblocks(blocks.begin(), blocks.end());
  if (!cov.GetCovarianceMatrix(cblocks, out.cov.data())) return out;
  for (double& v : out.cov) v *= out.residual_variance * inflation;
  out.ok = true;
  return out;
}

}  // namespace burrbench::calibration
