#include "burrbench/study/population.hpp"

#include <cmath>
#include <map>

namespace burrbench::study {
namespace ds = data_schema;

double t975(int dof) {
  // Exact to 4 digits for 1..30 (tables), then the Cornish–Fisher expansion about z.
  static const double table[] = {12.7062, 4.3027, 3.1824, 2.7764, 2.5706, 2.4469, 2.3646, 2.3060, 2.2622, 2.2281,
                                 2.2010,  2.1788, 2.1604, 2.1448, 2.1314, 2.1199, 2.1098, 2.1009, 2.0930, 2.0860,
                                 2.0796,  2.0739, 2.0687, 2.0639, 2.0595, 2.0555, 2.0518, 2.0484, 2.0452, 2.0423};
  if (dof < 1) return NAN;
  if (dof <= 30) return table[dof - 1];
  const double z = 1.959963984540054, n = dof;
  return z + (z * z * z + z) / (4 * n) + (5 * std::pow(z, 5) + 16 * z * z * z + 3 * z) / (96 * n * n);
}

Extracted extract(const std::vector<std::pair<std::string, ds::FitResult>>& fits, const std::string& class_name,
                  const std::string& parameter) {
  Extracted out;
  for (const auto& [specimen, fit] : fits) {
    const ds::FitParameter* p = nullptr;
    for (const auto& q : fit.parameters)
      if (q.class_name == class_name && q.name == parameter) p = &q;
    if (!p) {
      out.excluded.push_back({specimen, "not in this fit"});
      continue;
    }
    if (p->fixed) {
      out.excluded.push_back({specimen, "held fixed"});
      continue;
    }
    // The profile's verdict where there is one ("imprecise" is identifiable, only wide).
    const bool bad_verdict = p->verdict == "practically_non_identifiable" || p->verdict == "non_identifiable" ||
                             p->verdict == "at_bound" || p->verdict == "conditional_on_bound" ||
                             p->verdict == "unconfirmed";
    if (!p->identifiable || bad_verdict) {
      out.excluded.push_back({specimen, "not identifiable (" + (p->verdict.empty() ? std::string("covariance") : p->verdict) +
                                            (p->reason.empty() ? std::string(")") : "): " + p->reason)});
      continue;
    }
    SpecimenEstimate e;
    e.specimen = specimen;
    e.estimate = p->estimate;
    if (!(p->estimate > 0) || !std::isfinite(p->estimate)) {
      out.excluded.push_back({specimen, "no positive estimate"});
      continue;
    }
    e.ln_estimate = std::log(p->estimate);
    if (p->profile_ci95_low > 0 && std::isfinite(p->profile_ci95_high) && p->profile_ci95_high > p->profile_ci95_low) {
      // The profile interval is the fit's best statement; its log width gives the SE.
      e.ln_se = (std::log(p->profile_ci95_high) - std::log(p->profile_ci95_low)) / (2 * 1.959963984540054);
      e.ci95_low = p->profile_ci95_low;
      e.ci95_high = p->profile_ci95_high;
      e.se_source = "profile";
    } else if (p->std_error > 0 && std::isfinite(p->std_error)) {
      e.ln_se = p->std_error / p->estimate;  // delta method
      e.ci95_low = p->ci95_low;
      e.ci95_high = p->ci95_high;
      e.se_source = "covariance";
    } else {
      out.excluded.push_back({specimen, "no finite interval"});
      continue;
    }
    out.used.push_back(e);
  }
  return out;
}

PopulationEstimate pool(const Extracted& e, const std::string& class_name, const std::string& parameter,
                        const std::string& unit) {
  PopulationEstimate p;
  p.class_name = class_name;
  p.parameter = parameter;
  p.unit = unit;
  p.used = e.used;
  p.excluded = e.excluded;
  p.k = e.used.size();
  if (p.k == 0) {
    p.mean = p.ci95_low = p.ci95_high = NAN;
    return p;
  }
  if (p.k == 1) {  // nothing to pool: the one estimate, no population interval
    p.ln_mean = e.used[0].ln_estimate;
    p.mean = std::exp(p.ln_mean);
    p.ln_se = p.tau_ln = p.ci95_low = p.ci95_high = NAN;
    return p;
  }
  // Fixed-effect weights, Cochran's Q, the DL moment estimate of τ².
  double sw = 0, sw2 = 0, swy = 0;
  for (const auto& s : e.used) {
    const double w = 1 / (s.ln_se * s.ln_se);
    sw += w;
    sw2 += w * w;
    swy += w * s.ln_estimate;
  }
  const double fixed_mean = swy / sw;
  double q = 0;
  for (const auto& s : e.used) q += (s.ln_estimate - fixed_mean) * (s.ln_estimate - fixed_mean) / (s.ln_se * s.ln_se);
  const double df = double(p.k - 1);
  const double tau2 = std::max(0.0, (q - df) / (sw - sw2 / sw));
  // Random-effects mean, and the HKSJ variance: the weighted residual scatter about it.
  double rw = 0, rwy = 0;
  for (const auto& s : e.used) {
    const double w = 1 / (s.ln_se * s.ln_se + tau2);
    rw += w;
    rwy += w * s.ln_estimate;
  }
  p.ln_mean = rwy / rw;
  double scatter = 0;
  for (const auto& s : e.used) {
    const double w = 1 / (s.ln_se * s.ln_se + tau2);
    scatter += w * (s.ln_estimate - p.ln_mean) * (s.ln_estimate - p.ln_mean);
  }
  // HKSJ; never narrower than the DL standard error (the "modified" HKSJ, which keeps
  // the interval honest when the estimates happen to agree closely).
  p.ln_se = std::sqrt(std::max(scatter / (df * rw), 1 / rw));
  const double t = t975(int(p.k - 1));
  p.mean = std::exp(p.ln_mean);
  p.ci95_low = std::exp(p.ln_mean - t * p.ln_se);
  p.ci95_high = std::exp(p.ln_mean + t * p.ln_se);
  p.tau_ln = std::sqrt(tau2);
  p.q = q;
  p.i2 = q > 0 ? std::max(0.0, (q - df) / q) : 0.0;
  return p;
}

std::vector<PopulationEstimate> summarize(const std::vector<std::pair<std::string, ds::FitResult>>& fits) {
  std::vector<PopulationEstimate> out;
  if (fits.empty()) return out;
  for (const auto& p : fits.front().second.parameters)
    out.push_back(pool(extract(fits, p.class_name, p.name), p.class_name, p.name, p.unit));
  return out;
}

}  // namespace burrbench::study
