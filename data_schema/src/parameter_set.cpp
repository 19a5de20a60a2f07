// Parameter set (TOML, format "burrbench.params"): per class id, α, C1, μ.
#include "burrbench/data_schema/parameter_set.hpp"

#include <cmath>
#include <fstream>
#include <set>

#include <fmt/format.h>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "format_common.hpp"
#include "toml_util.hpp"

namespace burrbench::data_schema {

const ClassParams* ParameterSet::by_name(const std::string& name) const {
  for (const auto& [id, c] : classes)
    if (c.name == name) return &c;
  return nullptr;
}

void validate(const ParameterSet& p, const std::string& file) {
  std::set<std::string> names;
  for (const auto& [id, c] : p.classes) {
    const std::string f = "classes." + (c.name.empty() ? std::to_string(id) : c.name);
    if (id == 0) throw InputError(file, f + ".id", "a class id 1..255 (0 is empty space)", "0");
    if (c.name.empty()) throw InputError(file, f, "a class name");
    if (!names.insert(c.name).second) throw InputError(file, f, "unique class names", "duplicate");
    // Physical ranges (docs/formats.md): far wider than bone, narrow enough that a typo
    // (c1 = 1e200) is refused here instead of turning into NaN forces in a replay.
    const double a = c.alpha_N_per_mm2;
    if (std::isnan(a) || !(a > 0) || (std::isfinite(a) && a > kMaxAlpha_N_per_mm2))
      throw InputError(file, f + ".alpha_N_per_mm2",
                       fmt::format("alpha > 0 N/mm², at most {:g} (inf = no erosion)", kMaxAlpha_N_per_mm2),
                       fmt::format("{}", a));
    if (!std::isfinite(c.c1_N_per_mm2) || !(c.c1_N_per_mm2 > 0) || c.c1_N_per_mm2 > kMaxC1_N_per_mm2)
      throw InputError(file, f + ".c1_N_per_mm2", fmt::format("a finite C1 > 0 N/mm², at most {:g}", kMaxC1_N_per_mm2),
                       fmt::format("{}", c.c1_N_per_mm2));
    if (!std::isfinite(c.mu) || c.mu < 0 || c.mu > kMaxMu)
      throw InputError(file, f + ".mu", fmt::format("a finite mu >= 0, at most {:g}", kMaxMu), fmt::format("{}", c.mu));
  }
}

void write_params(const std::filesystem::path& path, const ParameterSet& p) {
  validate(p, path.string());
  toml::table classes;
  for (const auto& [id, c] : p.classes) {
    toml::table ct{{"id", int64_t{id}},
                   {"alpha_N_per_mm2", c.alpha_N_per_mm2},
                   {"c1_N_per_mm2", c.c1_N_per_mm2},
                   {"mu", c.mu}};
    if (auto it = p.not_identifiable.find(id); it != p.not_identifiable.end() && !it->second.empty()) {
      toml::array names;
      for (const auto& n : it->second) names.push_back(n);
      ct.insert("not_identifiable", names);
    }
    classes.insert(c.name, ct);
  }
  const toml::table root{{"format", kParamsFormat},
                         {"format_version", version_string(kParamsVersionMajor, kParamsVersionMinor)},
                         {"notes", p.notes},
                         {"classes", classes},
                         {"provenance", detail::provenance_to_toml(detail::stamped(p.provenance))}};
  std::ostringstream text;
  text << "# burrbench parameter set: model constants per bone class (docs/formats.md).\n"
          "# Units: alpha_N_per_mm2 and c1_N_per_mm2 in N/mm^2 (alpha = mJ/mm^3, energy to\n"
          "# remove 1 mm^3 of full-density bone; inf = no erosion); mu dimensionless.\n"
       << root << "\n";
  write_file_atomic(path, text.str());
}

ParameterSet read_params(const std::filesystem::path& path) {
  const ReadingFile reading(path.string());  // names it if memory runs out
  const std::string file = path.string();
  const toml::table t = parse_toml_file(path);
  TomlView root(t, file, "");
  check_format(file, "format", root.str("format"), kParamsFormat);
  check_version(file, "format_version", root.str("format_version"), kParamsVersionMajor);
  ParameterSet p;
  p.notes = root.opt_str("notes").value_or("");
  auto classes = root.table("classes");
  for (const auto& name : classes.keys()) {
    auto c = classes.table(name);
    const std::int64_t id = c.integer("id");
    if (id < 1 || id > kMaxClassId)
      throw InputError(file, c.field("id"), fmt::format("a class id 1..{}", kMaxClassId), std::to_string(id));
    ClassParams cp;
    cp.name = name;
    cp.alpha_N_per_mm2 = c.num_or_inf("alpha_N_per_mm2");
    cp.c1_N_per_mm2 = c.num("c1_N_per_mm2");
    cp.mu = c.num("mu");
    std::vector<std::string> flagged;
    if (c.has("not_identifiable")) flagged = c.strings("not_identifiable");
    for (const auto& n : flagged)
      if (n != "alpha" && n != "c1" && n != "mu")
        throw InputError(file, c.field("not_identifiable"), "names among alpha, c1, mu", n);
    c.done();
    if (!flagged.empty()) p.not_identifiable[std::uint8_t(id)] = flagged;
    if (!p.classes.emplace(std::uint8_t(id), cp).second)
      throw InputError(file, c.field("id"), "unique class ids", std::to_string(id) + " twice");
  }
  classes.done();
  if (auto prov = root.opt_table("provenance")) p.provenance = detail::provenance_from_toml(*prov);
  root.done();
  validate(p, file);
  return p;
}

}  // namespace burrbench::data_schema
