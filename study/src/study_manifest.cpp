#include "burrbench/study/study_manifest.hpp"

#include <fmt/format.h>

#include <cctype>
#include <fstream>
#include <functional>
#include <iterator>
#include <set>
#include <sstream>

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

constexpr const char* kDocs = "docs/study.md";

bool valid_id(const std::string& id) {
  if (id.empty() || id.size() > 64 || id == "." || id == "..") return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

std::string number(double v) { return fmt::format("{}", v); }

// The import command's option for a study key: threshold_mg_cm3 → --threshold-mg-cm3.
std::string flag(std::string key) {
  for (char& c : key)
    if (c == '_') c = '-';
  return "--" + key;
}

// The experiment's samples and recordings as its TOML names them (ids, paths relative
// to it), read without their files: those the study imports do not exist yet.
struct ExperimentFiles {
  struct Entry {
    std::string id, path, sample, field;  // field: "samples[0].path"
  };
  std::vector<Entry> samples, recordings;
  const Entry* find(const std::vector<Entry>& v, const std::string& id) const {
    for (const auto& e : v)
      if (e.id == id) return &e;
    return nullptr;
  }
};

ExperimentFiles experiment_files(const fs::path& file, const toml::table& t) {
  ds::TomlView root(t, file.string());
  ds::check_format(file.string(), "format", root.str("format"), ds::kManifestFormat);
  ds::check_version(file.string(), "format_version", root.str("format_version"), ds::kManifestVersionMajor);
  ExperimentFiles f;
  for (auto& s : root.tables("samples")) f.samples.push_back({s.str("id"), s.str("path"), {}, s.field("path")});
  for (auto& r : root.tables("recordings"))
    f.recordings.push_back({r.str("id"), r.str("path"), r.str("sample"), r.field("path")});
  return f;
}

std::string id_list(const std::vector<ExperimentFiles::Entry>& v) {
  std::string s;
  for (const auto& e : v) s += (s.empty() ? "" : ", ") + e.id;
  return s.empty() ? "none" : s;
}

// [specimen.sample]: `burrbench sample import`'s options as keys (docs/study.md).
Import sample_import(const ds::TomlView& v, const ExperimentFiles& ef, const fs::path& experiment,
                     const std::function<fs::path(const std::string&)>& resolve) {
  Import imp;
  imp.kind = Import::Kind::kSample;
  if (auto id = v.opt_str("id")) {
    imp.id = *id;
  } else {
    if (ef.samples.size() != 1)
      v.fail("id", fmt::format("the id of the experiment's sample to import ({} has {} samples: {})", experiment.string(),
                               ef.samples.size(), id_list(ef.samples)),
             "missing");
    imp.id = ef.samples.front().id;
  }
  if (!ef.find(ef.samples, imp.id))
    v.fail("id", fmt::format("a sample id of {} ({})", experiment.string(), id_list(ef.samples)), imp.id);
  if (!valid_id(imp.id)) v.fail("id", "a sample id of 1-64 characters of A-Z a-z 0-9 _ - . (it names the imported file)", imp.id);
  auto file = [&](const char* key) {
    const std::string p = v.str(key);
    const fs::path a = fs::absolute(resolve(p)).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(a, ec)) v.fail(key, "an existing file", p);
    imp.inputs.push_back(a);
    return a.string();
  };
  const bool labels = v.has("labels"), ct = v.has("ct");
  if (labels == ct)
    v.fail(ct ? "labels" : "ct", "exactly one of ct (a grey CT to segment) or labels (+ fraction)", ct ? "both" : "neither");
  if (labels) {
    imp.args.insert(imp.args.end(), {"--labels", file("labels")});
    if (v.has("fraction")) imp.args.insert(imp.args.end(), {"--fraction", file("fraction")});
  } else {
    // A file, a folder (slices, DICOM, SkyScan), or several DICOM files.
    const toml::node* n = v.node("ct");
    std::vector<std::string> paths;
    if (auto s = n->value<std::string>()) {
      paths.push_back(*s);
    } else if (const toml::array* a = n->as_array(); a && !a->empty()) {
      for (const auto& e : *a) {
        auto s = e.value<std::string>();
        if (!s) v.fail("ct", "a path or an array of paths (strings)", "an array holding a non-string");
        paths.push_back(*s);
      }
    } else {
      v.fail("ct", "a path (a file or a folder) or a non-empty array of paths (DICOM files)");
    }
    imp.args.push_back("--ct");
    for (const auto& p : paths) {
      const fs::path a = fs::absolute(resolve(p)).lexically_normal();
      std::error_code ec;
      if (!fs::exists(a, ec)) v.fail("ct", "an existing file or folder", p);
      imp.inputs.push_back(a);
      imp.args.push_back(a.string());
    }
    if (v.has("fraction")) v.fail("fraction", "labels with it (a CT gives its own fraction)");
    if (auto s = v.opt_str("dicom_series")) imp.args.insert(imp.args.end(), {"--dicom-series", *s});
    if (v.has("density")) imp.args.insert(imp.args.end(), {"--density", file("density")});
    if (auto t = v.opt_num("threshold_mg_cm3")) {
      if (!v.has("density")) v.fail("threshold_mg_cm3", "density (a phantom calibration) with it");
      imp.args.insert(imp.args.end(), {"--threshold-mg-cm3", number(*t)});
    }
    if (v.has("threshold_mg_cm3") && v.has("threshold"))
      v.fail("threshold", "either threshold or threshold_mg_cm3, not both");
    if (v.has("density"))
      for (const char* k : {"empty_grey", "bone_grey"})
        if (v.has(k)) v.fail(k, "no grey calibration with density (the phantom gives χ = 0 and 1)");
    for (const char* k : {"threshold", "empty_grey", "bone_grey"})
      if (auto x = v.opt_num(k)) imp.args.insert(imp.args.end(), {flag(k), number(*x)});
    if (v.has("bvtv_radius_mm")) imp.args.insert(imp.args.end(), {flag("bvtv_radius_mm"), number(v.positive("bvtv_radius_mm"))});
    for (const char* k : {"envelope_radius_mm", "compact_open_mm"})
      if (v.has(k)) imp.args.insert(imp.args.end(), {flag(k), number(v.non_negative(k))});
    if (auto b = v.opt_num("compact_bvtv")) {
      if (!(*b > 0 && *b <= 1)) v.fail("compact_bvtv", "a bone volume fraction in (0, 1]", number(*b));
      imp.args.insert(imp.args.end(), {"--compact-bvtv", number(*b)});
    }
    for (const char* k : {"bone_open", "bone_close", "compact_close"})
      if (v.has(k)) imp.args.insert(imp.args.end(), {flag(k), std::to_string(v.integer(k, 0, 50))});
  }
  if (labels)
    for (const char* k : {"dicom_series", "density", "threshold_mg_cm3", "threshold", "empty_grey", "bone_grey",
                          "bvtv_radius_mm", "envelope_radius_mm", "compact_open_mm", "compact_bvtv", "bone_open",
                          "bone_close", "compact_close"})
      if (v.has(k)) v.fail(k, "ct with it (it sets the import of a grey CT, not of labels)");
  if (v.has("spacing_mm")) {
    const auto s = v.numbers("spacing_mm", 3);
    for (double x : s)
      if (!(x > 0)) v.fail("spacing_mm", "three positive voxel spacings [sx, sy, sz] in mm", number(x));
    imp.args.insert(imp.args.end(), {"--spacing-mm", fmt::format("{},{},{}", s[0], s[1], s[2])});
  }
  if (v.opt_boolean("resample").value_or(false)) imp.args.push_back("--resample");
  if (v.has("voxel_mm")) imp.args.insert(imp.args.end(), {"--voxel-mm", number(v.positive("voxel_mm"))});
  if (auto e = v.opt_str("fraction_encoding")) {
    if (*e != "float32" && *e != "counter8") v.fail("fraction_encoding", "float32 or counter8", *e);
    imp.args.insert(imp.args.end(), {"--fraction-encoding", *e});
  }
  if (v.has("budget_mb")) imp.args.insert(imp.args.end(), {"--budget-mb", number(v.positive("budget_mb"))});
  v.done();
  return imp;
}

