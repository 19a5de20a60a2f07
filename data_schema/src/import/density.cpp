#include "burrbench/data_schema/import/density.hpp"

#include <cmath>
#include <set>

#include <fmt/format.h>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace burrbench::data_schema::import {

DensityPhantom read_density_phantom(const std::filesystem::path& path) {
  const toml::table t = parse_toml_file(path);
  DensityPhantom p;
  p.file = path.string();
  const TomlView root(t, p.file, {}, "docs/importers.md");
  check_format(p.file, "format", root.str("format"), kDensityFormat);
  check_version(p.file, "format_version", root.str("format_version"), 1);
  if (root.has("tissue_density_mg_cm3")) {
    p.tissue_density_mg_cm3 = root.positive("tissue_density_mg_cm3");
    p.tissue_density_given = true;
  }
  p.slope = root.opt_num("slope_mg_cm3_per_grey");
  p.intercept = root.opt_num("intercept_mg_cm3");
  const auto rods = root.tables("rod");
  if (p.slope.has_value() != p.intercept.has_value())
    root.fail(p.slope ? "intercept_mg_cm3" : "slope_mg_cm3_per_grey", "slope_mg_cm3_per_grey and intercept_mg_cm3 together",
              "missing");
  if (p.slope && !rods.empty()) root.fail("rod", "either rods or slope_mg_cm3_per_grey/intercept_mg_cm3, not both");
  if (!p.slope && rods.empty())
    root.fail("rod", "[[rod]] tables (two or more) or slope_mg_cm3_per_grey and intercept_mg_cm3", "neither");
  if (p.slope && !(*p.slope > 0)) root.fail("slope_mg_cm3_per_grey", "a positive slope (denser is brighter)", fmt::format("{}", *p.slope));
  std::set<double> densities;
  for (std::size_t i = 0; i < rods.size(); ++i) {
    const TomlView& r = rods[i];
    DensityRod rod;
    rod.name = r.str_or("name", fmt::format("rod {}", i + 1));
    rod.density_mg_cm3 = r.num("density_mg_cm3");
    rod.center_mm = r.vec3("center_mm");
    rod.radius_mm = r.positive("radius_mm");
    if (r.has("length_mm")) rod.length_mm = r.positive("length_mm");
    r.done();
    densities.insert(rod.density_mg_cm3);
    p.rods.push_back(rod);
  }
  if (!rods.empty() && densities.size() < 2)
    root.fail("rod", "rods of at least two different densities", fmt::format("{} distinct", densities.size()));
  root.done();
  return p;
}

DensityCalibration calibrate_density(const DensityPhantom& p, const ImageVolume& ct, const std::string& ct_file) {
  DensityCalibration c;
  c.tissue_density_mg_cm3 = p.tissue_density_mg_cm3;
  nlohmann::json rec = {{"file", p.file},
                        {"unit", "mg HA/cm3"},
                        {"tissue_density_mg_cm3", p.tissue_density_mg_cm3},
                        {"tissue_density_source", p.tissue_density_given ? "given" : "default"},
                        {"tissue_density_reference", kTissueDensityReference},
                        {"chi", "clamp(density / tissue_density, 0, 1)"}};
  if (p.slope) {
    c.slope = *p.slope;
    c.intercept = *p.intercept;
    rec["source"] = "given slope and intercept";
  } else {
    // Mean grey inside each rod, then least squares density = slope·grey + intercept.
    nlohmann::json rods = nlohmann::json::array();
    std::vector<double> g, rho;
    for (std::size_t k = 0; k < p.rods.size(); ++k) {
      const DensityRod& r = p.rods[k];
      const std::string field = fmt::format("rod[{}] ({})", k, r.name);
      double sum = 0;
      std::size_t n = 0;
      for (std::size_t z = 0; z < ct.dims[2]; ++z) {
        const double wz = ct.origin_mm.z + double(z) * ct.spacing_mm.z;
        if (r.length_mm && std::abs(wz - r.center_mm.z) > *r.length_mm / 2) continue;
        for (std::size_t y = 0; y < ct.dims[1]; ++y) {
          const double dy = ct.origin_mm.y + double(y) * ct.spacing_mm.y - r.center_mm.y;
          if (std::abs(dy) > r.radius_mm) continue;
          for (std::size_t x = 0; x < ct.dims[0]; ++x) {
            const double dx = ct.origin_mm.x + double(x) * ct.spacing_mm.x - r.center_mm.x;
            if (dx * dx + dy * dy > r.radius_mm * r.radius_mm) continue;
            sum += ct.values[ct.index(x, y, z)];
            ++n;
          }
        }
      }
      if (n < 8)
        throw InputError(p.file, field,
                         fmt::format("a region holding at least 8 voxel centres of {} (the CT spans ({:.4g},{:.4g},{:.4g})..({:.4g},{:.4g},{:.4g}) mm)",
                                     ct_file, ct.origin_mm.x, ct.origin_mm.y, ct.origin_mm.z,
                                     ct.origin_mm.x + double(ct.dims[0] - 1) * ct.spacing_mm.x,
                                     ct.origin_mm.y + double(ct.dims[1] - 1) * ct.spacing_mm.y,
                                     ct.origin_mm.z + double(ct.dims[2] - 1) * ct.spacing_mm.z),
                         fmt::format("{} voxels", n));
      g.push_back(sum / double(n));
      rho.push_back(r.density_mg_cm3);
      rods.push_back({{"name", r.name}, {"density_mg_cm3", r.density_mg_cm3}, {"mean_grey", g.back()}, {"voxels", n}});
    }
    const double m = double(g.size());
    double gm = 0, rm = 0;
    for (std::size_t i = 0; i < g.size(); ++i) { gm += g[i] / m; rm += rho[i] / m; }
    double sgg = 0, sgr = 0, srr = 0;
    for (std::size_t i = 0; i < g.size(); ++i) {
      sgg += (g[i] - gm) * (g[i] - gm);
      sgr += (g[i] - gm) * (rho[i] - rm);
      srr += (rho[i] - rm) * (rho[i] - rm);
    }
    if (!(sgg > 0)) throw InputError(p.file, "rod", "rods of different mean grey values in " + ct_file, "the same grey in every rod");
    c.slope = sgr / sgg;
    c.intercept = rm - c.slope * gm;
    if (!(c.slope > 0))
      throw InputError(p.file, "rod", "mean greys that rise with density (check the rods' centres and densities)",
                       fmt::format("a slope of {:.6g} mg HA/cm3 per grey", c.slope));
    double ss_res = 0;
    for (std::size_t i = 0; i < g.size(); ++i) {
      const double res = rho[i] - c.density(g[i]);
      rods[i]["fitted_mg_cm3"] = c.density(g[i]);
      rods[i]["residual_mg_cm3"] = res;
      ss_res += res * res;
    }
    rec["source"] = "least squares over the rods";
    rec["rods"] = rods;
    rec["r_squared"] = srr > 0 ? 1 - ss_res / srr : 1.0;
  }
  rec["slope_mg_cm3_per_grey"] = c.slope;
  rec["intercept_mg_cm3"] = c.intercept;
  rec["grey_at_0_mg_cm3"] = c.empty_grey();
  rec["grey_at_tissue_density"] = c.bone_grey();
  c.record = rec;
  return c;
}

}  // namespace burrbench::data_schema::import
