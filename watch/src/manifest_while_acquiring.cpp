#include <toml++/toml.h>

#include <sstream>
#include <system_error>

#include "burrbench/watch/live_model.hpp"

namespace burrbench::watch {
namespace fs = std::filesystem;

data_schema::ExperimentManifest read_manifest_while_acquiring(const fs::path& manifest,
                                                              const std::string& recording_id) {
  toml::table t;
  try {
    t = toml::parse_file(manifest.string());
  } catch (const toml::parse_error&) {
    return data_schema::read_manifest(manifest);  // its message names the file and the line
  }
  // The session's own listing points at the manifest itself (a file that exists) while it
  // is parsed and validated; its real path is put back after.
  fs::path missing;
  if (auto* recs = t["recordings"].as_array())
    for (auto& node : *recs) {
      auto* r = node.as_table();
      if (!r || r->get_as<std::string>("id") == nullptr ||
          r->get_as<std::string>("id")->get() != recording_id || !r->get_as<std::string>("path"))
        continue;
      const fs::path p = r->get_as<std::string>("path")->get();
      const fs::path resolved = p.is_absolute() ? p : manifest.parent_path() / p;
      std::error_code ec;
      if (fs::exists(resolved, ec)) continue;
      missing = fs::absolute(resolved, ec);
      r->insert_or_assign("path", fs::absolute(manifest, ec).string());
    }
  if (missing.empty()) return data_schema::read_manifest(manifest);
  std::ostringstream text;
  text << t;
  data_schema::ExperimentManifest m = data_schema::parse_manifest(text.str(), manifest);
  for (auto& r : m.recordings)
    if (r.id == recording_id) r.path = missing;
  return m;
}

}  // namespace burrbench::watch
