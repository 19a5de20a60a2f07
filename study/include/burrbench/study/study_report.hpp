#pragma once
// What `burrbench study summarize` writes: the population estimates as JSON
// (format "burrbench.population"), a population params.toml for a simulator release, and
// a self-contained HTML study report (forest plots per constant, the specimens' table with
// their gate results and links to each specimen's own report).
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/study/population.hpp"
#include "burrbench/study/study_manifest.hpp"

namespace burrbench::study {

inline constexpr const char* kPopulationFormat = "burrbench.population";

struct SpecimenRow {
  std::string id;
  std::string experiment;     // path of its experiment manifest
  std::string gate;           // "PASS" | "FAIL" | "" (not validated)
  std::string fit_link, report_link;  // relative to the study report ("" when absent)
};

nlohmann::json population_json(const StudyManifest& study, const std::vector<PopulationEstimate>& pop,
                               const std::vector<SpecimenRow>& specimens);

// The population constants as a parameter set: per class the pooled geometric means; a
// constant with fewer than two usable specimens keeps the first fit's held value and is
// listed under not_identifiable. Class labels and names from the first fit.
data_schema::ParameterSet population_params(const std::vector<PopulationEstimate>& pop,
                                            const data_schema::FitResult& first_fit);

std::string study_report_html(const StudyManifest& study, const std::vector<PopulationEstimate>& pop,
                              const std::vector<SpecimenRow>& specimens);

}  // namespace burrbench::study
