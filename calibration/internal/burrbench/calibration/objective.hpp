#pragma once
// The least-squares objective over all recordings and its Ceres solve.
//
// Residual per used sample and axis: r = (predicted sensor force + bias − measured)/σ,
// then multiplied by √w (w: bootstrap multiplicity × buried weight; 0 = not used). With
// the torque channel, 3 more per sample: (predicted moment + moment bias − measured)/σ_M;
// with the spindle channel 1 more: (predicted load + idle + viscous·krpm − measured)/σ_S.
// The robust loss is applied per residual (not per recording, which is what a Ceres
// LossFunction on a whole residual block would do): r̃ = sign(r)·√ρ(r²), so Σ r̃² = Σ ρ(r²).
#include <algorithm>
#include <atomic>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "burrbench/calibration/parameters.hpp"
#include "burrbench/calibration/recording_model.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/progress.hpp"

namespace burrbench::calibration {

struct ObjectiveSettings {
  data_schema::LossKind loss = data_schema::LossKind::kHuber;
  double loss_scale = 3.0;  // in units of σ
  data_schema::BuriedPolicy buried = data_schema::BuriedPolicy::kExclude;
  double buried_weight = 0.1;  // squared-residual weight of a buried sample when down-weighted
  double sigma_N = 0.02;
  // The other channels' noise (used when the layout fits them, Layout::channels()).
  double sigma_torque_Nmm = 1.0;
  double sigma_spindle_Nmm = 0.1;
};

// Per recording, per force sample: weight of its residuals (0 = not used: outside the
// used segments, held out, or not drawn by the bootstrap).
using SampleWeights = std::vector<std::vector<double>>;

struct SolveOptions {
  int max_iterations = 50;
  int threads = 2;  // Ceres evaluates recordings concurrently
  double function_tolerance = 1e-7;
  Progress* progress = nullptr;
  std::vector<bool> hold;  // per x entry: true = held constant (empty: none)
  bool geometry_terms = true;  // see EvalPoint::geometry_terms
  // Called after every iteration with the costs so far (entry 0: the start); true ends
  // the solve there, keeping its point (SolveOutcome::stopped_early).
  std::function<bool(const std::vector<double>& costs)> stop_early;
  // Solve each step's linear system by Cholesky of JᵀJ instead of QR of J: 4× faster on
  // the pre-fit's held-geometry solves (hundreds of thousands of rows, no replay behind
  // them, ~20 well-scaled columns), where QR was half of the pre-fit's time.
  bool normal_equations = false;
};

// The cheap pre-fit (Objective::prefit): C1, μ and the linear nuisances (bias, the
// moment's bias, the spindle's idle and viscous terms) with lag, depth and pose held and
// each α moved with its class's C1·μ, so that the replayed geometry stays.
struct PrefitOptions {
  // Replays per recording at most. Each holds its geometry while C1, μ and the nuisances
  // are solved exactly on it (FixedGeometryTerms); the next replays at the result.
  int replays = 3;
  // Threads of the fallback's solve below. With fixed-geometry terms every replay queues
  // all recordings at once on the pool, and the held-geometry solves run on one thread.
  int threads = 2;
  // Models without fixed-geometry terms (a closed-form test model): Levenberg–Marquardt
  // iterations with the fixed-geometry Jacobian, every point replayed.
  int fallback_iterations = 4;
};

struct SolveOutcome {
  std::vector<double> x;
  std::uint64_t iterations = 0;
  std::uint64_t steps_taken = 0;  // accepted steps (0: x is the start)
  double initial_cost = 0, final_cost = 0;
  std::string termination;
  bool usable = false;
  bool stopped_early = false;  // SolveOptions::stop_early ended it
  bool converged = false;      // Ceres's CONVERGENCE (not an iteration limit or a stop)
  double wall_s = 0;
};

struct Evaluation {
  double cost = 0;                    // ½ Σ r̃²
  std::uint64_t residuals_used = 0;   // residuals with weight > 0
  std::uint64_t samples_used = 0, samples_buried = 0, samples_excluded = 0;
  std::vector<Prediction> predictions;  // per recording, without derivative columns
  // Lag-1 autocorrelation of the weighted residuals: Σ r_j r_{j+1} / Σ r_j² over
  // consecutive used samples of each recording and axis (0 for white noise).
  double residual_lag1 = 0;
};

// Variance inflation of an estimate whose residuals follow an AR(1) process of lag-1
// autocorrelation ρ: (1 + ρ)/(1 − ρ), the bound reached by slowly varying regressors (the
// replayed force at 1 kHz). Never below 1 (a negative ρ does not narrow an interval); ρ is
// capped at 0.95.
double ar1_inflation(double rho);

struct CovarianceOutcome {
  bool ok = false;
  std::vector<std::size_t> indices;  // x entries covered (free and not held)
  std::vector<double> cov;           // |indices|² row-major, scaled space, × residual variance × inflation
  double residual_variance = 1;      // 2·cost / (used residuals − parameters)
  double inflation = 1;              // the noise-model factor applied besides (ar1_inflation)
  std::vector<double> info_diag;     // diag(JᵀJ) per covered entry
  std::vector<double> gradient;      // ∂cost/∂x = Jᵀr per covered entry (loss applied)
  std::vector<double> eig_values;    // of the unit-diagonal information matrix (ascending)
  std::vector<std::vector<double>> eig_vectors;  // eig_vectors[j] = eigenvector of eig_values[j]
  // With channels besides the force: JᵀJ over every row (info) and over the force rows
  // and priors alone (info_force), |indices|² row-major, to compare what each adds.
  std::vector<double> info, info_force;
  // Where x entry `entry` sits in `indices` (indices.size(): not covered).
  std::size_t position(std::size_t entry) const {
    return std::size_t(std::find(indices.begin(), indices.end(), entry) - indices.begin());
  }
};

class Objective {
 public:
  Objective(const Layout& layout, std::vector<const RecordingModel*> models,
            ObjectiveSettings settings);
  const Layout& layout() const { return layout_; }
  const std::vector<const RecordingModel*>& models() const { return models_; }
  const ObjectiveSettings& settings() const { return settings_; }

