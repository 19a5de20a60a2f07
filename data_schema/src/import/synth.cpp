// Seeded synthetic sample. The trabecular core is the band |g| < t of a smoothed, unit-
// variance Gaussian random field g: a connected network of plates, the usual model of
// trabecular bone. t is chosen (bisection) so the core's mean χ equals 1 − porosity;
// χ ramps over about one voxel across each plate surface (partial volume).
#include "burrbench/data_schema/import/synth.hpp"

#include <cmath>
#include <numbers>
#include <random>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/import/volume.hpp"

namespace burrbench::data_schema::import {
namespace {

// Box–Muller on mt19937_64 bits: the standard library's normal_distribution differs
// between implementations; this does not.
class Normal {
 public:
  explicit Normal(std::uint64_t seed) : rng_(seed) {}
  double operator()() {
    const double u1 = (double(rng_() >> 11) + 0.5) * 0x1.0p-53;
    const double u2 = double(rng_() >> 11) * 0x1.0p-53;
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * std::numbers::pi * u2);
  }

 private:
  std::mt19937_64 rng_;
};

// Separable Gaussian blur (clamped borders) along axis a.
void blur_axis(std::vector<double>& v, const std::array<std::size_t, 3>& d, int a, const std::vector<double>& k) {
  const int r = static_cast<int>(k.size() / 2);
  const std::array<std::size_t, 3> stride{1, d[0], d[0] * d[1]};
  const auto ua = static_cast<std::size_t>(a);
  const long n = static_cast<long>(d[ua]);
  std::vector<double> line(d[ua]), out(d[ua]);
  const std::size_t other1 = (ua + 1) % 3, other2 = (ua + 2) % 3;
  for (std::size_t i = 0; i < d[other1]; ++i)
    for (std::size_t j = 0; j < d[other2]; ++j) {
      const std::size_t base = i * stride[other1] + j * stride[other2];
      for (long p = 0; p < n; ++p) line[static_cast<std::size_t>(p)] = v[base + static_cast<std::size_t>(p) * stride[ua]];
      for (long p = 0; p < n; ++p) {
        double acc = 0;
        for (int q = -r; q <= r; ++q) {
          const long s = std::clamp(p + q, 0L, n - 1);
          acc += k[static_cast<std::size_t>(q + r)] * line[static_cast<std::size_t>(s)];
        }
        out[static_cast<std::size_t>(p)] = acc;
      }
      for (long p = 0; p < n; ++p) v[base + static_cast<std::size_t>(p) * stride[ua]] = out[static_cast<std::size_t>(p)];
    }
}

}  // namespace

SampleVolume synth_sample(const SynthSettings& s) {
  const std::string f = "<synth>";
  if (!(s.voxel_mm > 0) || !std::isfinite(s.voxel_mm)) throw InputError(f, "voxel_mm", "a positive voxel size");
  if (!(s.porosity > 0 && s.porosity < 1)) throw InputError(f, "porosity", "a value in (0, 1)", fmt::format("{}", s.porosity));
  if (!(s.compact_mm >= 0) || !std::isfinite(s.compact_mm)) throw InputError(f, "compact_mm", "a thickness ≥ 0");
  if (!(s.strut_mm > 0) || !std::isfinite(s.strut_mm)) throw InputError(f, "strut_mm", "a positive length");
  SampleVolume v;
  for (int a = 0; a < 3; ++a) {
    const double n = std::round(s.extent_mm[a] / s.voxel_mm);
    if (!(n >= 1) || n > 1e5) throw InputError(f, "extent_mm", "extents giving 1..100000 voxels per axis");
    v.dims[static_cast<std::size_t>(a)] = static_cast<std::size_t>(n);
  }
  const std::size_t n = v.voxel_count();
  if (n > kDefaultBudgetBytes / (sizeof(double) + 5)) throw InputError(f, "extent_mm", "a volume within the memory budget");
  v.voxel_mm = s.voxel_mm;
  v.origin_mm = glm::dvec3(s.voxel_mm / 2);  // the sample spans [0, extent]

  Normal normal(s.seed);
  std::vector<double> g(n);
  for (double& x : g) x = normal();
  const double sigma = s.strut_mm / s.voxel_mm;
  const int r = std::max(1, static_cast<int>(std::ceil(3 * sigma)));
  std::vector<double> k(static_cast<std::size_t>(2 * r + 1));
  double ks = 0;
  for (int q = -r; q <= r; ++q) ks += k[static_cast<std::size_t>(q + r)] = std::exp(-0.5 * q * q / (sigma * sigma));
  for (double& x : k) x /= ks;
  for (int a = 0; a < 3; ++a) blur_axis(g, v.dims, a, k);
  double var = 0, grad = 0;
  for (double x : g) var += x * x;
  const double sd = std::sqrt(var / double(n));
  for (double& x : g) x /= sd;
  for (std::size_t i = 0; i + 1 < n; ++i) grad += std::abs(g[i + 1] - g[i]);
  const double ramp = std::max(1e-6, grad / double(n));  // |Δg| per voxel: χ ramps over ~1 voxel

  const double top = double(v.dims[2]) * s.voxel_mm - s.compact_mm;  // compact where centre z ≥ top
  const std::size_t plane = v.dims[0] * v.dims[1];
  std::size_t z_compact = v.dims[2];
  for (std::size_t z = 0; z < v.dims[2]; ++z) {
    if (v.origin_mm.z + double(z) * s.voxel_mm >= top) { z_compact = z; break; }
  }
  const std::size_t core = z_compact * plane;
  auto chi = [&](double x, double t) { return std::clamp(0.5 + (t - std::abs(x)) / ramp, 0.0, 1.0); };
  double lo = 0, hi = 10, achieved = 0;
  if (core > 0) {
    for (int it = 0; it < 60; ++it) {
      const double t = 0.5 * (lo + hi);
      double m = 0;
      for (std::size_t i = 0; i < core; ++i) m += chi(g[i], t);
      m /= double(core);
      (m < 1 - s.porosity ? lo : hi) = t;
      achieved = 1 - m;
    }
  }
  const double t = 0.5 * (lo + hi);
  v.labels.assign(n, kCompact);
  v.fraction.assign(n, 1.0f);
  for (std::size_t i = 0; i < core; ++i) {
    const double c = chi(g[i], t);
    v.fraction[i] = static_cast<float>(c);
    v.labels[i] = c > 0 ? kTrabecular : kEmpty;
  }
  const nlohmann::json j = {{"method", "synth: compact layer over a plate-like trabecular core (|smoothed noise| < t)"},
                            {"voxel_mm", s.voxel_mm},
                            {"extent_mm", {s.extent_mm.x, s.extent_mm.y, s.extent_mm.z}},
                            {"compact_mm", s.compact_mm},
                            {"compact_from_z_index", z_compact},
                            {"porosity", s.porosity},
                            {"porosity_achieved", achieved},
                            {"strut_mm", s.strut_mm},
                            {"seed", s.seed}};
  v.segmentation_json = j.dump();
  return v;
}

}  // namespace burrbench::data_schema::import
