// The cost's texture at the optimum (docs/calibration.md "Profiles on a textured cost").
// The voxel model's cost is not smooth at the scale of the profile threshold: a refit that
// starts a profile's distance from the optimum stops in a dip of the texture, on average
// above the optimum it came from (the session of issue 55: refits from ≈ 2 SE away ended
// 0.1–1.6 above an optimum whose threshold was 2.2). A profile point stops the same way,
// so a profile read against the χ² threshold alone closes early and its interval is too
// narrow. The probes measure that excess; its median is added to the threshold.
#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Eigenvalues>

#include "burrbench/calibration/profile.hpp"
#include "burrbench/model/job_queue.hpp"

namespace burrbench::calibration {
namespace {

// The probes' starts: on the covariance ellipsoid of Mahalanobis radius 2 (where the 95 %
// profile points lie), in four sign patterns of its principal axes: all +, all −, and two
// alternating.
double probe_sign(std::size_t k, std::size_t axis) {
  const double pattern = k < 2 ? 1.0 : (axis % 2 == 0 ? 1.0 : -1.0);
  return k % 2 == 0 ? pattern : -pattern;
}

}  // namespace

TextureProbe probe_texture(const Objective& obj, const std::vector<double>& x_hat, double cost_hat,
                           const SampleWeights& w, const std::vector<bool>& held, const CovarianceOutcome& cov,
                           double threshold, int threads) {
  TextureProbe t;
  const std::size_t m = cov.indices.size();
  if (!cov.ok || m == 0) return t;
  const Layout& L = obj.layout();
  const Eigen::Map<const Eigen::MatrixXd> S(cov.cov.data(), Eigen::Index(m), Eigen::Index(m));
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(S);
  if (es.info() != Eigen::Success) return t;
  const double radius = 2.0 / std::sqrt(double(m));  // |z| = √m ⇒ Mahalanobis radius 2
  ProfileOptions po;
  po.threads = threads;
  SolveOptions so = profile_point_solve(po, threshold, cost_hat);
  so.hold = held;
  t.starts.assign(kTextureProbes, x_hat);
  for (std::size_t k = 0; k < kTextureProbes; ++k) {
    std::vector<double>& x = t.starts[k];
    for (std::size_t a = 0; a < m; ++a) {
      const double scale = radius * probe_sign(k, a) * std::sqrt(std::max(0.0, es.eigenvalues()[Eigen::Index(a)]));
      for (std::size_t b = 0; b < m; ++b) x[cov.indices[b]] += scale * es.eigenvectors()(Eigen::Index(b), Eigen::Index(a));
    }
    for (const std::size_t e : cov.indices) x[e] = std::clamp(x[e], L.lower(e), L.upper(e));
  }
  std::vector<SolveOutcome> ends(kTextureProbes);
  std::vector<std::size_t> queue(kTextureProbes);
  std::iota(queue.begin(), queue.end(), std::size_t(0));
  model::run_job_queue(kTextureProbes, queue, threads,
                       [&](std::size_t, std::size_t k) { ends[k] = obj.solve(t.starts[k], w, so); });
  std::vector<double> above;
  for (const auto& e : ends) {
    const double d = e.usable ? e.final_cost - cost_hat : INFINITY;
    t.excess.push_back(d);
    if (std::isfinite(d)) above.push_back(std::max(0.0, d));
    if (e.usable && e.final_cost < t.cheapest_cost) {
      t.cheapest_cost = e.final_cost;
      t.cheapest_at = e.x;
    }
  }
  if (!above.empty()) {
    std::sort(above.begin(), above.end());
    const std::size_t n = above.size();
    t.allowance = n % 2 ? above[n / 2] : 0.5 * (above[n / 2 - 1] + above[n / 2]);
  }
  return t;
}

}  // namespace burrbench::calibration
