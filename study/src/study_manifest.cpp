#include "burrbench/study/study_manifest.hpp"

#include <fmt/format.h>

#include <cctype>
#include <set>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/format_version.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/toml_input.hpp"
#include "burrbench/data_schema/toml_view.hpp"

namespace burrbench::study {
namespace fs = std::filesystem;
namespace ds = data_schema;

std::vector<std::string> FitOptions::calibrate_args() const {
  std::vector<std::string> a{"--starts", std::to_string(starts)};
  if (!profiles) a.push_back("--no-profiles");
  if (!cross_validation) a.push_back("--no-cross-validation");
  if (!discretization_check) a.push_back("--no-discretization-check");
  return a;
}

namespace {

bool valid_id(const std::string& id) {
  if (id.empty() || id.size() > 64 || id == "." || id == "..") return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

}  // namespace

StudyManifest read_study(const fs::path& path) {
  const toml::table t = ds::parse_toml_file(path);
  ds::TomlView root(t, path.string(), {}, "docs/study.md");
  ds::check_format(path.string(), "format", root.str("format"), kStudyFormat);
  ds::check_version(path.string(), "format_version", root.str("format_version"), kStudyVersionMajor);
  StudyManifest s;
  s.file = fs::absolute(path);
  const fs::path base = s.file.parent_path();
  auto resolve = [&](const std::string& p) { return fs::path(p).is_absolute() ? fs::path(p) : base / p; };
  s.name = root.str("name");
  s.description = root.str_or("description", "");
  if (auto c = root.opt_str("criteria")) {
    s.criteria = resolve(*c);
    if (!fs::is_regular_file(*s.criteria)) root.fail("criteria", "an existing criteria file", c->c_str());
  }
  if (auto f = root.opt_table("fit")) {
    s.fit.starts = f->integer_or("starts", 1, 1000, s.fit.starts);
    s.fit.profiles = f->opt_boolean("profiles").value_or(s.fit.profiles);
    s.fit.cross_validation = f->opt_boolean("cross_validation").value_or(s.fit.cross_validation);
    s.fit.discretization_check = f->opt_boolean("discretization_check").value_or(s.fit.discretization_check);
    f->done();
  }
  std::set<std::string> ids;
  for (auto& sp : root.tables("specimen")) {
    Specimen x;
    x.id = sp.str("id");
    if (!valid_id(x.id)) sp.fail("id", "1-64 characters of A-Z a-z 0-9 _ - . (it names a folder)", x.id);
    if (!ids.insert(x.id).second) sp.fail("id", "a unique specimen id", x.id + " (again)");
    const std::string e = sp.str("experiment");
    x.experiment = fs::absolute(resolve(e));
    if (!fs::is_regular_file(x.experiment)) sp.fail("experiment", "an existing experiment manifest", e);
    const auto m = ds::read_manifest(x.experiment);  // validated here, not in a job an hour later
    x.inputs.push_back(x.experiment);
    for (const auto& smp : m.samples) x.inputs.push_back(fs::absolute(smp.path));
    for (const auto& r : m.recordings) x.inputs.push_back(fs::absolute(r.path));
    sp.done();
    s.specimens.push_back(std::move(x));
  }
  if (s.specimens.empty()) root.fail("specimen", "at least one [[specimen]]", "none");
  root.done();
  return s;
}

}  // namespace burrbench::study