// [[specimen.recording]]: a CSV export and its column map (`burrbench recording import`).
Import recording_import(const ds::TomlView& v, const ExperimentFiles& ef, const fs::path& experiment,
                        const std::function<fs::path(const std::string&)>& resolve) {
  Import imp;
  imp.kind = Import::Kind::kRecording;
  imp.id = v.str("id");
  const auto* rec = ef.find(ef.recordings, imp.id);
  if (!rec) v.fail("id", fmt::format("a recording id of {} ({})", experiment.string(), id_list(ef.recordings)), imp.id);
  if (!valid_id(imp.id))
    v.fail("id", "a recording id of 1-64 characters of A-Z a-z 0-9 _ - . (it names the imported file)", imp.id);
  auto file = [&](const char* key) {
    const std::string p = v.str(key);
    const fs::path a = fs::absolute(resolve(p)).lexically_normal();
    std::error_code ec;
    if (!fs::is_regular_file(a, ec)) v.fail(key, "an existing file", p);
    imp.inputs.push_back(a);
    return a;
  };
  imp.args = {"--csv", file("raw_csv").string()};
  if (v.has("column_map")) {
    const fs::path map = file("column_map");
    // Its format now, its columns against the CSV's header in the import job.
    const toml::table mt = ds::parse_toml_file(map);
    ds::check_format(map.string(), "format", mt["format"].value_or(std::string("(missing)")), "burrbench.csv_map");
    imp.args.insert(imp.args.end(), {"--map", map.string()});
  }
  imp.args.insert(imp.args.end(), {"--sample-id", rec->sample});
  v.done();
  return imp;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

}  // namespace

