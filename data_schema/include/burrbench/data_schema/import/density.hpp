#pragma once
// Grey value → bone mineral density (mg HA/cm³) → bone fraction χ, from a calibration
// phantom scanned with the sample (docs/importers.md, "Density calibration").
//
//   ρ = slope · grey + intercept           (mg HA/cm³; from the rods' mean greys by least
//                                           squares, or a scanner QC sheet's slope/intercept)
//   χ = clamp(ρ / ρ_tissue, 0, 1)           ρ_tissue: the mineral density of fully dense
//                                           bone tissue, default 1200 mg HA/cm³
//
// So χ = 0 at the grey of 0 mg HA/cm³ and 1 at the grey of ρ_tissue: the segmentation's
// empty_grey and bone_grey.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/import/volume.hpp"

namespace burrbench::data_schema::import {

inline constexpr const char* kDensityFormat = "burrbench.density";
// Tissue mineral density of fully dense bone: Tassani et al. 2011 measured ash density
// per bone volume (BV/TV from micro-CT) of 1.19 ± 0.06 g/cm³ in cortical and 1.24 ± 0.16
// g/cm³ in trabecular human bone, not different (p = 0.31); ash is the mineral, taken here
// as hydroxyapatite-equivalent.
inline constexpr double kDefaultTissueDensity_mg_cm3 = 1200.0;
inline constexpr const char* kTissueDensityReference =
    "Tassani S, Öhman C, Baruffaldi F, Baleani M, Viceconti M. Volume to density relation in adult human bone "
    "tissue. J Biomech 44(1):103-108, 2011 (tissue mineral density 1.19 g/cm3 cortical, 1.24 g/cm3 trabecular)";

// A rod of the phantom: a cylinder along z (the scan axis) in the CT's frame (mm, the
// frame the CT imports into: origin = centre of the first voxel).
struct DensityRod {
  std::string name;
  double density_mg_cm3 = 0;
  glm::dvec3 center_mm{0, 0, 0};
  double radius_mm = 0;
  std::optional<double> length_mm;  // absent: every slice
};

struct DensityPhantom {
  std::string file;
  std::optional<double> slope, intercept;  // given (QC sheet), or
  std::vector<DensityRod> rods;            // measured on the CT
  double tissue_density_mg_cm3 = kDefaultTissueDensity_mg_cm3;
  bool tissue_density_given = false;
};

// Format burrbench.density 1.0; unknown keys, fewer than two rods of different densities,
// both rods and a slope, or a slope ≤ 0 are InputError naming the file and key.
DensityPhantom read_density_phantom(const std::filesystem::path& toml);

struct DensityCalibration {
  double slope = 1;      // mg HA/cm³ per grey value (> 0)
  double intercept = 0;  // mg HA/cm³ at grey 0
  double tissue_density_mg_cm3 = kDefaultTissueDensity_mg_cm3;
  nlohmann::json record;  // source, per-rod mean grey / voxels / residual, R², tissue density + reference
  double density(double grey) const { return slope * grey + intercept; }
  double grey(double density_mg_cm3) const { return (density_mg_cm3 - intercept) / slope; }
  double empty_grey() const { return grey(0); }                      // χ = 0
  double bone_grey() const { return grey(tissue_density_mg_cm3); }  // χ = 1
};

// Given slope/intercept are taken; rods are measured on `ct` (mean grey of the voxels whose
// centres lie inside each cylinder, at least 8 per rod) and fitted by least squares.
DensityCalibration calibrate_density(const DensityPhantom& p, const ImageVolume& ct,
                                     const std::string& ct_file);

}  // namespace burrbench::data_schema::import