  SolveOutcome solve(const std::vector<double>& x0, const SampleWeights& w,
                     const SolveOptions& options) const;
  // The cheap pre-fit from x0 (PrefitOptions): final_cost is the replayed cost at x.
  SolveOutcome prefit(const std::vector<double>& x0, const SampleWeights& w,
                      const PrefitOptions& options) const;
  // only >= 0: replay and score that recording alone (the others count as cost 0).
  Evaluation evaluate(const std::vector<double>& x, const SampleWeights& w, int only = -1) const;
  // `inflation`: multiplies the covariance besides the residual variance (ar1_inflation).
  CovarianceOutcome covariance(const std::vector<double>& x, const SampleWeights& w,
                               const std::vector<bool>& hold, double inflation = 1) const;

  // Every recording's prediction at x with its fixed-geometry terms (Prediction::fixed, for
  // replay-backed models): the parts of the predicted force, elastic and friction, by class.
  std::vector<Prediction> predict_parts(const std::vector<double>& x) const { return predict_all(x, -1, false); }

  // Replays done so far through this objective (all threads).
  std::uint64_t replays() const;

 private:
  // Every recording's prediction at x (only >= 0: that one), concurrently, without columns;
  // counts their replays.
  std::vector<Prediction> predict_all(const std::vector<double>& x, int only, bool geometry_terms) const;
  // x strictly inside the layout's bounds.
  std::vector<double> inside_bounds(std::vector<double> x) const;
  const Layout& layout_;
  std::vector<const RecordingModel*> models_;
  ObjectiveSettings settings_;
  mutable std::atomic<std::uint64_t> replays_{0};
};

}  // namespace burrbench::calibration