fs::path imported_file(const fs::path& import_dir, const Import& imp) {
  return import_dir / imp.folder() / (imp.id + ".h5");
}

std::string resolved_experiment(const Specimen& sp, const fs::path& import_dir) {
  toml::table t = ds::parse_toml_text(sp.experiment_text, sp.experiment.string());
  const fs::path base = sp.experiment.parent_path();
  auto rewrite = [&](const char* key, Import::Kind kind) {
    toml::array* a = t[key].as_array();
    if (!a) return;
    for (auto& e : *a) {
      toml::table* x = e.as_table();
      if (!x) continue;
      const std::string id = (*x)["id"].value_or(std::string());
      fs::path p = fs::absolute(base / (*x)["path"].value_or(std::string())).lexically_normal();
      for (const auto& imp : sp.imports)
        if (imp.kind == kind && imp.id == id) p = imported_file(import_dir, imp);
      x->insert_or_assign("path", p.string());
    }
  };
  rewrite("samples", Import::Kind::kSample);
  rewrite("recordings", Import::Kind::kRecording);
  std::ostringstream text;
  text << "# " << sp.experiment.string() << " as `burrbench study run` calibrates specimen " << sp.id
       << ": the imported\n# samples and recordings under " << import_dir.string()
       << ", every path absolute (written by study run; edit the original).\n"
       << t << "\n";
  return text.str();
}

StudyManifest read_study(const fs::path& path) {
  const toml::table t = ds::parse_toml_file(path);
  ds::TomlView root(t, path.string(), {}, kDocs);
  ds::check_format(path.string(), "format", root.str("format"), kStudyFormat);
  ds::check_version(path.string(), "format_version", root.str("format_version"), kStudyVersionMajor);
  StudyManifest s;
  s.file = fs::absolute(path);
  const fs::path base = s.file.parent_path();
  const std::function<fs::path(const std::string&)> resolve = [&](const std::string& p) {
    return fs::path(p).is_absolute() ? fs::path(p) : base / p;
  };
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
    x.inputs.push_back(x.experiment);
    std::vector<ds::TomlView> samples, recordings = sp.tables("recording");
    if (const toml::node* n = sp.node("sample")) {
      if (const toml::table* tb = n->as_table())
        samples.emplace_back(*tb, sp.file(), sp.field("sample"), kDocs);
      else if (n->is_array_of_tables())
        samples = sp.tables("sample");
      else
        sp.fail("sample", "a table [specimen.sample] (or tables [[specimen.sample]], one per imported sample)");
    }
    if (samples.empty() && recordings.empty()) {
      const auto m = ds::read_manifest(x.experiment);  // validated here, not in a job an hour later
      for (const auto& smp : m.samples) x.inputs.push_back(fs::absolute(smp.path));
      for (const auto& r : m.recordings) x.inputs.push_back(fs::absolute(r.path));
    } else {
      // Its files are made by the imports: read what can be checked without them.
      const toml::table et = ds::parse_toml_file(x.experiment);
      x.experiment_text = slurp(x.experiment);
      const ExperimentFiles ef = experiment_files(x.experiment, et);
      std::set<std::string> seen_s, seen_r;
      for (const auto& v : samples) {
        x.imports.push_back(sample_import(v, ef, x.experiment, resolve));
        if (!seen_s.insert(x.imports.back().id).second)
          v.fail("id", "each of the experiment's samples imported once", x.imports.back().id + " (again)");
      }
      for (const auto& v : recordings) {
        x.imports.push_back(recording_import(v, ef, x.experiment, resolve));
        if (!seen_r.insert(x.imports.back().id).second)
          v.fail("id", "each of the experiment's recordings imported once", x.imports.back().id + " (again)");
      }
      const fs::path ebase = x.experiment.parent_path();
      auto given = [&](const std::vector<ExperimentFiles::Entry>& v, const std::set<std::string>& imported,
                       const char* table) {
        for (const auto& en : v) {
          if (imported.count(en.id)) continue;
          const fs::path p = fs::absolute(ebase / en.path).lexically_normal();
          std::error_code ec;
          if (!fs::is_regular_file(p, ec))
            throw InputError(x.experiment.string(), en.field,
                             fmt::format("an existing file (or its import in the study's {})", table),
                             "\"" + p.string() + "\" not found");
          x.inputs.push_back(p);
        }
      };
      given(ef.samples, seen_s, "[specimen.sample]");
      given(ef.recordings, seen_r, "[[specimen.recording]]");
    }
    sp.done();
    s.specimens.push_back(std::move(x));
  }
  if (s.specimens.empty()) root.fail("specimen", "at least one [[specimen]]", "none");
  root.done();
  return s;
}

}  // namespace burrbench::study
