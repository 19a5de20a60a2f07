#pragma once
// A closed-form stand-in for the replay with the same structure (force linear in C1,
// friction ∝ μ·C1, erosion ∝ μ·C1/α, lag shifts time, depth shifts the contact), used to
// check the solver, covariance and identifiability machinery on a problem with known
// truth and exact smooth derivatives. NOT a model of bone: the replay tests use synth data.
#include <cmath>
#include <mutex>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "burrbench/calibration/recording_model.hpp"

namespace burrbench::calibration::testing {

class AnalyticModel final : public RecordingModel {
 public:
  // touch2: whether class 2 is ever in contact; erode: whether α matters.
  AnalyticModel(std::string id, std::size_t n, bool touch2, bool erode)
      : id_(std::move(id)), touch2_(touch2), erode_(erode) {
    for (std::size_t j = 0; j < n; ++j) t_.push_back(0.002 * double(j));
    meas_.assign(n, glm::dvec3(0));
  }
  const std::string& id() const override { return id_; }
  std::size_t size() const override { return t_.size(); }
  const std::vector<double>& t_s() const override { return t_; }
  const std::vector<glm::dvec3>& measured_sensor_N() const override { return meas_; }

  // Measured = model at truth + bias + Gaussian noise of SD `noise`, an AR(1) process of
  // lag-1 autocorrelation `rho` per axis (0: white).
  void synthesise(const EvalPoint& truth, glm::dvec3 bias, double noise, unsigned seed,
                  double rho = 0) {
    Prediction p;
    predict(truth, {}, p);
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> N(0, noise);
    glm::dvec3 e(N(rng), N(rng), N(rng));
    const double innov = std::sqrt(1 - rho * rho);
    for (std::size_t j = 0; j < size(); ++j) {
      if (j > 0) e = rho * e + innov * glm::dvec3(N(rng), N(rng), N(rng));
      meas_[j] = p.force_sensor_N[j] + bias + e;
    }
  }

  void predict(const EvalPoint& at, const std::vector<Column>& cols, Prediction& out) const override {
    forces(at, out.force_sensor_N, &out.class_mask, &out.removed_mm3);
    out.buried.assign(size(), 0);
    out.replays = 1;
    {  // count derivative predictions, repeats at one point, and those at untried points
      std::vector<double> point{at.lag_ms, at.depth_mm};
      for (int k = 1; k <= 2; ++k)
        point.insert(point.end(), {at.physics.alpha[k], at.physics.c1[k], at.physics.mu[k]});
      // Side-by-side solves (the multistart's) predict one model at once.
      static std::mutex count_mu;
      std::lock_guard lk(count_mu);
      if (cols.empty()) {
        plain_seen_.insert(point);
      } else {
        ++column_calls;
        columns_at_untried_points += plain_seen_.count(point) == 0;
        point.push_back(double(cols.size()));
        repeated_column_calls += !seen_.insert(point).second;
      }
    }
    for (const auto& c : cols) {
      const double h = 1e-5;
      EvalPoint a = at, b = at;
      auto bump = [&](EvalPoint& e, double s) {
        switch (c.kind) {
          case ColumnKind::kLogAlpha: e.physics.alpha[c.label] *= std::exp(s); break;
          case ColumnKind::kLogC1: e.physics.c1[c.label] *= std::exp(s); break;
          case ColumnKind::kLogMu: e.physics.mu[c.label] *= std::exp(s); break;
          case ColumnKind::kLagMs: e.lag_ms += s; break;
          case ColumnKind::kDepthMm: e.depth_mm += s; break;
          case ColumnKind::kPose: e.pose[c.label] += s; break;  // no effect in this model
        }
      };
      bump(a, h);
      bump(b, -h);
      std::vector<glm::dvec3> fa, fb;
      forces(a, fa, nullptr, nullptr);
      forces(b, fb, nullptr, nullptr);
      std::vector<glm::dvec3> col(size());
      for (std::size_t j = 0; j < size(); ++j) col[j] = (fa[j] - fb[j]) / (2 * h);
      out.columns.push_back(std::move(col));
    }
  }

 private:
  void forces(const EvalPoint& at, std::vector<glm::dvec3>& f, std::vector<std::uint8_t>* mask,
              PerLabel* removed) const {
    f.assign(size(), glm::dvec3(0));
    if (mask) mask->assign(size(), 0);
    if (removed) removed->fill(0);
    const auto& P = at.physics;
    for (std::size_t j = 0; j < size(); ++j) {
      const double t = t_[j] - at.lag_ms * 1e-3;
      const double T = t_.back();
      for (std::uint8_t k = 1; k <= 2; ++k) {
        const bool on = k == 1 ? t_[j] < 0.6 * T : (touch2_ && t_[j] > 0.4 * T);
        if (!on) continue;
        if (mask) (*mask)[j] |= std::uint8_t(1u << k);
        const double w = 2 * M_PI * (k == 1 ? 3.0 : 5.0);
        const double depth = 0.5 + 0.3 * std::sin(w * t) + at.depth_mm;
        const double rate = erode_ ? P.mu[k] * P.c1[k] / P.alpha[k] : 0.0;
        const double e = std::exp(-rate * t);  // material left after erosion
        const double fe = P.c1[k] * depth * e;
        const glm::dvec3 n(0.3 * std::cos(w * t), 0.2, 1.0);
        const glm::dvec3 tang(std::cos(0.5 * w * t), std::sin(0.5 * w * t), 0.1);
        f[j] += fe * n + P.mu[k] * fe * tang;
        if (removed && erode_) (*removed)[k] += rate * 1e-3;
      }
    }
  }
  mutable std::set<std::vector<double>> seen_, plain_seen_;

 public:
  mutable std::size_t column_calls = 0, repeated_column_calls = 0;
  // Derivative predictions at a point never predicted without them first.
  mutable std::size_t columns_at_untried_points = 0;

 private:
  std::string id_;
  std::vector<double> t_;
  std::vector<glm::dvec3> meas_;
  bool touch2_, erode_;
};

}  // namespace burrbench::calibration::testing
