#pragma once
// Strict reading of our TOML files: every getter names the key path in its InputError
// ("E.toml: recordings[1].registration.rotation: expected ..."), and done() rejects keys
// nobody asked for (unknown keys are errors in every burrbench format).
#include <cstdint>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <glm/glm.hpp>
#include <toml++/toml.h>

#include "burrbench/data_schema/provenance.hpp"
#include "burrbench/data_schema/toml_input.hpp"

namespace burrbench::data_schema::detail {

using data_schema::parse_toml_file;
using data_schema::parse_toml_text;

class TomlView {
 public:
  TomlView(const toml::table& t, std::string file, std::string path)
      : t_(&t), file_(std::move(file)), path_(std::move(path)) {}

  const std::string& file() const { return file_; }
  std::string field(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }
  bool has(const std::string& key) const { return t_->contains(key); }
  std::vector<std::string> keys() const;

  std::string str(const std::string& key);
  std::optional<std::string> opt_str(const std::string& key);
  double num(const std::string& key);  // integer or float, finite
  std::optional<double> opt_num(const std::string& key);
  double num_or_inf(const std::string& key);  // also +inf (TOML inf or the string "inf")
  std::int64_t integer(const std::string& key);
  bool boolean(const std::string& key);
  std::optional<bool> opt_boolean(const std::string& key);
  glm::dvec3 vec3(const std::string& key);
  glm::dmat3 mat3_rows(const std::string& key);  // [[r0],[r1],[r2]] → glm (column-major)
  std::vector<glm::dvec3> points(const std::string& key);
  TomlView table(const std::string& key);
  std::optional<TomlView> opt_table(const std::string& key);
  std::vector<TomlView> tables(const std::string& key);  // array of tables; absent → empty
  // Mark a key as consumed without reading it through this view.
  void use(const std::string& key) { used_.insert(key); }
  // InputError on the first key that no getter consumed.
  void done() const;

 private:
  const toml::node* get(const std::string& key, const char* expected);
  double number_node(const toml::node& n, const std::string& field, bool allow_inf) const;
  const toml::table* t_;
  std::string file_, path_;
  std::set<std::string> used_;
};

// [provenance] table: software_version, command_line, created_utc, inputs = [{path, sha256}].
toml::table provenance_to_toml(const Provenance& p);
Provenance provenance_from_toml(TomlView v);

}  // namespace burrbench::data_schema::detail
