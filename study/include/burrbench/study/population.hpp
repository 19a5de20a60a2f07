#pragma once
// Population constants across specimens: a random-effects meta-analysis of the
// per-specimen estimates, in log space for the positive constants (docs/study.md).
//
// Method: DerSimonian–Laird for the between-specimen variance τ² (closed form, no
// iteration to fail on 3 specimens), with the Hartung–Knapp–Sidik–Jonkman interval for
// the mean (t with k − 1 degrees of freedom on a variance rescaled by the observed
// heterogeneity): with few specimens the plain DL interval, on a normal quantile, is
// known to cover far less than 95 %.
#include <string>
#include <utility>
#include <vector>

#include "burrbench/data_schema/fit_result.hpp"

namespace burrbench::study {

// One specimen's estimate of one constant, in ln units.
struct SpecimenEstimate {
  std::string specimen;
  double estimate = 0;          // natural units
  double ln_estimate = 0;
  double ln_se = 0;             // from the profile interval, else the covariance (delta method)
  double ci95_low = 0, ci95_high = 0;  // natural units, as the fit reported
  std::string se_source;        // "profile" | "covariance"
};

struct PopulationEstimate {
  std::string class_name, parameter, unit;
  std::size_t k = 0;             // specimens used
  double ln_mean = 0, ln_se = 0;  // pooled mean of ln θ and its HKSJ standard error
  double mean = 0, ci95_low = 0, ci95_high = 0;  // exp(): the population's geometric mean
  double tau_ln = 0;             // between-specimen SD of ln θ (DL)
  double q = 0, i2 = 0;          // Cochran's Q and I² = max(0, (Q − (k−1))/Q)
  std::vector<SpecimenEstimate> used;
  std::vector<std::pair<std::string, std::string>> excluded;  // specimen, reason
  bool estimable() const { return k >= 2; }
};

// The estimate of the constant from each fit, or the reason it is excluded: fixed,
// not identifiable (or profile-"not identifiable"), or without a finite interval.
struct Extracted {
  std::vector<SpecimenEstimate> used;
  std::vector<std::pair<std::string, std::string>> excluded;
};
Extracted extract(const std::vector<std::pair<std::string, data_schema::FitResult>>& fits,
                  const std::string& class_name, const std::string& parameter);

// The random-effects pool of k ≥ 2 estimates (k < 2: estimable() false, mean = the one).
PopulationEstimate pool(const Extracted& e, const std::string& class_name, const std::string& parameter,
                        const std::string& unit);

// Every (class, constant) the fits share, in the first fit's order.
std::vector<PopulationEstimate> summarize(const std::vector<std::pair<std::string, data_schema::FitResult>>& fits);

// Two-sided 97.5 % quantile of Student's t with `dof` degrees of freedom (dof ≥ 1).
double t975(int dof);

}  // namespace burrbench::study
