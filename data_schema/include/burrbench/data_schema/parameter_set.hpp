#pragma once
// Model constants per bone class: what a simulator release consumes (TOML,
// format "burrbench.params"). Units: α and C1 in N/mm² (α = mJ/mm³), μ dimensionless.
#include <cstdint>
#include <filesystem>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "burrbench/data_schema/provenance.hpp"

namespace burrbench::data_schema {

inline constexpr const char* kParamsFormat = "burrbench.params";
// Largest constants a parameter set may hold: orders of magnitude above bone (cortical
// bone's elastic modulus ≈ 2·10⁴ N/mm², its specific cutting energy ≈ 10³–10⁴ N/mm²).
inline constexpr double kMaxAlpha_N_per_mm2 = 1e12;  // an implant that never erodes may say 1e9
inline constexpr double kMaxC1_N_per_mm2 = 1e6;
inline constexpr double kMaxMu = 10.0;
inline constexpr int kParamsVersionMajor = 1;
inline constexpr int kParamsVersionMinor = 0;

struct ClassParams {
  std::string name;                                          // "compact", "trabecular"
  double alpha_N_per_mm2 = std::numeric_limits<double>::infinity();  // ∞: no erosion
  double c1_N_per_mm2 = 0;
  double mu = 0;
};

struct ParameterSet {
  std::map<std::uint8_t, ClassParams> classes;  // by class label
  // Per class label, the constants the calibration could not identify ("alpha", "c1", "mu";
  // key `not_identifiable` in the class's table): their value above is the one the fit held
  // at its optimum, not a confident estimate (docs/calibration.md).
  std::map<std::uint8_t, std::vector<std::string>> not_identifiable;
  std::string notes;
  Provenance provenance;  // optional in hand-written files; writers always stamp it
  const ClassParams* by_name(const std::string& name) const;
};

void validate(const ParameterSet& p, const std::string& file_for_messages);
void write_params(const std::filesystem::path& path, const ParameterSet& p);
ParameterSet read_params(const std::filesystem::path& path);  // validates

}  // namespace burrbench::data_schema
